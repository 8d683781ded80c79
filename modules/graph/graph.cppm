// weft.graph — the render graph. Passes declare the resources they create, read and write;
// compile() validates the whole graph (reporting every error at once), culls what reaches no
// output, orders passes, aliases transient memory and derives barriers; the compiled graph
// records one command stream on a weft.gpu device with a debug label and timestamps per pass.
// Declaration, validation, culling, ordering, aliasing and barrier planning need no device.
// A graph rebuilt every frame is reset() and filled again, reusing its memory.
//
// This file is the API. The words it uses are in types.cppm and the blackboard in
// blackboard.cppm; how a graph stores its declarations (and setup's inline fast paths) is in
// details.cppm, and what compile() builds in compiled_state.cppm -- neither is exported.
module;
#include <cstddef>
#include <cstdint>
#include <expected>
#include <memory>
#include <new>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <type_traits>
#include <utility>
export module weft.graph;
import weft.core;
import weft.gpu;
export import :types;
export import :blackboard;
// Exported only because the standard wants every interface partition exported: it declares
// nothing exported, so importers reach its definitions (setup's inline paths) but cannot
// name them.
export import :details;

export namespace weft {

// ---- setup -----------------------------------------------------------------------------
// Handed to a pass's setup callback: everything the pass will touch is declared here.
class PassBuilder {
 public:
  // A transient texture/buffer owned by the graph; its gpu usage flags are derived from every
  // use declared on it, and its memory may be shared with transients that are not alive at
  // the same time. Its version 0 has no contents: write it before reading it.
  TextureHandle create_texture(std::string_view name, const TextureDesc& desc);
  BufferHandle create_buffer(std::string_view name, const BufferDesc& desc);

  // Reads return the handle they were given; writes return the next version, which later
  // passes must use to see this pass's results.
  TextureHandle read(TextureHandle handle, TextureUse use);
  BufferHandle read(BufferHandle handle, BufferUse use);
  [[nodiscard]] TextureHandle write(TextureHandle handle, TextureUse use);
  [[nodiscard]] BufferHandle write(BufferHandle handle, BufferUse use);

  // Part of a texture: mips and layers (TextureRange::mip(1), ::layer(face), ::at(mip, layer)).
  // A pass may use disjoint ranges of one texture in different ways -- sample mip 0 while it
  // renders mip 1, copy mip 2 into mip 3 -- each range in its own state with its own barriers.
  // A write of a range makes the next version of the whole texture (the rest carried over),
  // but hazards are tracked per mip and layer: passes that write different faces of a cube,
  // or read one face while another is written, are not ordered against each other by the
  // texture. Overlapping ranges in one pass may only be read the same way.
  TextureHandle read(TextureHandle handle, TextureUse use, const TextureRange& range);
  [[nodiscard]] TextureHandle write(TextureHandle handle, TextureUse use, const TextureRange& range);

  // Keeps the pass even when nothing it writes reaches an output (e.g. it uploads uniforms
  // or writes a readback buffer the graph does not know about).
  void side_effect();
  // Declares the pass kind; without it the kind is inferred (attachments or vertex/index
  // buffers: render; only copies: transfer; otherwise compute).
  void kind(PassKind kind);

  [[nodiscard]] Blackboard& blackboard();
  [[nodiscard]] std::string_view pass_name() const;

 private:
  inline PassBuilder(detail::GraphData* graph, std::uint32_t pass) : graph_(graph), pass_(pass) {}
  detail::GraphData* graph_;
  std::uint32_t pass_;
  friend class RenderGraph;
};

// ---- execute ---------------------------------------------------------------------------
// What a pass's execute callback may touch: only the resources its setup declared. Asking
// for anything else records an UndeclaredAccess error that execute() returns.
class PassResources {
 public:
  [[nodiscard]] const gpu::Texture& texture(TextureHandle handle) const;
  [[nodiscard]] const gpu::TextureView& view(TextureHandle handle) const;
  // A view of mips and layers of a declared texture (made once per frame's textures and
  // kept): one face of a cube to render into, one mip of a chain to sample or write.
  [[nodiscard]] const gpu::TextureView& view(TextureHandle handle, const TextureRange& range) const;
  [[nodiscard]] const gpu::Buffer& buffer(BufferHandle handle) const;
  [[nodiscard]] gpu::Extent3D extent(TextureHandle handle) const;
  [[nodiscard]] gpu::Extent3D extent(TextureHandle handle, std::uint32_t mip) const;  // of one mip

