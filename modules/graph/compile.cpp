// compile(), part 1: validate every declaration, cull passes that reach no output, and order
// the rest. Every step is linear in passes + accesses: each access contributes at most two
// ordering edges (its version's producer before it; it before the version's next writer).
module;
#include <algorithm>
#include <array>
#include <atomic>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <expected>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <numeric>
#include <queue>
#include <string>
#include <string_view>
#include <tuple>
#include <utility>
#include <vector>
module weft.graph;
import weft.core;
import weft.gpu;
import :compiled_state;

namespace weft::detail {

namespace {

constexpr std::uint16_t attachment_uses = use_bit(TextureUse::ColorAttachment) |
                                          use_bit(TextureUse::DepthAttachment) | use_bit(TextureUse::DepthRead);
constexpr std::uint16_t draw_buffer_uses = use_bit(BufferUse::Vertex) | use_bit(BufferUse::Index);
constexpr std::uint16_t texture_copy_uses = use_bit(TextureUse::CopySrc) | use_bit(TextureUse::CopyDst);
constexpr std::uint16_t buffer_copy_uses = use_bit(BufferUse::CopySrc) | use_bit(BufferUse::CopyDst);

// The gpu usage of every combination of use bits, tabulated once: compile asks per resource.
template <class Use, class Usage>
constexpr std::array<Usage, 256> usage_table() {
  std::array<Usage, 256> table{};
  for (unsigned uses = 0; uses < 256; ++uses)
    for (unsigned bit = 0; bit < 8; ++bit)
      if (uses & (1u << bit)) table[uses] = Usage(std::uint32_t(table[uses]) | std::uint32_t(usage_of(Use(bit))));
  return table;
}
constexpr auto texture_usages = usage_table<TextureUse, gpu::TextureUsage>();
constexpr auto buffer_usages = usage_table<BufferUse, gpu::BufferUsage>();

gpu::TextureUsage texture_usage_of(std::uint16_t uses) { return texture_usages[uses & 0xffu]; }
gpu::BufferUsage buffer_usage_of(std::uint16_t uses) { return buffer_usages[uses & 0xffu]; }

// The usage bits `format` can never take, from gpu::forbidden_usages, computed once per
// format (the messages are built only when a texture uses one).
std::uint32_t forbidden_mask(gpu::Format format) {
  constexpr std::uint32_t known = 0x8000'0000u;
  static std::array<std::atomic<std::uint32_t>, 256> cache{};  // racing threads compute the same value
  std::atomic<std::uint32_t>& entry = cache[std::size_t(format)];
  std::uint32_t mask = entry.load(std::memory_order_relaxed);
  if (mask & known) return mask & ~known;
  mask = 0;
  for (std::uint32_t bit = 1; bit <= std::uint32_t(gpu::TextureUsage::DepthAttachment); bit <<= 1)
    if (!gpu::forbidden_usages(format, gpu::TextureUsage(bit)).empty()) mask |= bit;
  entry.store(mask | known, std::memory_order_relaxed);
  return mask;
}

// The usage a texture needs to be put in `state` (an output's final state).
gpu::TextureUsage usage_for_state(gpu::Access state) {
  using A = gpu::Access;
  using U = gpu::TextureUsage;
  switch (state) {
    case A::CopySrc: return U::CopySrc;
    case A::CopyDst: return U::CopyDst;
    case A::ShaderRead: return U::Sampled;
    case A::StorageRead:
    case A::StorageWrite: return U::Storage;
    case A::ColorAttachment: return U::ColorAttachment;
    case A::DepthAttachment:
    case A::DepthRead: return U::DepthAttachment;
    default: return U::None;
  }
}

struct Edge {
  std::uint32_t to;
  std::uint32_t resource;  // the resource that orders the two passes (named in cycle errors)
  std::uint32_t version = 0;  // the version `from` reads, for an edge to the pass overwriting it
  bool overwrite = false;  // `to` writes the next version of what `from` reads (not: `from` produced it)
};

class Scheduler {
 public:
  Scheduler(const GraphData& g, CompiledState& s, std::vector<GraphError>& errors)
      : g_(g), s_(s), errors_(errors), alive_(s.scratch.alive), last_pass_(s.scratch.last_pass) {}

  // The errors come in a stable order: descriptors, unwritten reads, pass kinds, outputs,
  // cycles, usages, attachment sizes.
  void run() {
    const std::uint32_t P = s_.pass_count, R = s_.resource_count;
    alive_.assign(P, 0);
    last_pass_.assign(R, invalid_index);
    s_.resource_final_state.assign(R, gpu::Access::Undefined);
    std::vector<GraphError> output_errors, usage_errors;  // allocate only when there are errors
    mark_outputs(output_errors);
    init_resources(usage_errors);
    if (g_.maybe_unwritten_read) report_unwritten_reads();
    init_passes();
    move_errors(output_errors);
    s_.order.clear();
    s_.order.reserve(P);
    if (!g_.backward_edges && all_used_) {
      // Every pass is a root or used by a later one: walking back from the last pass (a root,
      // as nothing comes after it), every pass is needed. Nothing to cull, declaration order
      // is the order, and each resource's last user is the last pass that declared it.
      s_.order.resize(P);
      std::iota(s_.order.begin(), s_.order.end(), 0u);
      for (std::uint32_t r = 0; r < s_.resource_count; ++r)
        if (last_pass_[r] == invalid_index) last_pass_[r] = g_.resources[r].last_pass;
    } else if (!g_.backward_edges) {
      cull_in_declaration_order();
    } else {
      cull_from_roots();
      ordered_by_edges();
      for (std::uint32_t p = 0; p < P; ++p) s_.passes[p].culled = !alive_[p];
      for (std::uint32_t i = std::uint32_t(s_.order.size()); i-- > 0;) note_last_uses(s_.order[i]);
    }
    move_errors(usage_errors);
    check_attachments();
    if (g_.multisampled) check_sample_counts();
  }

 private:
  const GraphData& g_;
  CompiledState& s_;
  std::vector<GraphError>& errors_;
  std::vector<std::uint8_t>& alive_;
  std::vector<std::uint32_t>& last_pass_;
  bool all_used_ = true;  // every pass is a root of culling or used by a later pass

  void error(GraphErrorKind kind, std::string message, std::vector<std::string> passes,
             std::vector<std::string> resources) {
    errors_.push_back(GraphError{kind, std::move(message), std::move(passes), std::move(resources)});
  }
  void move_errors(std::vector<GraphError>& errors) {
    for (GraphError& e : errors) errors_.push_back(std::move(e));
  }

  [[nodiscard]] std::string pass_name(std::uint32_t p) const { return std::string(g_.passes[p].name); }
  [[nodiscard]] std::string resource_name(std::uint32_t r) const { return std::string(g_.resources[r].name); }

