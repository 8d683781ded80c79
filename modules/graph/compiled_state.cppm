// weft.graph:compiled_state — what compile() produces and works with, shared by the
// implementation units only (not part of the module's interface: importers never see it).
module;
#include <cstdint>
#include <memory>
#include <string>
#include <vector>
module weft.graph:compiled_state;
import weft.core;
import weft.gpu;
import :types;
import :details;

namespace weft::detail {

// compile()'s working memory, kept with the compiled state so that a recompile reuses it.
// scratch.last_pass of an output: its memory is kept to the end of the frame.
inline constexpr std::uint32_t kept_to_end = invalid_index - 1;

struct HeapBuilder;  // frame_plan.cpp
struct HeapBuilders {  // the memory planner's heaps, kept with their arrays' capacity
  HeapBuilders();
  ~HeapBuilders();
  std::vector<std::unique_ptr<HeapBuilder>> heaps;  // not moved: a heap's search tree points into it
};
struct CompileScratch {
  std::vector<std::uint8_t> alive;
  std::vector<std::uint32_t> stack;
  std::vector<std::uint32_t> last_pass;  // per resource: the last pass using it (release after it)
  std::vector<std::uint32_t> alias_group_of, alias_group_parent, alias_group_number;
  std::vector<gpu::Access> current;
  std::vector<std::uint8_t> released;
  // Textures used in parts: each one's subresource states, mip-major, from sub_begin[r].
  std::vector<std::uint32_t> sub_begin;
  std::vector<gpu::Access> sub_state;
  HeapBuilders heaps;
};

struct Realized;  // gpu objects of an executed graph (execute.cpp)

struct CompiledState {
  CompiledState();
  CompiledState(const CompiledState&) = delete;
  CompiledState& operator=(const CompiledState&) = delete;
  ~CompiledState();

  std::shared_ptr<GraphData> graph;
  CompileOptions options;
  std::uint32_t pass_count = 0, resource_count = 0;  // what this snapshot covers

  std::vector<PassInfo> passes;
  std::vector<std::uint32_t> order;
  std::vector<ResourceInfo> resources;
  std::vector<gpu::Access> resource_final_state;  // Undefined: leave as last used

  // Memory: per resource, the transients whose memory it takes over:
  // takeovers[takeover_first[r] .. takeover_first[r] + takeover_count[r]).
  std::vector<std::uint32_t> takeover_first, takeover_count;
  std::vector<std::uint32_t> takeovers;
  MemoryPlan memory;

  // Barriers: those before order position i are barriers[barrier_begin[i] .. barrier_begin[i+1]);
  // the last range (i == order.size()) is the end of the frame.
  std::vector<PlannedBarrier> barriers;
  std::vector<std::uint32_t> barrier_begin;

  std::unique_ptr<Realized> realized;
  std::uint64_t frame_index = 0;
  CompileScratch scratch;
  // What the plan was made for, to decide whether the next frame may reuse it: the options
  // compile() was given (execute() may re-plan memory for its device), and whether it was.
  gpu::Extent3D planned_output_extent{};
  const gpu::Device* planned_device = nullptr;
  bool planned_aliasing = true;
  bool planned_custom_sizes = false;
  bool reused = false;
};

// Whether `now` declares exactly what `before` did, so a plan made for one serves the other:
// the same passes with the same uses of the same resources in the same order, the same
// descriptors, imports and outputs. Names and execute callbacks may differ.
bool same_declarations(const GraphData& now, const GraphData& before);
// Destroys the gpu objects an executed plan created (execute.cpp, where they are defined).
void drop_gpu_objects(CompiledState& state);

// The state a texture is moved to when another transient first takes over (part of) its
// memory: always a different image layout than its last one, with shader stages. The layout
// change makes the release a write that the synchronization validation (and the driver)
// orders the new resource's transition after; the shader stages chain with the stages the
// new resource's barrier waits for (see execute.cpp). GENERAL (StorageRead) fits every image;
// an image last in GENERAL goes to SHADER_READ_ONLY (ShaderRead), which is why transient
// storage textures also get Sampled usage.
constexpr gpu::Access release_state(gpu::Access last) {
  const bool general = last == gpu::Access::StorageRead || last == gpu::Access::StorageWrite ||
                       last == gpu::Access::HostRead || last == gpu::Access::HostWrite;
  return general ? gpu::Access::ShaderRead : gpu::Access::StorageRead;
}

// Compile stages (one file each), run in this order by RenderGraph::compile.
// validate_and_schedule: every check, culling, the order, and scratch.last_pass.
void validate_and_schedule(const GraphData& graph, CompiledState& state, std::vector<GraphError>& errors);
// One walk over the order: lifetimes, transient memory (aliasing) and barriers. `replan` is
// for a compiled graph whose order and lifetimes are known (execute() sizing memory with its
// device's requirements); otherwise validate_and_schedule() has just run.
void plan_frame(const GraphData& graph, CompiledState& state, const gpu::Device* device, bool replan,
                std::vector<GraphError>& errors);

// Estimated memory requirements when no device is at hand.
gpu::MemoryRequirements estimate_requirements(const ResourceInfo& resource);

std::string format_extent(gpu::Extent3D extent);

}  // namespace weft::detail