 private:
  PassResources(detail::Executor* executor, std::uint32_t pass) : executor_(executor), pass_(pass) {}
  detail::Executor* executor_;
  std::uint32_t pass_;
  friend struct detail::Executor;
};

class PassContext {
 public:
  [[nodiscard]] gpu::CommandEncoder& encoder() const { return *encoder_; }
  [[nodiscard]] gpu::Device& device() const { return *device_; }
  [[nodiscard]] std::string_view pass_name() const { return pass_name_; }
  [[nodiscard]] std::uint64_t frame_index() const { return frame_index_; }

  // Keeps an object made for this frame (typically a bind group over this frame's
  // resources) alive until the frame's commands have finished on the GPU.
  template <class T>
    requires(!std::is_lvalue_reference_v<T>)
  T& keep(T&& object) const {
    auto holder = std::make_unique<detail::Kept<T>>(std::move(object));
    T& value = holder->value;
    keep_alive(std::move(holder));
    return value;
  }

 private:
  PassContext() = default;
  void keep_alive(std::unique_ptr<detail::KeptObject> object) const;
  detail::Executor* executor_ = nullptr;
  gpu::CommandEncoder* encoder_ = nullptr;
  gpu::Device* device_ = nullptr;
  std::string_view pass_name_;
  std::uint64_t frame_index_ = 0;
  friend struct detail::Executor;
};


// ---- memory kept between graphs ---------------------------------------------------------
// For a frame loop that builds a new RenderGraph every frame (as Filament and Frostbite do):
// the application keeps one GraphMemory and hands it to each frame's graph, which takes the
// arrays, arena and compile state the last graph left there and gives them back when it is
// destroyed (Filament's LinearAllocatorArena plays this part). A new graph then costs what
// reset() and a rebuild cost: no allocation and no page fault when the frame keeps its shape,
// and, like reset(), compile() takes last frame's plan over when the frame declares the same.
// One thread builds graphs from a GraphMemory at a time; a graph made while another one
// holds the memory gets memory of its own. Objects the execute callbacks captured are
// destroyed with the graph, or, while its compiled graph lives, when the next graph reuses
// the memory. What is kept lives as long as the GraphMemory or the last graph made from it.
// A RenderGraph made without one uses its thread's (for_this_thread()), so the frame loop
// written the plain way costs what this one costs.
class GraphMemory {
 public:
  GraphMemory();
  GraphMemory(const GraphMemory&) = delete;
  GraphMemory& operator=(const GraphMemory&) = delete;
  ~GraphMemory();
  // Frees what is kept now (e.g. after a frame much larger than the ones to come).
  void release();

  // The memory of the calling thread, which `RenderGraph(name)` uses. It keeps only what no
  // compiled graph still holds, and no gpu objects (transients are recreated next frame), so
  // nothing of a device outlives the device; it is freed when the thread ends or by release().
  [[nodiscard]] static GraphMemory& for_this_thread();

 private:
  std::shared_ptr<detail::KeptGraphs> kept_;
  friend class RenderGraph;
};

// ---- the graph -------------------------------------------------------------------------
class RenderGraph {
 public:
  // A graph in the memory its thread's last graph left (GraphMemory::for_this_thread()).
  explicit RenderGraph(std::string_view name = "frame");
  // A graph in memory the last graph made with `memory` left (see GraphMemory).
  RenderGraph(std::string_view name, GraphMemory& memory);
  RenderGraph(RenderGraph&&) noexcept;
  RenderGraph& operator=(RenderGraph&&) noexcept;
  ~RenderGraph();

  // Empties the graph for the next frame's passes (Frostbite's rebuild-every-frame loop),
  // keeping the memory of its arrays, its arena and its last compile's working state, so a
  // graph rebuilt with the same shape allocates nothing. Handles, the Data& add_pass
  // returned and the blackboard's entries are invalid afterwards.
  // The graph alternates between two sets of arrays, so this frame's declarations are kept
  // while the next frame's are made: when they turn out identical (the same passes declaring
  // the same uses of the same resources, the same outputs, the same compile options) and last
  // frame's compiled graph is gone, compile() reuses its plan -- order, memory, barriers and
  // the gpu objects it created -- instead of planning again (CompiledGraph::plan_reused()).
  // Keeping last frame's compiled graph while building this frame's also allocates nothing
  // (it is then not reused). Objects captured by the execute callbacks are destroyed here,
  // or, while a compiled graph still needs them, when it is gone and their arrays are reused.
  void reset();

