// Introspection of a compiled graph: accessors, Graphviz DOT and a text dump.
module;
#include <array>
#include <cstdint>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <utility>
module weft.graph;
import weft.core;
import weft.gpu;
import :compiled_state;

namespace weft {

CompiledGraph::CompiledGraph(std::unique_ptr<detail::CompiledState> state) : state_(std::move(state)) {}
CompiledGraph::CompiledGraph(CompiledGraph&&) noexcept = default;
CompiledGraph& CompiledGraph::operator=(CompiledGraph&&) noexcept = default;

std::string_view CompiledGraph::name() const { return state_->graph->name; }
std::span<const std::uint32_t> CompiledGraph::order() const { return state_->order; }
std::span<const PassInfo> CompiledGraph::passes() const { return state_->passes; }
std::span<const ResourceInfo> CompiledGraph::resources() const { return state_->resources; }
const MemoryPlan& CompiledGraph::memory() const { return state_->memory; }
bool CompiledGraph::plan_reused() const { return state_->reused; }

std::optional<std::uint32_t> CompiledGraph::find_pass(std::string_view name) const {
  for (std::uint32_t p = 0; p < state_->pass_count; ++p)
    if (state_->passes[p].name == name) return p;
  return std::nullopt;
}

std::optional<std::uint32_t> CompiledGraph::find_resource(std::string_view name) const {
  for (std::uint32_t r = 0; r < state_->resource_count; ++r)
    if (state_->resources[r].name == name) return r;
  return std::nullopt;
}

bool CompiledGraph::culled(std::string_view pass_name) const {
  const auto p = find_pass(pass_name);
  return !p || state_->passes[*p].culled;
}

std::span<const PlannedBarrier> CompiledGraph::barriers_before(std::uint32_t pass) const {
  const detail::CompiledState& s = *state_;
  if (pass >= s.pass_count || s.passes[pass].culled) return {};
  const std::uint32_t pos = s.passes[pass].order_position;
  return std::span(s.barriers).subspan(s.barrier_begin[pos], s.barrier_begin[pos + 1] - s.barrier_begin[pos]);
}

std::span<const PlannedBarrier> CompiledGraph::final_barriers() const {
  const detail::CompiledState& s = *state_;
  const auto n = s.order.size();
  return std::span(s.barriers).subspan(s.barrier_begin[n], s.barrier_begin[n + 1] - s.barrier_begin[n]);
}

namespace {

constexpr std::array<std::string_view, 8> alias_palette{"#a6cee3", "#b2df8a", "#fb9a99", "#fdbf6f",
                                                        "#cab2d6", "#ffff99", "#8dd3c7", "#bebada"};

std::string use_list(std::uint16_t uses, ResourceType type) {
  std::string out;
  for (unsigned bit = 0; bit < 8; ++bit) {
    if (!(uses & (1u << bit))) continue;
    if (!out.empty()) out += "+";
    out += type == ResourceType::Texture ? to_string(TextureUse(bit)) : to_string(BufferUse(bit));
  }
  return out;
}

std::string describe_shape(const ResourceInfo& r) {
  if (r.type == ResourceType::Buffer) return weft::format("buffer {} B", r.buffer_size);
  return weft::format("{} {}", gpu::to_string(r.format), detail::format_extent(r.extent));
}

std::string bytes_text(std::uint64_t bytes) {
  if (bytes >= 1024ull * 1024) return weft::format("{:.1f} MiB", double(bytes) / (1024.0 * 1024.0));
  if (bytes >= 1024) return weft::format("{:.1f} KiB", double(bytes) / 1024.0);
  return weft::format("{} B", bytes);
}

}  // namespace

std::string CompiledGraph::to_dot() const {
  const detail::CompiledState& s = *state_;
  const detail::GraphData& g = *s.graph;
  std::string out = weft::format("digraph \"{}\" {{\n  rankdir=LR;\n  node [fontname=\"Helvetica\", fontsize=10];\n"
                                "  edge [fontname=\"Helvetica\", fontsize=9];\n",
                                g.name);
  for (std::uint32_t p = 0; p < s.pass_count; ++p) {
    const PassInfo& info = s.passes[p];
    if (info.culled)
      out += weft::format("  p{} [shape=box, style=\"filled,dashed\", fillcolor=\"#eeeeee\", fontcolor=\"#888888\", "
                         "label=\"{}\\n{}, culled\"];\n",
                         p, info.name, to_string(info.kind));
    else
      out += weft::format("  p{} [shape=box, style=filled, fillcolor=\"#cfe2f3\", label=\"{}\\n{} #{}\"];\n", p,
                         info.name, to_string(info.kind), info.order_position);
  }
  for (std::uint32_t r = 0; r < s.resource_count; ++r) {
    const ResourceInfo& info = s.resources[r];
    std::string label = weft::format("{}\\n{}", info.name, describe_shape(info));
    std::string_view fill = "#ffffff";
    if (info.imported) {
      label += "\\nimported";
      fill = "#fff2cc";
    } else if (!info.used) {
      label += "\\nunused";
      fill = "#eeeeee";
    } else if (info.alias_group != invalid_index) {
      label += weft::format("\\nalias group {}", info.alias_group);
      fill = alias_palette[info.alias_group % alias_palette.size()];
    }
    out += weft::format("  r{} [shape=ellipse, style=filled, fillcolor=\"{}\", label=\"{}\"];\n", r, fill, label);
  }
  for (std::uint32_t p = 0; p < s.pass_count; ++p) {
    const detail::PassNode& pass = g.passes[p];
    const std::string_view style = s.passes[p].culled ? ", style=dashed, color=\"#888888\"" : "";
    for (std::uint32_t i = pass.first_access, end = pass.first_access + pass.access_count; i < end; ++i) {
      const detail::AccessNode& a = g.accesses[i];
      const std::string uses = use_list(a.uses, g.resources[a.resource].type);
      if (a.reads) out += weft::format("  r{} -> p{} [label=\"{}\"{}];\n", a.resource, p, uses, style);
      if (a.writes()) out += weft::format("  p{} -> r{} [label=\"{}\"{}];\n", p, a.resource, uses, style);
    }
  }
  out += "}\n";
  return out;
}

std::string CompiledGraph::dump() const {
  const detail::CompiledState& s = *state_;
  const detail::GraphData& g = *s.graph;
  auto resource = [&](std::uint32_t r) { return std::string(g.resources[r].name); };
  std::string out = weft::format("render graph '{}': {} passes ({} culled), {} resources\norder:\n", g.name,
                                s.pass_count, s.pass_count - s.order.size(), s.resource_count);
  auto barrier_line = [&](const PlannedBarrier& b) {
    const bool part = b.range != TextureRange{};
    auto range_of = [&](std::uint32_t r) {
      const ResourceInfo& info = s.resources[r];
      const std::uint32_t layers = info.dimension == gpu::TextureDimension::D3 ? 1 : info.extent.depth_or_layers;
      return gpu::describe(b.range, info.mip_level_count, layers);
    };
    std::string line = weft::format("      barrier {}{}: {} -> {}", resource(b.resource),
                                   part && b.previous_occupant == invalid_index ? ", " + range_of(b.resource) : "",
                                   gpu::to_string(b.before), gpu::to_string(b.after));
    if (b.previous_occupant != invalid_index)
      line += b.occupant_before == b.occupant_after
                  ? weft::format(" (takes over memory of {})", resource(b.previous_occupant))
                  : weft::format(" (takes over memory of {}{}, moved {} -> {})", resource(b.previous_occupant),
                                 part ? ", " + range_of(b.previous_occupant) : "", gpu::to_string(b.occupant_before),
                                 gpu::to_string(b.occupant_after));
    return line + "\n";
  };
  for (std::uint32_t pos = 0; pos < s.order.size(); ++pos) {
    const std::uint32_t p = s.order[pos];
    out += weft::format("  {}. {} ({}{})\n", pos, s.passes[p].name, to_string(s.passes[p].kind),
                       s.passes[p].side_effect ? ", side effect" : "");
    for (std::uint32_t b = s.barrier_begin[pos]; b < s.barrier_begin[pos + 1]; ++b) out += barrier_line(s.barriers[b]);
  }
  const auto n = s.order.size();
  if (s.barrier_begin[n] < s.barrier_begin[n + 1]) {
    out += "  end of frame\n";
    for (std::uint32_t b = s.barrier_begin[n]; b < s.barrier_begin[n + 1]; ++b) out += barrier_line(s.barriers[b]);
  }
  std::string culled;
  for (std::uint32_t p = 0; p < s.pass_count; ++p)
    if (s.passes[p].culled) culled += weft::format("{}{}", culled.empty() ? "" : ", ", s.passes[p].name);
  if (!culled.empty()) out += "culled: " + culled + "\n";
  out += "resources:\n";
  for (std::uint32_t r = 0; r < s.resource_count; ++r) {
    const ResourceInfo& info = s.resources[r];
    out += weft::format("  {} ({}{})", info.name, describe_shape(info), info.imported ? ", imported" : "");
    if (!info.used) {
      out += ": unused\n";
      continue;
    }
    out += weft::format(": used {}..{}", info.first_use, info.last_use);
    if (info.heap != invalid_index)
      out += weft::format(", heap {} @ {} ({})", info.heap, info.offset, bytes_text(info.bytes));
    if (info.alias_group != invalid_index) out += weft::format(", alias group {}", info.alias_group);
    out += "\n";
  }
  out += weft::format("memory: {} heap{}, {} with aliasing, {} without{}\n", s.memory.heaps.size(),
                     s.memory.heaps.size() == 1 ? "" : "s", bytes_text(s.memory.aliased_bytes),
                     bytes_text(s.memory.unaliased_bytes), s.memory.from_device ? "" : " (estimated)");
  return out;
}

}  // namespace weft