  // Outputs: their producers are roots of culling, their final states are recorded, and
  // their memory is kept to the end of the frame (they are read after it).
  void mark_outputs(std::vector<GraphError>& output_errors) {
    const std::uint32_t P = s_.pass_count;
    for (const OutputNode& out : g_.outputs) {
      if (out.resource >= s_.resource_count) continue;
      const std::uint32_t slot = g_.find_slot(out.resource, out.version);
      if (slot == invalid_index || g_.versions[slot].producer == invalid_index || g_.versions[slot].producer >= P) {
        output_errors.push_back(GraphError{
            GraphErrorKind::OutputNeverWritten,
            weft::format("output {} (version {}) is never written by any pass", g_.describe(out.resource), out.version),
            {},
            {resource_name(out.resource)}});
        continue;
      }
      alive_[g_.versions[slot].producer] = 1;
      s_.resource_final_state[out.resource] = out.final_state;
      last_pass_[out.resource] = kept_to_end;
    }
  }

  // Resolved descriptors and gpu usages of every resource, the usage checks, and the state
  // each resource starts the frame in.
  void init_resources(std::vector<GraphError>& usage_errors) {
    const std::uint32_t R = s_.resource_count;
    s_.resources.clear();
    s_.resources.reserve(R);
    std::vector<gpu::Access>& current = s_.scratch.current;
    current.resize(R);
    const gpu::Extent3D output = s_.options.output_extent;
    const bool have_output = output.width > 0 && output.height > 0;
    RelativeSize last_relative{};
    gpu::Extent3D last_resolved{};
    bool have_last_relative = false;
    struct CleanUsage {
      gpu::Format format;
      std::uint16_t uses;
      gpu::TextureUsage extra_usage;
      gpu::Access final_state;
      gpu::TextureUsage usage;
    } clean{};
    bool have_clean = false;
    for (std::uint32_t r = 0; r < R; ++r) {
      const ResourceNode& node = g_.resources[r];
      ResourceInfo& info = s_.resources.emplace_back();
      info.name = node.name;
      info.type = node.type;
      info.imported = node.imported;
      current[r] = node.imported ? node.initial_state : gpu::Access::Undefined;
      if (node.type == ResourceType::Texture) {
        const TextureDesc& d = node.texture_desc;
        if (d.size.is_relative) {
          if (!have_output) {
            error(GraphErrorKind::InvalidDescriptor,
                  weft::format("texture '{}' has a size relative to the output, but CompileOptions::output_extent "
                               "is not set",
                               node.name),
                  node.creator != invalid_index ? std::vector<std::string>{pass_name(node.creator)}
                                                : std::vector<std::string>{},
                  {resource_name(r)});
          }
          // Most relative sizes repeat (full-screen targets): resolve each once in a row.
          if (!have_last_relative || d.size.relative.width != last_relative.width ||
              d.size.relative.height != last_relative.height) {
            last_relative = d.size.relative;
            last_resolved = d.size.resolve(have_output ? output : gpu::Extent3D{1, 1, 1});
            have_last_relative = true;
          }
          info.extent = last_resolved;
        } else {
          info.extent = d.size.absolute;
          info.extent.depth_or_layers = std::max(1u, d.size.absolute.depth_or_layers);
        }
        info.format = d.format;
        info.mip_level_count = d.mip_level_count;
        info.dimension = d.dimension;
        info.sample_count = d.sample_count;
        info.texture_usage = d.extra_usage | texture_usage_of(node.uses);
        if (node.uses != 0) {
          // Transients repeat (format, uses, final state): one that checked clean before
          // gets the same usage again without the checks.
          const gpu::Access final_state = s_.resource_final_state[r];
          if (!node.imported && have_clean && d.format == clean.format && node.uses == clean.uses &&
              d.extra_usage == clean.extra_usage && final_state == clean.final_state) {
            info.texture_usage = clean.usage;
          } else {
            const std::size_t errors_before = usage_errors.size();
            check_texture_usage(r, node, info, usage_errors);
            have_clean = !node.imported && usage_errors.size() == errors_before;
            if (have_clean) clean = {d.format, node.uses, d.extra_usage, final_state, info.texture_usage};
          }
        }
      } else {
        info.buffer_size = node.buffer_desc.size;
        info.buffer_usage = node.buffer_desc.extra_usage | buffer_usage_of(node.uses);
        if (node.uses != 0 && node.imported && node.imported_buffer_usage != gpu::BufferUsage::None)
          check_import_usage<BufferUse>(r, node.uses, node.imported_buffer_usage, "buffer", node.name, usage_errors);
      }
    }
  }

  void check_texture_usage(std::uint32_t r, const ResourceNode& node, ResourceInfo& info,
                           std::vector<GraphError>& usage_errors) {
    const std::uint16_t uses = node.uses;
    const gpu::TextureUsage final_usage = usage_for_state(s_.resource_final_state[r]);
    if (!node.imported) {
      info.texture_usage = info.texture_usage | final_usage;
      // weft.gpu gives every texture a view, which Vulkan allows only with a usage a view
      // can serve; a copy-only transient gets Sampled.
      using U = gpu::TextureUsage;
      if (!gpu::any(info.texture_usage & (U::Sampled | U::Storage | U::ColorAttachment | U::DepthAttachment)))
        info.texture_usage = info.texture_usage | U::Sampled;
    } else if (node.imported_texture_usage != gpu::TextureUsage::None && gpu::any(final_usage) &&
               !gpu::has(node.imported_texture_usage, final_usage)) {
      usage_errors.push_back(GraphError{
          GraphErrorKind::MissingUsage,
          weft::format("output texture '{}' is to be left in state {}, but it was created without {} usage (it has {})",
                       node.name, gpu::to_string(s_.resource_final_state[r]), gpu::to_string(final_usage),
                       gpu::to_string(node.imported_texture_usage)),
          {},
          {resource_name(r)}});
    }
    // A storage texture whose memory is taken over leaves GENERAL through a layout that
    // needs Sampled (see release_state()).
    const std::uint32_t forbidden = forbidden_mask(info.format);
    if (!node.imported && gpu::has(info.texture_usage, gpu::TextureUsage::Storage) &&
        !(forbidden & std::uint32_t(gpu::TextureUsage::Sampled)))
      info.texture_usage = info.texture_usage | gpu::TextureUsage::Sampled;
    if (forbidden & std::uint32_t(texture_usage_of(uses))) {
      for (unsigned bit = 0; bit < 8; ++bit) {
        if (!(uses & (1u << bit))) continue;
        const auto use = TextureUse(bit);
        std::string bad = gpu::forbidden_usages(info.format, usage_of(use));
        if (bad.empty()) continue;
        const auto users = passes_using(r, std::uint16_t(1u << bit));
        usage_errors.push_back(
            GraphError{GraphErrorKind::UnsupportedUsage,
                       weft::format("pass '{}': uses texture '{}' ({}) as {}, which the format cannot take ({})",
                                    users.front(), node.name, gpu::to_string(info.format), to_string(use), bad),
                       users,
                       {resource_name(r)}});
      }
    }
    if (node.imported && node.imported_texture_usage != gpu::TextureUsage::None)
      check_import_usage<TextureUse>(r, node.uses, node.imported_texture_usage, "texture", node.name, usage_errors);
  }

