// Execution: transient resources are created once per device in memory blocks at the
// planned offsets and kept for later frames; each frame records every pass into one command
// encoder (debug group, barriers, timestamps, the pass's callback), submits and waits.
module;
#include <algorithm>
#include <chrono>
#include <cstdint>
#include <expected>
#include <memory>
#include <mutex>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <utility>
#include <vector>
module weft.graph;
import weft.core;
import weft.gpu;
import :compiled_state;

namespace weft::detail {

// A texture taking over memory must start from an undefined layout yet wait for the
// previous occupant's last access. gpu::TextureBarrier's `before` gives both the old layout
// and the stages to wait for, and Undefined waits for nothing. So a takeover is recorded in
// two barrier calls: (1) the first time its memory is taken over, the occupant moves from
// its last state to release_state() — a layout change, ending in shader stages; (2) the new
// texture moves from UniformRead — shader stages, the UNDEFINED layout — to its first state.
// (2)'s source stages chain with (1)'s destination stages, so the new layout transition
// happens after everything the occupant did. A TextureBarrier that could say "discard the
// contents, but wait for access X" would make (1) unnecessary.
inline constexpr gpu::Access takeover_wait_state = gpu::Access::UniformRead;

struct Realized {
  const gpu::Device* device = nullptr;
  std::vector<gpu::MemoryBlock> blocks;  // destroyed after the resources placed in them
  std::vector<std::optional<gpu::Texture>> textures;
  std::vector<std::optional<gpu::Buffer>> buffers;
  std::optional<gpu::Texture> fallback_texture;  // handed out for undeclared accesses
  std::optional<gpu::Buffer> fallback_buffer;
  std::optional<gpu::QuerySet> queries;
  // Views of parts of transient textures (PassResources::view with a range), made on first
  // use and kept with the textures; an imported texture's are made per frame (Executor::kept).
  struct RangeView {
    const gpu::Texture* texture;
    TextureRange range;
    std::unique_ptr<gpu::TextureView> view;
  };
  std::vector<RangeView> range_views;
};

CompiledState::CompiledState() = default;
CompiledState::~CompiledState() = default;

void drop_gpu_objects(CompiledState& state) { state.realized.reset(); }

struct Executor {
  CompiledState& state;
  GraphData& graph;
  gpu::Device& device;
  gpu::CommandEncoder* encoder = nullptr;
  std::vector<std::string> errors;
  std::vector<std::string> error_passes, error_resources;
  std::vector<std::unique_ptr<KeptObject>> kept;  // released after the frame's wait
  std::vector<gpu::TextureBarrier> release_batch, texture_batch;
  std::vector<gpu::BufferBarrier> buffer_batch;

  [[nodiscard]] const gpu::Texture* texture_of(std::uint32_t r) const {
    if (graph.resources[r].imported) return graph.resources[r].texture;
    const auto& t = state.realized->textures[r];
    return t ? &*t : nullptr;
  }
  [[nodiscard]] const gpu::Buffer* buffer_of(std::uint32_t r) const {
    if (graph.resources[r].imported) return graph.resources[r].buffer;
    const auto& b = state.realized->buffers[r];
    return b ? &*b : nullptr;
  }
  [[nodiscard]] bool declared(std::uint32_t pass, std::uint32_t resource) const {
    const PassNode& p = graph.passes[pass];
    for (std::uint32_t i = p.first_access, end = p.first_access + p.access_count; i < end; ++i)
      if (graph.accesses[i].resource == resource) return true;
    return false;
  }