  // Adds a pass: setup(PassBuilder&, Data&) runs now and fills Data with handles;
  // execute(const PassResources&, const Data&, PassContext&) runs at every execute() unless
  // the pass is culled. The returned Data stays valid for the graph's lifetime.
  template <class Data, class Setup, class Execute>
  Data& add_pass(std::string_view name, Setup&& setup, Execute&& execute) {
    static_assert(std::is_invocable_v<Setup&, PassBuilder&, Data&>,
                  "setup must be callable as setup(PassBuilder&, Data&)");
    static_assert(std::is_invocable_v<std::decay_t<Execute>&, const PassResources&, const Data&, PassContext&>,
                  "execute must be callable as execute(const PassResources&, const Data&, PassContext&)");
    using Fn = std::decay_t<Execute>;
    auto* data = new (detail::arena_allocate(*data_, sizeof(Data), alignof(Data))) Data{};
    auto* callable = new (detail::arena_allocate(*data_, sizeof(Fn), alignof(Fn))) Fn(std::forward<Execute>(execute));
    detail::ErasedExecute erased{data, callable, &detail::invoke_execute<Data, Fn>, nullptr};
    if constexpr (!std::is_trivially_destructible_v<Data> || !std::is_trivially_destructible_v<Fn>)
      erased.destroy = &detail::destroy_pass<Data, Fn>;
    PassBuilder builder(data_.get(), detail::begin_pass(*data_, name, erased));
    setup(builder, *data);
    detail::end_pass(*data_, builder.pass_);
    return *data;
  }

  // A pass that only declares (no execute callback): graph tests and placeholders.
  template <class Setup>
  void add_pass(std::string_view name, Setup&& setup) {
    static_assert(std::is_invocable_v<Setup&, PassBuilder&>, "setup must be callable as setup(PassBuilder&)");
    PassBuilder builder(data_.get(), detail::begin_pass(*data_, name, detail::ErasedExecute{}));
    setup(builder);
    detail::end_pass(*data_, builder.pass_);
  }

  // Persistent resources owned by the caller (LUTs, baked data, the frame output, last
  // frame's history). `initial_state` is the state the resource is in when the frame
  // starts. The descriptor-only forms need no device (graph tests); execute() then fails if
  // a pass that is not culled uses them.
  TextureHandle import_texture(std::string_view name, const gpu::Texture* texture, gpu::Access initial_state);
  TextureHandle import_texture(std::string_view name, const gpu::TextureDescriptor& desc, gpu::Access initial_state);
  BufferHandle import_buffer(std::string_view name, const gpu::Buffer* buffer, gpu::Access initial_state);
  BufferHandle import_buffer(std::string_view name, const gpu::BufferDescriptor& desc, gpu::Access initial_state);

  // What the frame produces: passes that contribute to an output are kept, the rest culled.
  // `final_state` (if not Undefined) is the state the resource is left in, e.g. CopySrc for
  // a readback.
  void mark_output(TextureHandle handle, gpu::Access final_state = gpu::Access::Undefined);
  void mark_output(BufferHandle handle, gpu::Access final_state = gpu::Access::Undefined);

  [[nodiscard]] Blackboard& blackboard();
  [[nodiscard]] const Blackboard& blackboard() const;
  [[nodiscard]] const std::string& name() const;
  [[nodiscard]] std::size_t pass_count() const;
  [[nodiscard]] std::size_t resource_count() const;
  [[nodiscard]] std::string_view resource_name(std::uint32_t index) const;
  // The latest version of the texture declared (created or imported) as `name` -- the last
  // one if the name repeats, which compile() refuses -- or an invalid handle: how a frame
  // finds an intermediate by name after its passes were added (`weft render --output NAME`).
  [[nodiscard]] TextureHandle find_texture(std::string_view name) const;
  // A texture's descriptor as declared (relative sizes unresolved: TextureSize::resolve).
  [[nodiscard]] std::optional<TextureDesc> texture_desc(TextureHandle handle) const;

  // Validates, culls, orders, plans memory and barriers. Names identify passes and resources
  // (culled(), find_pass, errors, dumps), so two passes, or two resources, with one name are
  // an error (GraphErrorKind::DuplicateName) -- a pass and a resource may share one. The compiled graph keeps what it
  // needs of this graph alive; passes added later are not part of it. After reset(), a frame
  // that declares exactly what the last one did takes the last compiled graph's plan over
  // once that is gone (see reset()): the result is the same, for the cost of a comparison.
  [[nodiscard]] std::expected<CompiledGraph, GraphErrors> compile(const CompileOptions& options = {}) const;

 private:
  std::shared_ptr<detail::GraphData> data_;
  std::shared_ptr<detail::GraphData> spare_;  // the other set of arrays reset() switches between
  std::shared_ptr<detail::KeptGraphs> memory_;  // where both go back when the graph is destroyed
  void give_back_memory();
};

// ---- the compiled graph ----------------------------------------------------------------
class CompiledGraph {
 public:
  CompiledGraph(CompiledGraph&&) noexcept;
  CompiledGraph& operator=(CompiledGraph&&) noexcept;
  ~CompiledGraph();