  // An import created with a known usage: each use it lacks is an error naming its passes.
  template <class Use, class Usage>
  void check_import_usage(std::uint32_t r, std::uint16_t uses, Usage has, std::string_view kind, std::string_view name,
                          std::vector<GraphError>& usage_errors) {
    for (unsigned bit = 0; bit < 8; ++bit) {
      if (!(uses & (1u << bit))) continue;
      const std::uint32_t missing = std::uint32_t(usage_of(Use(bit))) & ~std::uint32_t(has);
      if (missing == 0) continue;
      const auto users = passes_using(r, std::uint16_t(1u << bit));
      usage_errors.push_back(GraphError{
          GraphErrorKind::MissingUsage,
          weft::format("pass '{}': uses imported {} '{}' as {}, but it was created without {} usage (it has {})",
                       users.front(), kind, name, to_string(Use(bit)), gpu::to_string(Usage(missing)),
                       gpu::to_string(has)),
          users,
          {resource_name(r)}});
    }
  }

  // Only when setup saw a read of a version no pass produced (it may be an imported one).
  void report_unwritten_reads() {
    for (std::uint32_t p = 0; p < s_.pass_count; ++p) {
      const PassNode& pass = g_.passes[p];
      for (std::uint32_t i = pass.first_access, end = pass.first_access + pass.access_count; i < end; ++i) {
        const AccessNode& a = g_.accesses[i];
        const VersionNode& v = g_.versions[a.slot];
        if (a.reads && v.producer == invalid_index && !(a.imported && v.version == 0)) {
          error(GraphErrorKind::UnwrittenRead,
                weft::format("pass '{}': reads {} (version {}), which no pass writes and nothing imports", pass.name,
                             g_.describe(a.resource), v.version),
                {pass_name(p)}, {resource_name(a.resource)});
        }
      }
    }
  }

  // Pass records with their kinds (declared, or inferred from the uses setup collected), and
  // the roots of culling: side effects and writers of imported resources.
  void init_passes() {
    const std::uint32_t P = s_.pass_count;
    s_.passes.resize(P);
    for (std::uint32_t p = 0; p < P; ++p) {
      const PassNode& pass = g_.passes[p];
      const std::uint16_t tex = pass.texture_uses, buf = pass.buffer_uses;
      PassKind inferred = PassKind::Compute;
      if ((tex & attachment_uses) || (buf & draw_buffer_uses)) inferred = PassKind::Render;
      else if ((tex | buf) != 0 && (tex & ~texture_copy_uses) == 0 && (buf & ~buffer_copy_uses) == 0)
        inferred = PassKind::Transfer;
      PassInfo& info = s_.passes[p];
      info.name = pass.name;
      info.kind_declared = pass.kind_declared;
      info.side_effect = pass.side_effect;
      info.kind = pass.kind_declared ? pass.declared_kind : inferred;
      info.culled = false;
      info.order_position = invalid_index;
      if (pass.side_effect || pass.writes_import) alive_[p] = 1;
      all_used_ = all_used_ && (alive_[p] || pass.consumed);
      if (pass.kind_declared && pass.declared_kind != PassKind::Render && pass.declared_kind != inferred)
        check_declared_kind(p);
    }
  }

  void check_declared_kind(std::uint32_t p) {
    const PassNode& pass = g_.passes[p];
    const std::uint16_t tex = pass.texture_uses, buf = pass.buffer_uses;
    // A declared compute or transfer pass must not use what only render passes can.
    const bool render_only = (tex & attachment_uses) || (buf & draw_buffer_uses);
    const bool non_copy = (tex & ~texture_copy_uses) || (buf & ~buffer_copy_uses);
    if (!render_only && !(pass.declared_kind == PassKind::Transfer && non_copy)) return;
    for (std::uint32_t i = pass.first_access, end = pass.first_access + pass.access_count; i < end; ++i) {
      const AccessNode& a = g_.accesses[i];
      const bool texture = a.texture;
      const std::uint16_t bad = texture ? (pass.declared_kind == PassKind::Transfer ? a.uses & ~texture_copy_uses
                                                                                    : a.uses & attachment_uses)
                                        : (pass.declared_kind == PassKind::Transfer ? a.uses & ~buffer_copy_uses
                                                                                    : a.uses & draw_buffer_uses);
      if (!bad) continue;
      unsigned bit = 0;
      while (!(bad & (1u << bit))) ++bit;
      error(GraphErrorKind::WrongPassKind,
            weft::format("pass '{}' is declared {} but uses {} as {}", pass.name, to_string(pass.declared_kind),
                         g_.describe(a.resource), texture ? to_string(TextureUse(bit)) : to_string(BufferUse(bit))),
            {pass_name(p)}, {resource_name(a.resource)});
      return;
    }
  }

  // Declaration order is a valid order (setup saw no read of a version an earlier pass had
  // already overwritten), so every producer comes before its readers: one backward sweep
  // keeps what the roots need and finds each resource's last use, one forward sweep orders.
  void cull_in_declaration_order() {
    const std::uint32_t P = s_.pass_count;
    for (std::uint32_t p = P; p-- > 0;) {
      if (!alive_[p]) {
        s_.passes[p].culled = true;
        continue;
      }
      const PassNode& pass = g_.passes[p];
      // A write depends on the version it starts from too: the pass may load or blend.
      for (std::uint32_t i = pass.first_access, end = pass.first_access + pass.access_count; i < end; ++i) {
        const AccessNode& a = g_.accesses[i];
        const std::uint32_t producer = g_.versions[a.slot].producer;
        if (producer != invalid_index) alive_[producer] = 1;  // producer < p: visited later
        if (last_pass_[a.resource] == invalid_index) last_pass_[a.resource] = p;
      }
    }
    for (std::uint32_t p = 0; p < P; ++p)
      if (alive_[p]) s_.order.push_back(p);
  }

  // Any order: keeps the roots (marked alive) and everything they need, depth first.
  void cull_from_roots() {
    const std::uint32_t P = s_.pass_count;
    std::vector<std::uint32_t>& stack = s_.scratch.stack;
    stack.clear();
    for (std::uint32_t p = 0; p < P; ++p)
      if (alive_[p]) stack.push_back(p);
    while (!stack.empty()) {
      const std::uint32_t p = stack.back();
      stack.pop_back();
      const PassNode& pass = g_.passes[p];
      for (std::uint32_t i = pass.first_access, end = pass.first_access + pass.access_count; i < end; ++i) {
        const std::uint32_t producer = g_.versions[g_.accesses[i].slot].producer;
        if (producer != invalid_index && producer < P && !alive_[producer]) {
          alive_[producer] = 1;
          stack.push_back(producer);
        }
      }
    }
  }