  void undeclared(std::uint32_t pass, std::uint32_t resource, ResourceType type, std::uint32_t version) {
    const std::string_view pass_name = graph.passes[pass].name;
    const std::string_view kind = type == ResourceType::Texture ? "texture" : "buffer";
    if (resource >= graph.resources.size() || graph.resources[resource].type != type) {
      errors.push_back(weft::format("pass '{}': execute uses an invalid {} handle (index {}, version {})", pass_name,
                                   kind, resource, version));
      error_passes.emplace_back(pass_name);
      return;
    }
    const std::string_view name = graph.resources[resource].name;
    errors.push_back(weft::format("pass '{}': execute uses {} '{}', which its setup did not declare (declare it with "
                                 "read() or write())",
                                 pass_name, kind, name));
    error_passes.emplace_back(pass_name);
    error_resources.emplace_back(name);
  }

  // An undeclared access is recorded (execute() fails after this pass) but still answered,
  // with the real resource when it exists, so the callback can finish normally.
  const gpu::Texture& texture(std::uint32_t pass, TextureHandle h) {
    if (h.index >= state.resource_count || graph.resources[h.index].type != ResourceType::Texture) {
      undeclared(pass, h.index, ResourceType::Texture, h.version);
      return *state.realized->fallback_texture;
    }
    if (!declared(pass, h.index)) undeclared(pass, h.index, ResourceType::Texture, h.version);
    const gpu::Texture* t = texture_of(h.index);
    return t ? *t : *state.realized->fallback_texture;
  }

  const gpu::TextureView& view(std::uint32_t pass, TextureHandle h, const TextureRange& range) {
    const gpu::Texture& t = texture(pass, h);
    if (&t == &*state.realized->fallback_texture) return t.view();
    const std::uint32_t mips = t.descriptor().mip_level_count, layers = t.layer_count();
    if (range.covers(mips, layers)) return t.view();
    const std::string_view pass_name = graph.passes[pass].name;
    if (!range.fits(mips, layers)) {
      errors.push_back(weft::format("pass '{}': execute asks for a view of {} of texture '{}', which has {} mips and {} "
                                   "layers",
                                   pass_name, gpu::describe(range), t.label(), mips, layers));
      error_passes.emplace_back(pass_name);
      error_resources.emplace_back(graph.resources[h.index].name);
      return t.view();
    }
    const TextureRange exact{range.base_mip, range.mips_of(mips), range.base_layer, range.layers_of(layers)};
    const bool imported = graph.resources[h.index].imported;
    if (!imported)
      for (const auto& v : state.realized->range_views)
        if (v.texture == &t && v.range == exact) return *v.view;
    auto made = t.create_view({exact.base_mip, exact.mip_count, exact.base_layer, exact.layer_count});
    if (!made) {
      errors.push_back(weft::format("pass '{}': {}", pass_name, made.error().message));
      error_passes.emplace_back(pass_name);
      return t.view();
    }
    if (imported) {
      auto holder = std::make_unique<Kept<gpu::TextureView>>(std::move(*made));
      const gpu::TextureView& view = holder->value;
      kept.push_back(std::move(holder));
      return view;
    }
    state.realized->range_views.push_back({&t, exact, std::make_unique<gpu::TextureView>(std::move(*made))});
    return *state.realized->range_views.back().view;
  }

  const gpu::Buffer& buffer(std::uint32_t pass, BufferHandle h) {
    if (h.index >= state.resource_count || graph.resources[h.index].type != ResourceType::Buffer) {
      undeclared(pass, h.index, ResourceType::Buffer, h.version);
      return *state.realized->fallback_buffer;
    }
    if (!declared(pass, h.index)) undeclared(pass, h.index, ResourceType::Buffer, h.version);
    const gpu::Buffer* b = buffer_of(h.index);
    return b ? *b : *state.realized->fallback_buffer;
  }

  void run(std::uint32_t p) {
    const PassNode& pass = graph.passes[p];
    if (!pass.execute.invoke) return;
    PassResources resources(this, p);
    PassContext ctx;
    ctx.executor_ = this;
    ctx.encoder_ = encoder;
    ctx.device_ = &device;
    ctx.pass_name_ = pass.name;
    ctx.frame_index_ = state.frame_index;
    pass.execute.invoke(pass.execute.callable, pass.execute.data, resources, ctx);
  }

