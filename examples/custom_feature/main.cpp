// weft-custom-feature: an application that adds its own material feature (toon/, module
// custom.toon) to weft's built-in ones and renders a scene file that uses them together.
// Nothing under modules/, passes/ or tools/ knows "toon": this program registers it.
//
//   weft-custom-feature SCENE.json [-o out.png] [--size WxH] [--dot graph.dot] [--list] [--check]
//
// --list prints every registered feature with its knobs (the toon's among them). --check
// turns on the validation layer with synchronization validation and fails on any message,
// and checks what the example promises (how ctest runs it): the toon pass runs beside the
// built-in features' passes, the outline is there (dark pixels that vanish at width 0),
// and bad toon materials fail naming their JSON path.
#include <cstdint>
#include <cstdio>
#include <expected>
#include <filesystem>
#include <fstream>
#include <span>
#include <string>
#include <vector>
#include <weft/args.h>
import weft.core;
import weft.gpu;
import weft.image;
import weft.scene;
import weft.feature;
import weft.renderer;
import weft.builtin_features;
import custom.toon;

using namespace weft;

namespace {

int failed(const std::string& message) {
  std::fprintf(stderr, "weft-custom-feature: %s\n", message.c_str());
  return 1;
}

void print_features() {
  for (const FeatureDescriptor* f : feature_registry().all()) {
    std::printf("%s: %s (%s)\n", f->name.c_str(), f->summary.c_str(), f->doc.c_str());
    for (const Knob& k : f->knobs) std::printf("  %-18s %s\n", k.name.c_str(), k.meaning.c_str());
  }
}

bool contains(const std::vector<std::string>& names, const std::string& name) {
  for (const auto& n : names)
    if (n == name) return true;
  return false;
}

// A toon material with bad fields fails naming their JSON path; an unknown type lists "toon".
int check_errors() {
  const char* text = R"({"version": 1, "meshes": {"m": {"primitive": "cube"}},
    "materials": {"bad": {"type": "toon", "bands": 0, "outline_width": "wide", "shade": 1}},
    "objects": [{"mesh": "m", "material": "bad"}]})";
  auto desc = scene::parse_scene(text, ".", "bad.json");
  if (!desc) return failed("the bad-material scene should parse (its toon fields are the feature's): " + desc.error().what());
  auto toon = feature_registry().get(desc->materials.at(0).type);
  if (!toon) return failed(toon.error().what());
  auto bad = (*toon)->check_material(desc->materials.at(0));
  if (bad) return failed("a toon material with bands 0 was accepted");
  for (const char* path : {"$.materials.bad.bands: 0 is out of range [1, 64]", "$.materials.bad.outline_width",
                           "$.materials.bad.shade: unknown field"})
    if (bad.error().message.find(path) == std::string::npos)
      return failed(weft::format("the error does not name '{}':\n{}", path, bad.error().message));
  auto unknown = scene::parse_scene(R"({"version": 1, "materials": {"x": {"type": "tooon"}}})", ".", "typo.json");
  if (unknown || unknown.error().message.find("known: standard, shell_fur (fur)") == std::string::npos ||
      unknown.error().message.find("toon") == std::string::npos || unknown.error().message.find("$.materials.x.type") == std::string::npos)
    return failed("an unknown material type should be an error naming its path and listing toon: " +
                  (unknown ? std::string("accepted") : unknown.error().message));
  return 0;
}

// Pixels of `a` darker than `b` by more than `by` in every channel.
std::size_t darker_pixels(const image::Image8& a, const image::Image8& b, int by) {
  std::size_t n = 0;
  for (std::size_t i = 0; i + 3 < a.pixels.size(); i += 4) {
    bool darker = true;
    for (int c = 0; c < 3; ++c) darker = darker && int(a.pixels[i + c]) + by < int(b.pixels[i + c]);
    n += darker ? 1 : 0;
  }
  return n;
}