  // Walking the order backwards: the first pass seen using a resource is its last user.
  void note_last_uses(std::uint32_t p) {
    const PassNode& pass = g_.passes[p];
    for (std::uint32_t i = pass.first_access, end = pass.first_access + pass.access_count; i < end; ++i) {
      const std::uint32_t r = g_.accesses[i].resource;
      if (last_pass_[r] == invalid_index) last_pass_[r] = p;
    }
  }

  // The size an attachment renders at: its texture's, at the mip its range starts with.
  [[nodiscard]] gpu::Extent3D attachment_extent(const AccessNode& a) const {
    const gpu::Extent3D e = s_.resources[a.resource].extent;
    const std::uint32_t mip = g_.ranges[a.range].base_mip;
    return {std::max(1u, e.width >> mip), std::max(1u, e.height >> mip), 1};
  }

  [[nodiscard]] bool attachments_mismatch(std::uint32_t p) const {
    const PassNode& pass = g_.passes[p];
    const AccessNode* first = nullptr;
    bool differ = false;
    for (std::uint32_t i = pass.first_access, end = pass.first_access + pass.access_count; i < end; ++i) {
      const AccessNode& a = g_.accesses[i];
      if (!a.texture || !(a.uses & attachment_uses)) continue;
      if (!first) {
        first = &a;
        continue;
      }
      const gpu::Extent3D x = attachment_extent(*first), y = attachment_extent(a);
      differ = differ || x.width != y.width || x.height != y.height;
    }
    return differ;
  }

  // Kahn's algorithm over every pass (so cycles among culled passes are reported too), the
  // lowest declaration index first among ready passes: a deterministic order.
  void ordered_by_edges() {
    const std::uint32_t P = s_.pass_count;
    std::vector<std::uint32_t> begin(P + 1, 0);
    std::vector<std::pair<std::uint32_t, Edge>> subresource_edges;
    if (g_.subresources) subresource_edges = edges_of_subresources();
    auto for_each_edge = [&](auto&& emit) {
      for (const auto& [from, edge] : subresource_edges) emit(from, edge.to, edge);
      for (std::uint32_t p = 0; p < P; ++p) {
        const PassNode& pass = g_.passes[p];
        for (std::uint32_t i = pass.first_access, end = pass.first_access + pass.access_count; i < end; ++i) {
          const AccessNode& a = g_.accesses[i];
          if (g_.subresources && g_.resources[a.resource].ranged) continue;  // edges_of_subresources()
          const VersionNode& v = g_.versions[a.slot];
          if (v.producer != invalid_index && v.producer != p) emit(v.producer, p, Edge{p, a.resource});
          if (a.reads && v.next_writer != invalid_index && v.next_writer != p)
            emit(p, v.next_writer, Edge{v.next_writer, a.resource, v.version, true});
        }
      }
    };
    for_each_edge([&](std::uint32_t from, std::uint32_t, const Edge&) { ++begin[from + 1]; });
    for (std::uint32_t p = 0; p < P; ++p) begin[p + 1] += begin[p];
    std::vector<Edge> edges(begin[P]);
    std::vector<std::uint32_t> fill(begin.begin(), begin.end() - 1);
    std::vector<std::uint32_t> indegree(P, 0);
    for_each_edge([&](std::uint32_t from, std::uint32_t to, const Edge& edge) {
      edges[fill[from]++] = edge;
      ++indegree[to];
    });

    std::priority_queue<std::uint32_t, std::vector<std::uint32_t>, std::greater<>> ready;
    for (std::uint32_t p = 0; p < P; ++p)
      if (indegree[p] == 0) ready.push(p);
    std::uint32_t placed = 0;
    while (!ready.empty()) {
      const std::uint32_t p = ready.top();
      ready.pop();
      ++placed;
      if (alive_[p]) s_.order.push_back(p);
      for (std::uint32_t e = begin[p]; e < begin[p + 1]; ++e)
        if (--indegree[edges[e].to] == 0) ready.push(edges[e].to);
    }
    if (placed < P) report_cycles(begin, edges, indegree);
  }

  // The ordering edges of textures used in parts, mip by mip and layer by layer: a read waits
  // for the last write of each subresource it reads, a write for the reads and the write of
  // each subresource before it -- so passes that use different faces or mips of one texture
  // are not ordered by it. Versions are a texture's program order: the accesses are visited
  // version by version, the writes that made a version before the reads of it.
  [[nodiscard]] std::vector<std::pair<std::uint32_t, Edge>> edges_of_subresources() const {
    std::vector<std::pair<std::uint32_t, Edge>> out;
    struct Event {
      std::uint32_t version, order, pass, access;  // order: 0 = a write making `version`, 1 = a read of it
    };
    std::vector<std::vector<Event>> events(s_.resource_count);
    for (std::uint32_t p = 0; p < s_.pass_count; ++p) {
      const PassNode& pass = g_.passes[p];
      for (std::uint32_t i = pass.first_access, end = pass.first_access + pass.access_count; i < end; ++i) {
        const AccessNode& a = g_.accesses[i];
        if (!g_.resources[a.resource].ranged) continue;
        if (a.writes()) events[a.resource].push_back({g_.versions[a.out_slot].version, 0, p, i});
        else events[a.resource].push_back({g_.versions[a.slot].version, 1, p, i});
      }
    }
    std::vector<std::uint32_t> last_writer;
    std::vector<std::vector<std::uint32_t>> readers;
    for (std::uint32_t r = 0; r < s_.resource_count; ++r) {
      std::vector<Event>& list = events[r];
      if (list.empty()) continue;
      std::sort(list.begin(), list.end(), [](const Event& x, const Event& y) {
        return std::tie(x.version, x.order, x.access) < std::tie(y.version, y.order, y.access);
      });
      const TextureDesc& desc = g_.resources[r].texture_desc;
      const std::uint32_t mips = desc.mip_level_count, layers = declared_layers(desc);
      last_writer.assign(std::size_t(mips) * layers, invalid_index);
      readers.assign(std::size_t(mips) * layers, {});
      for (const Event& e : list) {
        const TextureRange& range = g_.ranges[g_.accesses[e.access].range];
        const std::uint32_t m_end = range.base_mip + range.mips_of(mips), l_end = range.base_layer + range.layers_of(layers);
        for (std::uint32_t m = range.base_mip; m < m_end; ++m) {
          for (std::uint32_t l = range.base_layer; l < l_end; ++l) {
            const std::size_t sub = std::size_t(m) * layers + l;
            const std::uint32_t writer = last_writer[sub];
            if (writer != invalid_index && writer != e.pass) out.push_back({writer, Edge{e.pass, r}});
            if (e.order == 1) {
              if (std::find(readers[sub].begin(), readers[sub].end(), e.pass) == readers[sub].end())
                readers[sub].push_back(e.pass);
              continue;
            }
            for (std::uint32_t reader : readers[sub])
              if (reader != e.pass) out.push_back({reader, Edge{e.pass, r, e.version - 1, true}});
            readers[sub].clear();
            last_writer[sub] = e.pass;
          }
        }
      }
    }
    // One edge per pair and resource is enough for Kahn's algorithm and the cycle report.
    std::sort(out.begin(), out.end(), [](const auto& x, const auto& y) {
      return std::tie(x.first, x.second.to, x.second.resource, x.second.overwrite) <
             std::tie(y.first, y.second.to, y.second.resource, y.second.overwrite);
    });
    out.erase(std::unique(out.begin(), out.end(),
                          [](const auto& x, const auto& y) {
                            return x.first == y.first && x.second.to == y.second.to &&
                                   x.second.resource == y.second.resource && x.second.overwrite == y.second.overwrite;
                          }),
              out.end());
    return out;
  }