  // Barriers within one vkCmdPipelineBarrier2 are not ordered against each other, so two that
  // move the same subresource (a texture placed whole, then one of its mips moved on for a
  // second use in the same pass) go in consecutive batches, in the order planned.
  void add_texture_barrier(const gpu::TextureBarrier& barrier) {
    const gpu::Texture* t = barrier.texture;
    const bool clash = t && std::any_of(texture_batch.begin(), texture_batch.end(), [&](const gpu::TextureBarrier& x) {
                         return x.texture == t && overlap(x.range, barrier.range, t->descriptor().mip_level_count,
                                                          t->layer_count());
                       });
    if (clash) {
      encoder->barrier(texture_batch, buffer_batch);
      texture_batch.clear();
      buffer_batch.clear();
    }
    texture_batch.push_back(barrier);
  }

  void record_barriers(std::span<const PlannedBarrier> planned) {
    release_batch.clear();
    texture_batch.clear();
    buffer_batch.clear();
    for (const PlannedBarrier& b : planned) {
      const bool is_texture = state.resources[b.resource].type == ResourceType::Texture;
      if (b.previous_occupant != invalid_index && is_texture && b.occupant_before != b.occupant_after)
        release_batch.push_back(
            gpu::TextureBarrier{texture_of(b.previous_occupant), b.occupant_before, b.occupant_after, b.range});
    }
    if (!release_batch.empty()) encoder->barrier(release_batch, {});
    for (const PlannedBarrier& b : planned) {
      const bool is_texture = state.resources[b.resource].type == ResourceType::Texture;
      if (b.previous_occupant != invalid_index && is_texture) {
        const gpu::Texture* taker = texture_of(b.resource);
        if (std::none_of(texture_batch.begin(), texture_batch.end(),
                         [&](const gpu::TextureBarrier& x) { return x.texture == taker; }))
          add_texture_barrier(gpu::TextureBarrier{taker, takeover_wait_state, b.after});
      } else if (b.previous_occupant != invalid_index) {
        buffer_batch.push_back(gpu::BufferBarrier{buffer_of(b.resource), b.occupant_before, b.after});
      } else if (is_texture) {
        add_texture_barrier(gpu::TextureBarrier{texture_of(b.resource), b.before, b.after, b.range});
      } else {
        buffer_batch.push_back(gpu::BufferBarrier{buffer_of(b.resource), b.before, b.after});
      }
    }
    if (!texture_batch.empty() || !buffer_batch.empty()) encoder->barrier(texture_batch, buffer_batch);
  }
};

namespace {

Result<void> realize(GraphData& graph, CompiledState& s, gpu::Device& device) {
  if (s.realized && s.realized->device == &device) return {};
  s.realized.reset();
  if (!s.memory.from_device || s.options.device != &device) {
    // Compiled with estimates (or another device): size and place with this device's numbers.
    std::vector<GraphError> errors;
    plan_frame(graph, s, &device, true, errors);
    if (!errors.empty()) return std::unexpected(Error{ErrorKind::Device, errors.front().message});
    s.options.device = &device;
  }
  auto real = std::make_unique<Realized>();
  real->device = &device;
  real->blocks.reserve(s.memory.heaps.size());
  for (std::size_t h = 0; h < s.memory.heaps.size(); ++h) {
    const MemoryHeap& heap = s.memory.heaps[h];
    auto block = device.create_memory_block(
        weft::format("{} {} heap {}", graph.name, heap.type == ResourceType::Texture ? "texture" : "buffer", h),
        std::max<std::uint64_t>(heap.size, 1), heap.type_bits);
    if (!block) return with_context(weft::format("render graph '{}'", graph.name), block.error());
    real->blocks.push_back(std::move(*block));
  }
  real->textures.resize(s.resource_count);
  real->buffers.resize(s.resource_count);
  for (std::uint32_t r = 0; r < s.resource_count; ++r) {
    const ResourceInfo& info = s.resources[r];
    if (info.heap == invalid_index) continue;
    const gpu::Placement placement{&real->blocks[info.heap], info.offset};
    if (info.type == ResourceType::Texture) {
      auto texture = device.create_texture(gpu::TextureDescriptor{std::string(info.name), info.extent, info.format,
                                                                  info.texture_usage, info.mip_level_count,
                                                                  info.dimension, info.sample_count},
                                           placement);
      if (!texture) return with_context(weft::format("render graph '{}'", graph.name), texture.error());
      real->textures[r].emplace(std::move(*texture));
    } else {
      auto buffer = device.create_buffer(gpu::BufferDescriptor{std::string(info.name), info.buffer_size,
                                                               info.buffer_usage},
                                         placement);
      if (!buffer) return with_context(weft::format("render graph '{}'", graph.name), buffer.error());
      real->buffers[r].emplace(std::move(*buffer));
    }
  }
  using TU = gpu::TextureUsage;
  auto fallback_texture = device.create_texture(gpu::TextureDescriptor{
      "graph fallback texture", {1, 1, 1}, gpu::Format::RGBA8Unorm, TU::Sampled | TU::Storage | TU::CopySrc | TU::CopyDst});
  if (!fallback_texture) return std::unexpected(fallback_texture.error());
  real->fallback_texture.emplace(std::move(*fallback_texture));
  using BU = gpu::BufferUsage;
  auto fallback_buffer = device.create_buffer(gpu::BufferDescriptor{
      "graph fallback buffer", 256,
      BU::CopySrc | BU::CopyDst | BU::Uniform | BU::Storage | BU::Vertex | BU::Index | BU::Indirect});
  if (!fallback_buffer) return std::unexpected(fallback_buffer.error());
  real->fallback_buffer.emplace(std::move(*fallback_buffer));
  s.realized = std::move(real);
  return {};
}

double elapsed_us(std::chrono::steady_clock::time_point since) {
  return std::chrono::duration<double, std::micro>(std::chrono::steady_clock::now() - since).count();
}

}  // namespace

}  // namespace weft::detail