  // Records every pass into one command encoder (debug group + timestamps per pass), submits
  // and waits. Transient resources are created on the first call (or when the device
  // changes) in memory blocks at the aliasing offsets and reused by later calls.
  Result<FrameStats> execute(gpu::Device& device, const ExecuteOptions& options = {});

  [[nodiscard]] std::string_view name() const;
  [[nodiscard]] std::span<const std::uint32_t> order() const;  // pass indices, execution order
  [[nodiscard]] std::span<const PassInfo> passes() const;       // by declaration index
  [[nodiscard]] std::span<const ResourceInfo> resources() const;
  [[nodiscard]] std::optional<std::uint32_t> find_pass(std::string_view name) const;
  [[nodiscard]] std::optional<std::uint32_t> find_resource(std::string_view name) const;
  [[nodiscard]] bool culled(std::string_view pass_name) const;  // true also for unknown names
  [[nodiscard]] std::span<const PlannedBarrier> barriers_before(std::uint32_t pass) const;
  [[nodiscard]] std::span<const PlannedBarrier> final_barriers() const;
  [[nodiscard]] const MemoryPlan& memory() const;
  // Whether compile() took last frame's plan over (see RenderGraph::reset()).
  [[nodiscard]] bool plan_reused() const;

  // The gpu object behind a handle after execute() (transient or imported), or null.
  [[nodiscard]] const gpu::Texture* texture(TextureHandle handle) const;
  [[nodiscard]] const gpu::Buffer* buffer(BufferHandle handle) const;

  // Graphviz: passes as boxes (culled ones grey, dashed), resources as ellipses coloured by
  // aliasing group, edges labelled with the use.
  [[nodiscard]] std::string to_dot() const;
  // Order, lifetimes, memory placement and barriers as text.
  [[nodiscard]] std::string dump() const;

 private:
  explicit CompiledGraph(std::unique_ptr<detail::CompiledState> state);
  std::unique_ptr<detail::CompiledState> state_;
  friend class RenderGraph;
};

}  // namespace weft

// ---- setup's inline paths ----------------------------------------------------------------
// Defined here, out of the classes, because every declaration of every frame runs them: the
// common case is decided inline in a few comparisons (details.cppm), the rest out of line.
namespace weft {

[[gnu::always_inline]] inline TextureHandle PassBuilder::create_texture(std::string_view name, const TextureDesc& desc) {
  const std::uint32_t index = detail::add_resource(*graph_, name, ResourceType::Texture, pass_);
  detail::set_texture_desc(graph_->resources[index].texture_desc, desc);
  const gpu::Extent3D& e = desc.size.absolute;
  // A multisampled texture takes the out-of-line path too (it marks the graph for compile's
  // sample-count checks).
  const bool valid = desc.format != gpu::Format::Undefined && desc.mip_level_count != 0 && desc.sample_count == 1 &&
                     (desc.size.is_relative ? desc.size.relative.width > 0.0f && desc.size.relative.height > 0.0f
                                            : e.width != 0 && e.height != 0 && e.depth_or_layers != 0);
  if (!valid) [[unlikely]]
    detail::report_texture_desc(*graph_, index, desc, graph_->passes[pass_].name);
  return {index, 0};
}

[[gnu::always_inline]] inline TextureHandle PassBuilder::read(TextureHandle handle, TextureUse use) {
  return {handle.index, detail::declare(*graph_, pass_, ResourceType::Texture, handle.index, handle.version,
                                        detail::use_bit(use), false, access_of(use), is_write(use))};
}
[[gnu::always_inline]] inline BufferHandle PassBuilder::read(BufferHandle handle, BufferUse use) {
  return {handle.index, detail::declare(*graph_, pass_, ResourceType::Buffer, handle.index, handle.version,
                                        detail::use_bit(use), false, access_of(use), is_write(use))};
}
[[gnu::always_inline]] inline TextureHandle PassBuilder::write(TextureHandle handle, TextureUse use) {
  return {handle.index, detail::declare(*graph_, pass_, ResourceType::Texture, handle.index, handle.version,
                                        detail::use_bit(use), true, access_of(use), !is_write(use))};
}
[[gnu::always_inline]] inline BufferHandle PassBuilder::write(BufferHandle handle, BufferUse use) {
  return {handle.index, detail::declare(*graph_, pass_, ResourceType::Buffer, handle.index, handle.version,
                                        detail::use_bit(use), true, access_of(use), !is_write(use))};
}

}  // namespace weft