  // One error per strongly connected component left over: the shortest cycle through its
  // first-declared pass, naming every pass in order and the resources that link them.
  void report_cycles(const std::vector<std::uint32_t>& begin, const std::vector<Edge>& edges,
                     const std::vector<std::uint32_t>& indegree) {
    const std::uint32_t P = s_.pass_count;
    // Tarjan's SCC over the passes Kahn could not place (iterative).
    std::vector<std::uint32_t> index(P, invalid_index), low(P, 0), component(P, invalid_index);
    std::vector<std::uint8_t> on_stack(P, 0);
    std::vector<std::uint32_t> stack;
    std::vector<std::pair<std::uint32_t, std::uint32_t>> call;  // (node, next edge)
    std::uint32_t counter = 0, components = 0;
    auto remaining = [&](std::uint32_t p) { return indegree[p] > 0; };
    for (std::uint32_t root = 0; root < P; ++root) {
      if (!remaining(root) || index[root] != invalid_index) continue;
      call.push_back({root, begin[root]});
      index[root] = low[root] = counter++;
      stack.push_back(root);
      on_stack[root] = 1;
      while (!call.empty()) {
        auto& [v, e] = call.back();
        if (e < begin[v + 1]) {
          const std::uint32_t w = edges[e++].to;
          if (!remaining(w)) continue;
          if (index[w] == invalid_index) {
            index[w] = low[w] = counter++;
            stack.push_back(w);
            on_stack[w] = 1;
            call.push_back({w, begin[w]});
          } else if (on_stack[w]) {
            low[v] = std::min(low[v], index[w]);
          }
          continue;
        }
        const std::uint32_t done = v;
        call.pop_back();
        if (!call.empty()) low[call.back().first] = std::min(low[call.back().first], low[done]);
        if (low[done] == index[done]) {
          std::uint32_t w;
          do {
            w = stack.back();
            stack.pop_back();
            on_stack[w] = 0;
            component[w] = components;
          } while (w != done);
          ++components;
        }
      }
    }
    std::vector<std::uint8_t> reported(components, 0);
    std::vector<std::uint32_t> parent(P, invalid_index);
    for (std::uint32_t start = 0; start < P; ++start) {
      if (!remaining(start) || reported[component[start]]) continue;
      const std::uint32_t c = component[start];
      // Breadth-first from `start` inside its component until an edge returns to `start`.
      std::vector<std::uint32_t> queue{start};
      std::vector<std::uint32_t> touched{start};
      parent[start] = start;
      std::uint32_t last = invalid_index;
      for (std::size_t head = 0; head < queue.size() && last == invalid_index; ++head) {
        const std::uint32_t v = queue[head];
        for (std::uint32_t e = begin[v]; e < begin[v + 1]; ++e) {
          const std::uint32_t w = edges[e].to;
          if (!remaining(w) || component[w] != c) continue;
          if (w == start) {
            last = v;
            break;
          }
          if (parent[w] != invalid_index) continue;
          parent[w] = v;
          queue.push_back(w);
          touched.push_back(w);
        }
      }
      std::vector<std::uint32_t> cycle;
      if (last != invalid_index) {
        for (std::uint32_t v = last; v != start; v = parent[v]) cycle.push_back(v);
        cycle.push_back(start);
        std::reverse(cycle.begin(), cycle.end());
      }
      for (std::uint32_t t : touched) parent[t] = invalid_index;
      if (cycle.size() < 2) continue;  // a single pass: not a cycle
      reported[c] = 1;
      emit_cycle(cycle, begin, edges);
    }
  }

  void emit_cycle(const std::vector<std::uint32_t>& cycle, const std::vector<std::uint32_t>& begin,
                  const std::vector<Edge>& edges) {
    std::string message = "cycle: ";
    std::vector<std::string> passes, resources;
    for (std::uint32_t p : cycle) {
      message += weft::format("'{}' -> ", g_.passes[p].name);
      passes.push_back(pass_name(p));
    }
    message += weft::format("'{}' through ", g_.passes[cycle.front()].name);
    // An edge to the pass that overwrites what its source reads is usually a stale handle
    // (the handle of an older version kept after a later write): said, with the edge.
    std::string stale;
    for (std::size_t i = 0; i < cycle.size(); ++i) {
      const std::uint32_t from = cycle[i], to = cycle[(i + 1) % cycle.size()];
      const Edge* chosen = nullptr;
      for (std::uint32_t e = begin[from]; e < begin[from + 1]; ++e) {
        if (edges[e].to != to) continue;
        if (!chosen || (chosen->overwrite && !edges[e].overwrite)) chosen = &edges[e];
      }
      if (!chosen) continue;
      std::string name = resource_name(chosen->resource);
      if (std::find(resources.begin(), resources.end(), name) == resources.end()) resources.push_back(name);
      if (chosen->overwrite)
        stale += weft::format("; '{}' reads version {} of {}, which '{}' overwrites, so it must run first -- if it "
                              "should see '{}''s result, it holds a stale handle: read the one that write() returned",
                              g_.passes[from].name, chosen->version, g_.describe(chosen->resource), g_.passes[to].name,
                              g_.passes[to].name);
    }
    for (std::size_t i = 0; i < resources.size(); ++i) message += weft::format("{}'{}'", i ? ", " : "", resources[i]);
    message += stale;
    error(GraphErrorKind::Cycle, std::move(message), std::move(passes), std::move(resources));
  }

  // Runs only on the error path.
  [[nodiscard]] std::vector<std::string> passes_using(std::uint32_t resource, std::uint16_t uses) const {
    std::vector<std::string> out;
    for (std::uint32_t p = 0; p < s_.pass_count; ++p) {
      const PassNode& pass = g_.passes[p];
      for (std::uint32_t i = pass.first_access, end = pass.first_access + pass.access_count; i < end; ++i)
        if (g_.accesses[i].resource == resource && (g_.accesses[i].uses & uses)) {
          out.push_back(pass_name(p));
          break;
        }
    }
    if (out.empty()) out.push_back("?");
    return out;
  }

