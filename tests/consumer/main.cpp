// Imports weft from the installed package as a user's project would: declares a three-pass
// graph without a device and checks it with the installed test kit (weft.graph_testing) --
// the pass that reaches no output is culled, the other two run producer first, the barrier
// between them, the memory, a golden DOT written then compared -- then checks a broken
// pipeline file's exact message and a good one, with weft's pass types registered, and a
// scene's whole frame compiled with no device (expect_scene_frame).
#include <cstdio>
#include <expected>
#include <filesystem>
#include <fstream>
#include <optional>
#include <string>
import weft.core;
import weft.gpu;
import weft.graph;
import weft.pipeline;
import weft.scene;
import weft.renderer;
import weft.graph_testing;
import weft.builtin_features;

namespace {
int failures = 0;
void check(const std::optional<std::string>& why, const char* what) {
  if (!why) return;
  std::fprintf(stderr, "%s: %s\n", what, why->c_str());
  ++failures;
}
}  // namespace

int main() {
  using namespace weft;
  RenderGraph graph("consumer");
  const TextureDesc desc{.size = gpu::Extent3D{16, 16, 1}, .format = gpu::Format::RGBA8Unorm};
  TextureHandle made;
  graph.add_pass("make", [&](PassBuilder& b) { made = b.write(b.create_texture("made", desc), TextureUse::ColorAttachment); });
  TextureHandle shown;
  graph.add_pass("show", [&](PassBuilder& b) {
    (void)b.read(made, TextureUse::Sampled);
    shown = b.write(b.create_texture("shown", desc), TextureUse::ColorAttachment);
  });
  graph.add_pass("unused", [&](PassBuilder& b) { (void)b.write(b.create_texture("unused", desc), TextureUse::ColorAttachment); });
  graph.mark_output(shown);
  auto compiled = graph.compile({.output_extent = {16, 16, 1}});
  if (!compiled) {
    std::fprintf(stderr, "compile failed: %s\n", compiled.error().to_string().c_str());
    return 1;
  }
  check(testing::expect_order(*compiled, {"make", "show"}), "order");
  check(testing::expect_culled(*compiled, {"unused"}), "culling");
  check(testing::expect_barrier(*compiled, "show", "made", gpu::Access::ColorAttachment, gpu::Access::ShaderRead), "barrier");
  check(testing::expect_aliased(*compiled, "made", "shown", false), "aliasing");  // alive at once
  check(testing::expect_transient_bytes_at_most(*compiled, 1u << 20), "memory");
  const auto dir = std::filesystem::temp_directory_path() / "weft_consumer_kit";
  std::filesystem::create_directories(dir);
  std::ofstream(dir / "graph.dot") << compiled->to_dot();  // the golden file, as a first run with WEFT_UPDATE_GOLDEN=1 writes it
  check(testing::expect_golden_dot(*compiled, dir / "graph.dot"), "golden DOT");
  // A wrong expectation must fail, or the kit proves nothing.
  if (!testing::expect_order(*compiled, {"show", "make"}) || !testing::expect_culled(*compiled, {}))
    check("a false expectation held", "the kit");

  if (auto ok = register_builtin_pass_types(); !ok) check(ok.error().message, "registering the pass types");
  std::ofstream(dir / "cycle.json") << R"({"passes": {"t": {"type": "tonemap"}}, "connections": ["t.color -> t.color"], "outputs": ["t.color"]})";
  check(testing::expect_pipeline_error(dir / "cycle.json",
                                       "parse error: cycle.json: 1 problem:\n$.connections[0]: the passes 't' feed each other "
                                       "in a cycle: t.color -> t.color"),
        "broken pipeline");
  std::ofstream(dir / "good.json") << pipeline::default_pipeline_text();
  check(testing::expect_pipeline_valid(dir / "good.json"), "default pipeline");
  // A scene's whole frame, declared and compiled with no device.
  auto description = scene::parse_scene(R"({"version": 1, "output": {"width": 32, "height": 24},
    "camera": {"position": [0, 0, 3], "target": [0, 0, 0]},
    "lights": [{"type": "directional", "direction": [0, -1, -1], "intensity": 2}],
    "meshes": {"ball": {"primitive": "sphere", "radius": 0.5}},
    "materials": {"grey": {"base_color": [0.5, 0.5, 0.5]}},
    "objects": [{"name": "ball", "mesh": "ball", "material": "grey"}]})", dir);
  auto scene = description ? scene::load_scene(*description) : Result<scene::Scene>(std::unexpected(description.error()));
  if (!scene) {
    check(scene.error().message, "the scene");
  } else {
    check(testing::expect_scene_frame(*scene, {}, [](const CompiledGraph& frame) {
            return testing::expect_order(frame, {"shadow_map", "forward", "background", "tonemap"});
          }),
          "the scene's frame without a device");
    if (!testing::expect_scene_frame(*scene, {}, [](const CompiledGraph& frame) {
          return testing::expect_order(frame, {"tonemap", "shadow_map"});
        }))
      check("a false expectation on a scene's frame held", "the kit");
  }
  std::filesystem::remove_all(dir);
  if (failures) return 1;
  std::printf("weft consumer: graph '%s' checked with weft.graph_testing, %zu of %zu passes kept; pipelines checked\n",
              graph.name().c_str(), compiled->order().size(), graph.pass_count());
  return 0;
}