namespace weft {

// The state goes back to its graph for the next compile() to reuse, without its reference to
// the graph (which would keep the graph alive through itself). Its gpu objects stay with it:
// the next frame's compile() keeps them when it reuses the plan, and drops them otherwise.
CompiledGraph::~CompiledGraph() {
  if (!state_ || !state_->graph) return;
  std::shared_ptr<detail::GraphData> graph = std::move(state_->graph);
  const std::lock_guard lock(graph->spare_state_mutex);
  graph->spare_state = std::move(state_);
}

void PassContext::keep_alive(std::unique_ptr<detail::KeptObject> object) const {
  executor_->kept.push_back(std::move(object));
}

const gpu::Texture& PassResources::texture(TextureHandle handle) const { return executor_->texture(pass_, handle); }
const gpu::TextureView& PassResources::view(TextureHandle handle) const { return texture(handle).view(); }
const gpu::TextureView& PassResources::view(TextureHandle handle, const TextureRange& range) const {
  return executor_->view(pass_, handle, range);
}
gpu::Extent3D PassResources::extent(TextureHandle handle, std::uint32_t mip) const {
  const gpu::Extent3D e = texture(handle).size();
  return {std::max(1u, e.width >> mip), std::max(1u, e.height >> mip), e.depth_or_layers};
}
const gpu::Buffer& PassResources::buffer(BufferHandle handle) const { return executor_->buffer(pass_, handle); }
gpu::Extent3D PassResources::extent(TextureHandle handle) const { return texture(handle).size(); }

Result<FrameStats> CompiledGraph::execute(gpu::Device& device, const ExecuteOptions& options) {
  using clock = std::chrono::steady_clock;
  detail::CompiledState& s = *state_;
  detail::GraphData& graph = *s.graph;
  const auto frame_start = clock::now();
  const std::string context = weft::format("render graph '{}'", graph.name);

  // Imported resources a pass will touch must have gpu objects behind them.
  for (std::uint32_t r = 0; r < s.resource_count; ++r) {
    const detail::ResourceNode& node = graph.resources[r];
    if (!node.imported || !s.resources[r].used) continue;
    if ((node.type == ResourceType::Texture && node.texture == nullptr) ||
        (node.type == ResourceType::Buffer && node.buffer == nullptr))
      return fail(ErrorKind::InvalidArgument, "{}: {} was imported by descriptor only; execute() needs the gpu object",
                  context, graph.describe(r));
  }
  if (auto realized = detail::realize(graph, s, device); !realized) return std::unexpected(realized.error());

  auto encoder = device.create_command_encoder(graph.name);
  if (!encoder) return with_context(context, encoder.error());
  // Serial passes: each pass's commands go in an encoder of their own, submitted and waited for.
  auto submit_and_wait = [&]() -> Result<void> {
    auto commands = encoder->finish();
    if (!commands) return with_context(context, commands.error());
    if (auto submitted = device.queue().submit(std::move(*commands)); !submitted)
      return with_context(context, submitted.error());
    if (auto waited = device.queue().wait_idle(); !waited) return with_context(context, waited.error());
    return {};
  };
  const auto positions = std::uint32_t(s.order.size());
  const bool timestamps = options.timestamps && positions > 0 && device.adapter_info().limits.timestamps;
  detail::Realized& real = *s.realized;
  if (timestamps) {
    if (!real.queries || real.queries->count() != 2 * positions) {
      auto queries = device.create_query_set(weft::format("{} timestamps", graph.name), 2 * positions);
      if (!queries) return with_context(context, queries.error());
      real.queries.emplace(std::move(*queries));
    }
    encoder->reset_query_set(*real.queries);
  }

  detail::Executor executor{s, graph, device, &*encoder};
  // Imported textures the caller left in another state than the declared initial one (for
  // example after the previous frame) are brought to it first.
  executor.texture_batch.clear();
  for (std::uint32_t r = 0; r < s.resource_count; ++r) {
    const detail::ResourceNode& node = graph.resources[r];
    if (!node.imported || node.texture == nullptr || !s.resources[r].used) continue;
    const gpu::Access actual = node.texture->state();
    if (node.initial_state != gpu::Access::Undefined && actual != gpu::Access::Undefined && actual != node.initial_state)
      executor.texture_batch.push_back(gpu::TextureBarrier{node.texture, actual, node.initial_state});
  }
  if (!executor.texture_batch.empty()) encoder->barrier(executor.texture_batch, {});

  FrameStats stats;
  stats.passes.reserve(positions);
  for (std::uint32_t pos = 0; pos < positions; ++pos) {
    const std::uint32_t p = s.order[pos];
    const detail::PassNode& pass = graph.passes[p];
    const auto wall_start = clock::now();
    encoder->push_debug_group(pass.name);
    executor.record_barriers(
        std::span(s.barriers).subspan(s.barrier_begin[pos], s.barrier_begin[pos + 1] - s.barrier_begin[pos]));
    if (timestamps) encoder->write_timestamp(*real.queries, 2 * pos);
    const auto pass_start = clock::now();
    executor.run(p);
    stats.passes.push_back(PassStats{std::string(pass.name), s.passes[p].kind, -1.0, detail::elapsed_us(pass_start)});
    stats.cpu_record_total_us += stats.passes.back().cpu_record_us;
    if (timestamps) encoder->write_timestamp(*real.queries, 2 * pos + 1);
    encoder->pop_debug_group();
    if (!executor.errors.empty()) {
      std::string message = context + ": ";
      for (std::size_t i = 0; i < executor.errors.size(); ++i) message += (i ? "; " : "") + executor.errors[i];
      return std::unexpected(Error{ErrorKind::Graph, std::move(message)});
    }
    if (options.serial_passes) {
      if (auto ok = submit_and_wait(); !ok) return std::unexpected(ok.error());
      stats.passes.back().wall_ms = detail::elapsed_us(wall_start) / 1000.0;
      encoder = device.create_command_encoder(graph.name);
      if (!encoder) return with_context(context, encoder.error());
      executor.encoder = &*encoder;
    }
  }
  executor.record_barriers(std::span(s.barriers).subspan(s.barrier_begin[positions],
                                                         s.barrier_begin[positions + 1] - s.barrier_begin[positions]));
  stats.cpu_record_total_us = detail::elapsed_us(frame_start);
  if (auto ok = submit_and_wait(); !ok) return std::unexpected(ok.error());

  if (timestamps) {
    auto times = real.queries->read_timestamps_ns(0, 2 * positions);
    if (!times) return with_context(context, times.error());
    stats.gpu_total_ms = ((*times)[2 * positions - 1] - (*times)[0]) / 1e6;
    for (std::uint32_t pos = 0; pos < positions; ++pos)
      stats.passes[pos].gpu_ms = ((*times)[2 * pos + 1] - (*times)[2 * pos]) / 1e6;
  }
  stats.transient_bytes = s.memory.aliased_bytes;
  stats.transient_bytes_unaliased = s.memory.unaliased_bytes;
  stats.cpu_frame_ms = detail::elapsed_us(frame_start) / 1000.0;
  ++s.frame_index;
  return stats;
}

const gpu::Texture* CompiledGraph::texture(TextureHandle handle) const {
  const detail::CompiledState& s = *state_;
  if (handle.index >= s.resource_count || s.resources[handle.index].type != ResourceType::Texture) return nullptr;
  if (s.graph->resources[handle.index].imported) return s.graph->resources[handle.index].texture;
  if (!s.realized) return nullptr;
  const auto& t = s.realized->textures[handle.index];
  return t ? &*t : nullptr;
}

const gpu::Buffer* CompiledGraph::buffer(BufferHandle handle) const {
  const detail::CompiledState& s = *state_;
  if (handle.index >= s.resource_count || s.resources[handle.index].type != ResourceType::Buffer) return nullptr;
  if (s.graph->resources[handle.index].imported) return s.graph->resources[handle.index].buffer;
  if (!s.realized) return nullptr;
  const auto& b = s.realized->buffers[handle.index];
  return b ? &*b : nullptr;
}

std::string FrameStats::format_table() const {
  auto ms = [](double v) { return v < 0 ? std::string("—") : weft::format("{:.3f}", v); };
  const bool wall = std::any_of(passes.begin(), passes.end(), [](const PassStats& p) { return p.wall_ms >= 0; });
  std::string out = wall ? "| pass | kind | GPU ms | wall ms (alone) | CPU record µs |\n|:-----|:-----|-------:|-------:|--------------:|\n"
                         : "| pass | kind | GPU ms | CPU record µs |\n|:-----|:-----|-------:|--------------:|\n";
  double wall_total = 0.0;
  for (const PassStats& p : passes) {
    if (wall) {
      wall_total += std::max(p.wall_ms, 0.0);
      out += weft::format("| {} | {} | {} | {} | {:.1f} |\n", p.name, to_string(p.kind), ms(p.gpu_ms), ms(p.wall_ms),
                          p.cpu_record_us);
    } else {
      out += weft::format("| {} | {} | {} | {:.1f} |\n", p.name, to_string(p.kind), ms(p.gpu_ms), p.cpu_record_us);
    }
  }
  if (wall)
    out += weft::format("| **total** ({} passes) | | {} | {} | {:.1f} |\n", passes.size(), ms(gpu_total_ms),
                        ms(wall_total), cpu_record_total_us);
  else
    out += weft::format("| **total** ({} passes) | | {} | {:.1f} |\n", passes.size(), ms(gpu_total_ms),
                        cpu_record_total_us);
  return out;
}

}  // namespace weft