  // Only in graphs with a multisampled texture: a pass's multisampled attachments share one
  // count (a single-sample attachment beside them is their resolve target, which the render
  // pass checks when it is recorded), and no pass reads a multisampled texture per texel.
  void check_sample_counts() {
    constexpr std::uint16_t per_texel_uses = use_bit(TextureUse::Sampled) | use_bit(TextureUse::StorageRead) |
                                             use_bit(TextureUse::StorageWrite) | texture_copy_uses;
    for (std::uint32_t p = 0; p < s_.pass_count; ++p) {
      const PassNode& pass = g_.passes[p];
      std::uint32_t first = invalid_index;
      // A resolve (gpu::CommandEncoder::resolve_texture) reads a multisampled texture as a copy
      // source into a single-sample copy destination of the same pass.
      bool single_sample_copy_dst = false;
      for (std::uint32_t i = pass.first_access, end = pass.first_access + pass.access_count; i < end; ++i) {
        const AccessNode& a = g_.accesses[i];
        single_sample_copy_dst |= a.texture && (a.uses & use_bit(TextureUse::CopyDst)) &&
                                  g_.resources[a.resource].texture_desc.sample_count == 1;
      }
      for (std::uint32_t i = pass.first_access, end = pass.first_access + pass.access_count; i < end; ++i) {
        const AccessNode& a = g_.accesses[i];
        if (!a.texture) continue;
        const std::uint32_t samples = g_.resources[a.resource].texture_desc.sample_count;
        if (samples == 1) continue;
        if (a.uses == use_bit(TextureUse::CopySrc) && single_sample_copy_dst) continue;  // a resolve
        if (a.uses & per_texel_uses) {
          const bool sampled = a.uses & use_bit(TextureUse::Sampled);
          error(GraphErrorKind::SampleCount,
                weft::format("pass '{}': {} {} ({} samples) {}; resolve it into a single-sample texture first (a "
                             "render pass's resolve target beside it)",
                             pass.name, sampled ? "samples" : "copies or stores", g_.describe(a.resource), samples,
                             sampled ? "as one value per texel" : "texel by texel"),
                {pass_name(p)}, {resource_name(a.resource)});
          continue;
        }
        if (!(a.uses & attachment_uses)) continue;
        if (first == invalid_index) {
          first = a.resource;
          continue;
        }
        const std::uint32_t first_samples = g_.resources[first].texture_desc.sample_count;
        if (first_samples != samples)
          error(GraphErrorKind::SampleCount,
                weft::format("pass '{}': attachments {} has {} samples and {} has {}; a render pass's multisampled "
                             "attachments share one sample count",
                             pass.name, g_.describe(first), first_samples, g_.describe(a.resource), samples),
                {pass_name(p)}, {resource_name(first), resource_name(a.resource)});
      }
    }
  }

  // Only passes whose attachments setup saw declared with different sizes can differ once
  // the sizes are resolved (culled passes are checked too). One texture of the wrong size is
  // usually attached by many passes: their errors collapse into one naming it and them all.
  void check_attachments() {
    std::vector<std::uint32_t> mismatched;
    for (std::uint32_t p = 0; p < s_.pass_count; ++p)
      if (g_.passes[p].attachment_sizes_differ && attachments_mismatch(p)) mismatched.push_back(p);
    if (!mismatched.empty()) report_attachment_sizes(mismatched);
  }

  [[gnu::cold, gnu::noinline]] void report_attachment_sizes(const std::vector<std::uint32_t>& mismatched) {
    auto same = [](gpu::Extent3D x, gpu::Extent3D y) { return x.width == y.width && x.height == y.height; };
    // An attachment is a texture, or a range of one (a mip renders at its own size): keyed
    // by resource and range.
    using Key = std::uint64_t;
    auto resource_of = [](Key k) { return std::uint32_t(k >> 16); };
    auto extent_of = [&](Key k) {
      const gpu::Extent3D e = s_.resources[resource_of(k)].extent;
      const std::uint32_t mip = g_.ranges[k & 0xffffu].base_mip;
      return gpu::Extent3D{std::max(1u, e.width >> mip), std::max(1u, e.height >> mip), 1};
    };
    auto label = [&](Key k) {
      const std::uint32_t r = resource_of(k);
      const auto range = std::uint16_t(k & 0xffffu);
      if (range == 0) return weft::format("texture '{}'", g_.resources[r].name);
      const ResourceInfo& info = s_.resources[r];
      return weft::format("{} of texture '{}'",
                          gpu::describe(g_.ranges[range], info.mip_level_count, declared_layers(g_.resources[r].texture_desc)),
                          g_.resources[r].name);
    };
    auto attachments = [&](std::uint32_t p) {
      std::vector<Key> out;
      const PassNode& pass = g_.passes[p];
      for (std::uint32_t i = pass.first_access, end = pass.first_access + pass.access_count; i < end; ++i) {
        const AccessNode& a = g_.accesses[i];
        if (a.texture && (a.uses & attachment_uses)) out.push_back((Key(a.resource) << 16) | a.range);
      }
      return out;
    };
    auto add_name = [&](std::vector<std::string>& names, Key k) {
      std::string name = resource_name(resource_of(k));
      if (std::find(names.begin(), names.end(), name) == names.end()) names.push_back(std::move(name));
    };
    // How many mismatched passes attach each texture: of two attachments that disagree, the
    // one many passes share is the odd one (the others agree with their passes' own targets).
    std::map<Key, std::uint32_t> passes_using;
    for (std::uint32_t p : mismatched)
      for (Key k : attachments(p)) ++passes_using[k];
    // Per pass, the odd attachment: the one whose size fewest of the pass's attachments have,
    // among those the most mismatched passes share, the last declared.
    std::map<Key, std::vector<std::uint32_t>> passes_by_odd;
    std::vector<Key> odd_order;
    for (std::uint32_t p : mismatched) {
      const std::vector<Key> list = attachments(p);
      Key odd = list.back();
      std::uint32_t best_agreeing = ~0u, best_sharing = 0;
      for (Key k : list) {
        std::uint32_t agreeing = 0;
        for (Key q : list) agreeing += same(extent_of(k), extent_of(q)) ? 1 : 0;
        const std::uint32_t sharing = passes_using[k];
        if (agreeing < best_agreeing || (agreeing == best_agreeing && sharing >= best_sharing)) {
          odd = k;
          best_agreeing = agreeing;
          best_sharing = sharing;
        }
      }
      if (passes_by_odd[odd].empty()) odd_order.push_back(odd);
      passes_by_odd[odd].push_back(p);
    }
    for (Key odd : odd_order) {
      const std::vector<std::uint32_t>& passes = passes_by_odd[odd];
      if (passes.size() == 1) {
        const std::uint32_t p = passes.front();
        std::string list;
        std::vector<std::string> names;
        for (Key k : attachments(p)) {
          list += weft::format("{}{} is {}", list.empty() ? "" : ", ", label(k), format_extent(extent_of(k)));
          add_name(names, k);
        }
        error(GraphErrorKind::MismatchedAttachmentSizes,
              weft::format("pass '{}': attachments have different sizes: {}", g_.passes[p].name, list), {pass_name(p)},
              std::move(names));
        continue;
      }
      std::string pass_list, other_sizes;
      std::vector<std::string> pass_names, names{resource_name(resource_of(odd))};
      std::vector<Key> others_seen;
      for (std::uint32_t p : passes) {
        pass_list += weft::format("{}'{}'", pass_list.empty() ? "" : ", ", g_.passes[p].name);
        pass_names.push_back(pass_name(p));
        for (Key k : attachments(p)) {
          if (k == odd || std::find(others_seen.begin(), others_seen.end(), k) != others_seen.end()) continue;
          others_seen.push_back(k);
          add_name(names, k);
          const std::string size = format_extent(extent_of(k));
          if (other_sizes.find(size) == std::string::npos)
            other_sizes += weft::format("{}{}", other_sizes.empty() ? "" : " or ", size);
        }
      }
      const std::string odd_label = label(odd);
      error(GraphErrorKind::MismatchedAttachmentSizes,
            weft::format("{} is {}, but the other attachments of the {} passes it is attached to are {}: "
                         "passes {}; give it their size (or the same relative size), or give those passes a "
                         "texture of its size",
                         odd_label, format_extent(extent_of(odd)), passes.size(), other_sizes, pass_list),
            std::move(pass_names), std::move(names));
    }
  }
};

}  // namespace

void validate_and_schedule(const GraphData& graph, CompiledState& state, std::vector<GraphError>& errors) {
  state.pass_count = std::uint32_t(graph.passes.size());
  state.resource_count = std::uint32_t(graph.resources.size());
  Scheduler(graph, state, errors).run();
}


}  // namespace weft::detail