int run(int argc, char** argv) {
  std::filesystem::path scene_path, output = "custom_feature.png", dot_path;
  std::uint32_t width = 0, height = 0;
  bool check = false, list = false;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--help" || a == "-h") {
      std::printf("usage: weft-custom-feature SCENE.json [-o out.png] [--size WxH] [--dot graph.dot] [--list] [--check]\n");
      return 0;
    }
    if (a.empty() || ((a == "-o" || a == "--output" || a == "--dot" || a == "--size") && i + 1 < argc && argv[i + 1][0] == '\0'))
      return failed(weft::format("{} an empty value", a.empty() ? "an argument is" : a + " was given"));
    if (a == "--check") check = true;
    else if (a == "--list") list = true;
    else if ((a == "-o" || a == "--output") && i + 1 < argc) output = argv[++i];
    else if (a == "--dot" && i + 1 < argc) dot_path = argv[++i];
    else if (a == "--size" && i + 1 < argc) {
      if (!weft::args::size_into(argv[++i], 8192, width, height))
        return failed(weft::format("--size expects WxH with sides 1..8192, got '{}'", argv[i]));
    } else if (!a.starts_with("-") && scene_path.empty()) scene_path = a;
    else return failed(weft::format("unknown argument '{}' (see --help)", a));
  }

  // The application registers what it links: weft's features, then its own.
  if (auto ok = register_builtins(); !ok) return failed(ok.error().what());  // pass types and features
  if (auto ok = register_feature(custom::toon_feature()); !ok) return failed(ok.error().what());
  if (list) print_features();
  if (scene_path.empty()) return list ? 0 : failed("a scene file is required (see --help)");

  auto scene = scene::load_scene(scene_path);
  if (!scene) return failed(scene.error().what());
  auto instance = gpu::Instance::create(
      {.application_name = "weft-custom-feature", .validation = check, .synchronization_validation = check});
  if (!instance) return failed(instance.error().what());
  auto adapter = instance->request_adapter();
  if (!adapter) return failed(adapter.error().what());
  auto device = adapter->request_device();
  if (!device) return failed(device.error().what());
  auto renderer = renderer::Renderer::create(*device);
  if (!renderer) return failed(renderer.error().what());
  const renderer::RenderOptions options{.width = width, .height = height};

  if (!dot_path.empty()) {
    auto report = renderer->describe(*scene, options);
    if (!report) return failed(report.error().what());
    // Atomically, as weft writes every file: an unwritable path, a FIFO or a full disk is an error.
    if (auto ok = weft::write_file_atomically(dot_path, {std::as_bytes(std::span(report->dot))}, "DOT graph"); !ok)
      return failed(ok.error().what());
    std::printf("wrote %s\n", dot_path.string().c_str());
  }
  auto frame = renderer->render(*scene, options);
  if (!frame) return failed(frame.error().what());
  for (const auto& w : frame->warnings) std::printf("warning: %s\n", w.c_str());
  std::string passes;
  for (const auto& p : frame->passes) passes += (passes.empty() ? "" : " -> ") + p;
  std::printf("passes: %s\n", passes.c_str());
  if (auto saved = image::save_png(output, frame->image); !saved) return failed(saved.error().what());
  std::printf("wrote %s (%ux%u)\n", output.string().c_str(), frame->image.width, frame->image.height);
  if (!check) return 0;

  // The toon pass runs after forward, beside every built-in feature the scene uses.
  for (const char* pass : {"forward", "toon"})
    if (!contains(frame->passes, pass)) return failed(weft::format("the frame has no '{}' pass: {}", pass, passes));
  for (const FeatureDescriptor* f : feature_registry().all())
    if (f->name != "toon" && scene->uses(f->name))
      for (const auto& pass : f->passes)
        if (!contains(frame->passes, pass)) return failed(weft::format("the frame has no '{}' pass: {}", pass, passes));
  // The outline: the same scene without it loses only dark pixels.
  scene::Scene plain = *scene;
  for (auto& m : plain.materials)
    if (m.type == "toon") m.params["outline_width"] = 0;
  auto without = renderer->render(plain, options);
  if (!without) return failed(without.error().what());
  const std::size_t outline = darker_pixels(frame->image, without->image, 40);
  const std::size_t lighter = darker_pixels(without->image, frame->image, 40);
  std::printf("outline: %zu pixels darker with it, %zu lighter\n", outline, lighter);
  if (outline < 50) return failed("the outline darkens fewer than 50 pixels");
  if (lighter * 20 > outline) return failed("the outline made more than a few pixels lighter");
  if (int bad = check_errors()) return bad;
  const auto messages = instance->take_validation_messages();
  for (const auto& m : messages) std::fprintf(stderr, "validation: %s\n", m.c_str());
  if (!messages.empty()) return failed(weft::format("{} validation messages", messages.size()));
  std::printf("check passed\n");
  return 0;
}

}  // namespace

int main(int argc, char** argv) { return run(argc, argv); }
