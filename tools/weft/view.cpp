// `weft view SCENE.json [--size WxH] [--quality q] [--script FILE]`: the live viewer
// (tools/weft/view/, built when GLFW and Dear ImGui are installed).
#include <cstdio>
#include <memory>
#include <string>
#include "commands.h"
#ifdef WEFT_HAVE_VIEWER
import weft.viewer;
#endif

namespace weft::cli {

Command add_view(CLI::App& app) {
  auto* sub = app.add_subcommand("view", "Open a scene in a window: camera, knobs, per-pass times, hot reload");
  struct Options {
    std::string scene, size = "1280x720", quality = "medium", script;
    double motion_budget_ms = 100.0;
    std::string shader_dir, pipeline, scene_device = "auto";
    unsigned accumulate = 0;
  };
  auto o = std::make_shared<Options>();
  sub->add_option("scene", o->scene, "Scene file (.json, or a .gltf/.glb); edits to it are reloaded live")->required();
  sub->add_option("-s,--size", o->size, "Window size WxH")->capture_default_str();
  sub->add_option("-q,--quality", o->quality, "low | medium | high | reference")->capture_default_str();
  sub->add_option("--script", o->script, "Run a scripted session (see docs/viewer.md) and quit at its end");
  sub->add_option("--motion-budget-ms", o->motion_budget_ms,
                  "Scene frames while the camera moves aim at this time (lower resolution)")
      ->capture_default_str()
      ->check(CLI::Range(1.0, 100000.0));
  sub->add_option("--shader-dir", o->shader_dir,
                  "Hot-reload built-in shaders from files of the same names in this folder (default: their sources "
                  "in the source tree)");
  sub->add_option("--pipeline", o->pipeline,
                  "Pipeline file: the frame's passes (docs/pipelines.md); edits to it are reloaded live");
  sub->add_option("--accumulate", o->accumulate,
                  "While the camera rests, average this many frames jittered by sub-pixel offsets (the image "
                  "converges towards supersampling; 1: off; default 16, or 1 in a --script session)")
      ->check(CLI::Range(1u, 4096u));
  sub->add_option("--scene-device", o->scene_device,
                  "Where scene frames render: shared (the window's device, no CPU round trip), own (a device of "
                  "their own, pixels uploaded: keeps the UI's frames apart from a slow scene frame on a CPU "
                  "adapter), auto (own on a CPU adapter, shared on a GPU)")
      ->capture_default_str()
      ->check(CLI::IsMember({"auto", "shared", "own"}));
  return [o] {
#ifdef WEFT_HAVE_VIEWER
    const auto size = parse_size(o->size, 16384);  // digits only: sscanf's %u read "-1" as 4294967295
    if (!size) {
      std::fprintf(stderr, "weft view: --size expects WxH within 1..16384 (e.g. 1280x720), got '%s'\n", o->size.c_str());
      return 1;
    }
    viewer::ViewOptions options{.scene = o->scene, .width = size->width, .height = size->height, .quality = o->quality,
                                .motion_budget_ms = o->motion_budget_ms};
    if (!o->script.empty()) options.script = o->script;
    if (!o->shader_dir.empty()) options.shader_dir = o->shader_dir;
    if (!o->pipeline.empty()) options.pipeline = o->pipeline;
    if (o->accumulate > 0) options.refine_samples = o->accumulate;
    using SceneDevice = viewer::ViewOptions::SceneDevice;
    options.scene_device = o->scene_device == "shared" ? SceneDevice::Shared
                           : o->scene_device == "own" ? SceneDevice::Own
                                                      : SceneDevice::Auto;
    return viewer::run(options);
#else
    std::fprintf(stderr, "weft view: this weft was built without the viewer (install libglfw3-dev and libimgui-dev, "
                         "then rebuild); to render without a window: weft render %s -o out.png\n", o->scene.c_str());
    return 2;
#endif
  };
}

}  // namespace weft::cli