namespace weft {

namespace {

std::unique_ptr<detail::CompiledState> take_spare_state(detail::GraphData& graph) {
  const std::lock_guard lock(graph.spare_state_mutex);
  return std::move(graph.spare_state);
}

// A plan made with these options serves a graph compiled with `options`.
bool same_options(const detail::CompiledState& state, const CompileOptions& options) {
  const gpu::Extent3D a = state.planned_output_extent, b = options.output_extent;
  return !state.planned_custom_sizes && !options.texture_requirements && !options.buffer_requirements &&
         state.planned_device == options.device && state.planned_aliasing == options.aliasing &&
         a.width == b.width && a.height == b.height && a.depth_or_layers == b.depth_or_layers;
}

// The error for names declared more than once (the cold path of check_unique_names): one
// error per repeated name, naming every declaration of it.
[[gnu::cold, gnu::noinline]] void report_duplicate_names(const detail::GraphData& g, bool passes,
                                                         std::vector<GraphError>& errors) {
  std::map<std::string_view, std::vector<std::uint32_t>> by_name;
  const std::size_t n = passes ? g.passes.size() : g.resources.size();
  for (std::uint32_t i = 0; i < n; ++i) by_name[passes ? g.passes[i].name : g.resources[i].name].push_back(i);
  // In declaration order of each name's first use, as every other error.
  std::vector<std::pair<std::uint32_t, std::string_view>> repeated;
  for (const auto& [name, indices] : by_name)
    if (indices.size() > 1) repeated.emplace_back(indices.front(), name);
  std::sort(repeated.begin(), repeated.end());
  for (const auto& [first, name] : repeated) {
    const std::vector<std::uint32_t>& indices = by_name[name];
    GraphError e{GraphErrorKind::DuplicateName, {}, {}, {}};
    std::string list;
    for (std::uint32_t i : indices) {
      if (passes) {
        list += weft::format("{}#{}", list.empty() ? "" : ", ", i);
        e.passes.emplace_back(name);
        continue;
      }
      const detail::ResourceNode& r = g.resources[i];
      const std::string by = r.imported ? std::string("imported")
                             : r.creator < g.passes.size()
                                 ? weft::format("created by pass '{}'", g.passes[r.creator].name)
                                 : std::string("created");
      list += weft::format("{}{}", list.empty() ? "" : ", ", by);
      if (r.creator < g.passes.size()) e.passes.emplace_back(g.passes[r.creator].name);
      e.resources.emplace_back(name);
    }
    if (passes)
      e.message = weft::format("{} passes are named '{}' (passes {} in declaration order): culled(), find_pass(), "
                               "errors and dumps name passes by name, so give each its own (e.g. '{}.{}')",
                               indices.size(), name, list, name, 2);
    else
      e.message = weft::format("{} {}s are named '{}' ({}): find_texture(), errors and dumps name resources by "
                               "name, so give each its own (e.g. a suffix per pass or per object)",
                               indices.size(), g.resources[first].type == ResourceType::Texture ? "texture" : "buffer",
                               name, list);
    errors.push_back(std::move(e));
  }
}

// A hash of a pass or resource name for check_unique_names, which runs on every compile and
// should cost a few instructions per name: names are short, so their first, middle and last
// eight bytes decide it (equal hashes are compared in full); long ones take the library hash.
[[gnu::always_inline]] inline std::uint64_t name_hash(std::string_view s) {
  const std::size_t n = s.size();
  if (n > 24) return std::hash<std::string_view>{}(s);
  std::uint64_t a = 0, b = 0, c = 0;
  if (n >= 8) {
    std::memcpy(&a, s.data(), 8);
    std::memcpy(&b, s.data() + (n - 8), 8);
    std::memcpy(&c, s.data() + (n - 8) / 2, 8);
  } else if (n >= 4) {
    std::uint32_t x, y;
    std::memcpy(&x, s.data(), 4);
    std::memcpy(&y, s.data() + (n - 4), 4);
    a = x;
    b = y;
  } else if (n > 0) {
    a = std::uint64_t(std::uint8_t(s[0])) | std::uint64_t(std::uint8_t(s[n / 2])) << 8 |
        std::uint64_t(std::uint8_t(s[n - 1])) << 16;
  }
  std::uint64_t h = (a ^ n) * 0x9E3779B97F4A7C15ull;
  h = (h ^ (h >> 29) ^ b) * 0xBF58476D1CE4E5B9ull;
  h = (h ^ (h >> 32) ^ c) * 0x94D049BB133111EBull;
  return h ^ (h >> 31);
}

// Whether any two of `count` names (name(i)) are equal, by an open-addressing table of
// indices into them: one hash and about one probe per name.
template <class Name>
[[gnu::always_inline]] inline bool has_duplicate(std::vector<std::uint32_t>& slots, std::size_t count, Name&& name) {
  if (count < 2) return false;
  std::size_t size = 16;
  while (size < count * 2) size *= 2;
  slots.assign(size, invalid_index);
  const std::size_t mask = size - 1;
  for (std::uint32_t i = 0; i < count; ++i) {
    const std::string_view key = name(i);
    for (std::size_t at = name_hash(key) & mask;; at = (at + 1) & mask) {
      const std::uint32_t seen = slots[at];
      if (seen == invalid_index) {
        slots[at] = i;
        break;
      }
      if (name(seen) == key) return true;
    }
  }
  return false;
}

// Names identify passes and resources (culled(), find_pass, errors, dumps): two passes, or two
// resources, with one name make them disagree about which is meant. Checked in every
// compile, a reused plan's too: names are not part of what a plan is compared by.
void check_unique_names(detail::GraphData& g, std::vector<GraphError>& errors) {
  if (has_duplicate(g.name_slots, g.passes.size(), [&](std::uint32_t i) { return g.passes[i].name; }))
    report_duplicate_names(g, true, errors);
  if (has_duplicate(g.name_slots, g.resources.size(), [&](std::uint32_t i) { return g.resources[i].name; }))
    report_duplicate_names(g, false, errors);
}

// For a frame that repeats the last one: its names are unique if they are last frame's (which
// its compile checked) -- a comparison, cheaper than hashing them; otherwise checked in full.
bool unique_names_as_before(detail::GraphData& now, const detail::GraphData& before, std::vector<GraphError>& errors,
                            bool& checked) {
  bool same = true;
  for (std::size_t p = 0; p < now.passes.size() && same; ++p) same = now.passes[p].name == before.passes[p].name;
  for (std::size_t r = 0; r < now.resources.size() && same; ++r) same = now.resources[r].name == before.resources[r].name;
  if (same) return true;
  check_unique_names(now, errors);
  checked = true;
  return errors.empty();
}

}  // namespace

std::expected<CompiledGraph, GraphErrors> RenderGraph::compile(const CompileOptions& options) const {
  // Last frame's plan, when this frame declares exactly what it did and its compiled graph
  // is gone: only the names (and the callbacks, read from this graph at execute) change.
  std::vector<GraphError> name_errors;
  bool names_checked = false;
  std::unique_ptr<detail::CompiledState> state;
  if (detail::GraphData* before = data_->previous) {
    state = take_spare_state(*before);
    if (state && data_->current_pass == invalid_index && state->pass_count == before->passes.size() &&
        state->resource_count == before->resources.size() && same_options(*state, options) &&
        detail::same_declarations(*data_, *before) && unique_names_as_before(*data_, *before, name_errors, names_checked)) {
      state->graph = data_;
      state->frame_index = 0;
      state->reused = true;
      for (std::uint32_t p = 0; p < state->pass_count; ++p) state->passes[p].name = data_->passes[p].name;
      for (std::uint32_t r = 0; r < state->resource_count; ++r) state->resources[r].name = data_->resources[r].name;
      // An older plan this graph kept (from two frames ago) keeps its arrays but not its gpu
      // memory: only one frame's transients stay allocated between frames.
      {
        const std::lock_guard lock(data_->spare_state_mutex);
        if (data_->spare_state) detail::drop_gpu_objects(*data_->spare_state);
      }
      return CompiledGraph(std::move(state));
    }
  }
  if (!names_checked) check_unique_names(*data_, name_errors);
  if (!state) state = take_spare_state(*data_);
  if (!state) state = std::make_unique<detail::CompiledState>();
  detail::drop_gpu_objects(*state);  // a recycled state's gpu objects belong to its old plan
  state->reused = false;
  state->graph = data_;
  state->frame_index = 0;
  state->options = options;
  state->planned_output_extent = options.output_extent;
  state->planned_device = options.device;
  state->planned_aliasing = options.aliasing;
  state->planned_custom_sizes = bool(options.texture_requirements) || bool(options.buffer_requirements);
  GraphErrors errors{data_->name, data_->declaration_errors};
  for (GraphError& e : name_errors) errors.errors.push_back(std::move(e));
  if (data_->current_pass != invalid_index)
    errors.errors.push_back(GraphError{GraphErrorKind::InvalidDescriptor,
                                       weft::format("compile() called inside the setup of pass '{}'",
                                                   data_->current_pass_name()),
                                       {std::string(data_->current_pass_name())}, {}});
  detail::validate_and_schedule(*data_, *state, errors.errors);
  // A declaring device (gpu::Device::create_declaring) has no memory to ask about: its frame
  // is sized by estimate, as without a device.
  const gpu::Device* sizing = options.device && !options.device->declaring() ? options.device : nullptr;
  if (errors.empty()) detail::plan_frame(*data_, *state, sizing, false, errors.errors);
  if (!errors.empty()) return std::unexpected(std::move(errors));
  return CompiledGraph(std::move(state));
}

}  // namespace weft

