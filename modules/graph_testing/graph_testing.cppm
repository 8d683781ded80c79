// weft.graph_testing — the test kit for users' own frames, installed with weft: expectations
// on a compiled graph (order, culling, barriers, memory), on a failed compile (the kind of
// error, the passes and resources it names, its message) and a golden DOT file, plus a
// pipeline file and a scene's whole frame checked without a device. Every check returns nothing when it holds and a
// message saying what differs otherwise, so it works with any test framework:
//   if (auto why = weft::testing::expect_order(compiled, {"shadow_map", "forward"})) FAIL(*why);
module;
#include <cstdint>
#include <filesystem>
#include <functional>
#include <optional>
#include <string>
#include <string_view>
#include <vector>
export module weft.graph_testing;
import weft.core;
import weft.gpu;
import weft.graph;
import weft.pipeline;
import weft.scene;
import weft.renderer;

export namespace weft::testing {

using Failure = std::optional<std::string>;

// These passes all run, in this order (other passes may run between them).
Failure expect_order(const CompiledGraph& graph, const std::vector<std::string>& passes);
// Exactly these passes are culled (in any order).
Failure expect_culled(const CompiledGraph& graph, const std::vector<std::string>& culled);
// Before `pass`, the graph moves `resource` from `before` to `after`.
Failure expect_barrier(const CompiledGraph& graph, std::string_view pass, std::string_view resource, gpu::Access before,
                       gpu::Access after);
// No barrier before `pass` touches `resource`.
Failure expect_no_barrier(const CompiledGraph& graph, std::string_view pass, std::string_view resource);
// Two transients share memory (the same alias group), or do not.
Failure expect_aliased(const CompiledGraph& graph, std::string_view a, std::string_view b, bool aliased = true);
// The transients fit in at most this many bytes once aliased.
Failure expect_transient_bytes_at_most(const CompiledGraph& graph, std::uint64_t bytes);

// A failed compile reported an error of `kind` naming at least these passes and resources,
// its message containing `message_part`.
Failure expect_error(const GraphErrors& errors, GraphErrorKind kind, const std::vector<std::string>& passes = {},
                     const std::vector<std::string>& resources = {}, std::string_view message_part = {});

// The graph's DOT equals the golden file's. With WEFT_UPDATE_GOLDEN=1 in the environment the
// file is (re)written instead and the check holds: review the diff before committing it.
Failure expect_golden_dot(const CompiledGraph& graph, const std::filesystem::path& golden);

// A pipeline file read and checked against the registered pass types, with no device: types,
// options, slots, formats, sizes, cycles, outputs (weft::pipeline::load_pipeline).
Failure expect_pipeline_valid(const std::filesystem::path& file);
// It fails, with exactly this message (Error::what(), the file's folder left out).
Failure expect_pipeline_error(const std::filesystem::path& file, std::string_view message);

// A scene's whole frame (its pipeline, or options.pipeline / pipeline_file; the features its
// materials use) declared and compiled with no adapter (weft::renderer::describe on a
// declaring device), then `check` run on the compiled graph. Fails with the frame's error
// when it does not compile. Register the pass types and features first
// (weft::register_builtins(), plugins).
Failure expect_scene_frame(const scene::Scene& scene, const renderer::RenderOptions& options,
                           const std::function<Failure(const CompiledGraph&)>& check);
// The same scene's frame fails to compile, its message containing `message_part`.
Failure expect_scene_frame_error(const scene::Scene& scene, const renderer::RenderOptions& options,
                                 std::string_view message_part);

}  // namespace weft::testing