namespace weft::detail {

namespace {

// The bits in which the first `Bytes` bytes of `a` and `b` differ, OR-ed together by word.
template <std::size_t Bytes>
[[gnu::always_inline]] inline std::uint64_t differing_bits(const void* a, const void* b) {
  static_assert(Bytes % 4 == 0, "nodes compared by whole 4-byte words");
  const auto* x = static_cast<const std::byte*>(a);
  const auto* y = static_cast<const std::byte*>(b);
  std::uint64_t diff = 0;
  std::size_t i = 0;
  for (; i + 8 <= Bytes; i += 8) {
    std::uint64_t u, v;
    std::memcpy(&u, x + i, 8);
    std::memcpy(&v, y + i, 8);
    diff |= u ^ v;
  }
  if constexpr (Bytes % 8 != 0) {
    std::uint32_t u, v;
    std::memcpy(&u, x + i, 4);
    std::memcpy(&v, y + i, 4);
    diff |= u ^ v;
  }
  return diff;
}

}  // namespace

bool same_declarations(const GraphData& now, const GraphData& before) {
  if (now.passes.size() != before.passes.size() || now.resources.size() != before.resources.size() ||
      now.accesses.size() != before.accesses.size() || now.versions.size() != before.versions.size() ||
      now.outputs.size() != before.outputs.size() || !now.declaration_errors.empty() ||
      !before.declaration_errors.empty() || now.backward_edges != before.backward_edges ||
      now.maybe_unwritten_read != before.maybe_unwritten_read || now.subresources != before.subresources ||
      (now.subresources && now.ranges != before.ranges))
    return false;
  // Cheapest first: what changes between frames usually shows in the counts, the outputs or
  // a descriptor (a resize) before the accesses are compared byte for byte.
  for (std::size_t o = 0; o < now.outputs.size(); ++o) {
    const OutputNode &a = now.outputs[o], &b = before.outputs[o];
    if (a.resource != b.resource || a.version != b.version || a.final_state != b.final_state) return false;
  }
  // Passes and resources up to their names, word by word (a memcmp call per node costs more
  // than the comparison), accumulated without branches: almost every frame compares equal.
  std::uint64_t differ = 0;
  for (std::size_t p = 0; p < now.passes.size(); ++p)
    differ |= differing_bits<offsetof(PassNode, name)>(&now.passes[p], &before.passes[p]);
  for (std::size_t r = 0; r < now.resources.size(); ++r)
    differ |= differing_bits<offsetof(ResourceNode, name)>(&now.resources[r], &before.resources[r]);
  if (differ != 0) return false;
  // Versions, use bits, pass kinds and culling roots follow from these in declaration order
  // (and each pass's first access from the counts before it).
  if (!now.accesses.empty() &&
      std::memcmp(now.accesses.data(), before.accesses.data(), now.accesses.size() * sizeof(AccessNode)) != 0)
    return false;
  return true;
}

}  // namespace weft::detail
