// weft-scene-in-code: a scene built in C++ rather than read from a file — three spheres of
// increasing roughness and a metal torus on a floor, a key light and a sky — rendered by
// the renderer, which adds only the passes this scene needs.
//   weft-scene-in-code [out.png] [--size WxH]
#include <cstdio>
#include <cstdlib>
#include <expected>
#include <string>
#include <utility>
#include <vector>
#include <weft/args.h>
import weft.core;
import weft.gpu;
import weft.image;
import weft.scene;
import weft.renderer;
import weft.builtin_features;

using namespace weft;

namespace {

Result<scene::Scene> build_scene(std::uint32_t width, std::uint32_t height) {
  scene::Scene s;
  s.output = {width, height};
  s.camera = {.position = {0.0f, 1.6f, 5.0f}, .target = {0.0f, 0.5f, 0.0f}, .fov_y_degrees = 40.0f};
  s.environment.constant_color = {0.35f, 0.45f, 0.6f};  // a soft blue sky
  s.lights.push_back(scene::DirectionalLight{.name = "sun", .direction = {-0.4f, -1.0f, -0.5f},
                                             .color = {1.0f, 0.95f, 0.85f}, .intensity = 3.0f});
  auto sphere = scene::make_sphere(0.45f, 48);
  auto floor = scene::make_plane(8.0f, 1);
  auto torus = scene::make_torus(0.45f, 0.15f, 64, 24);
  if (!sphere) return std::unexpected(sphere.error());
  if (!floor) return std::unexpected(floor.error());
  if (!torus) return std::unexpected(torus.error());
  s.meshes = {std::move(*sphere), std::move(*floor), std::move(*torus)};

  auto material = [&](std::string name, vec3 color, float metallic, float roughness) {
    scene::Material m{.name = std::move(name)};
    m.standard.base_color = color;
    m.standard.metallic = metallic;
    m.standard.roughness = roughness;
    s.materials.push_back(m);
    return std::uint32_t(s.materials.size() - 1);
  };
  auto place = [&](std::string name, std::uint32_t mesh, std::uint32_t mat, scene::Transform t) {
    s.objects.push_back({.name = std::move(name), .mesh = mesh, .material = mat, .transform = t.matrix()});
  };
  const float roughness[] = {0.15f, 0.45f, 0.9f};
  for (int i = 0; i < 3; ++i) {
    const auto m = material("plastic-" + std::to_string(i), {0.75f, 0.15f + 0.25f * i, 0.1f}, 0.0f, roughness[i]);
    place("sphere-" + std::to_string(i), 0, m, {.translation = {-1.2f + 1.2f * i, 0.45f, 0.0f}});
  }
  place("floor", 1, material("floor", vec3(0.6f), 0.0f, 0.8f), {});
  place("ring", 2, material("gold", {1.0f, 0.78f, 0.34f}, 1.0f, 0.3f),
        {.translation = {0.0f, 0.16f, 1.1f}, .rotation = scene::Transform::rotation_from_euler_degrees({90, 0, 0})});
  return s;
}

Result<void> run(const std::string& output, std::uint32_t width, std::uint32_t height) {
  auto s = build_scene(width, height);
  if (!s) return std::unexpected(s.error());
  // The pass types the default pipeline names (shadow map, scene colour, background, tone map).
  if (auto ok = register_builtin_pass_types(); !ok) return ok;
  auto instance = gpu::Instance::create({.application_name = "weft-scene-in-code"});
  if (!instance) return std::unexpected(instance.error());
  auto adapter = instance->request_adapter();
  if (!adapter) return std::unexpected(adapter.error());
  auto device = adapter->request_device();
  if (!device) return std::unexpected(device.error());
  auto renderer = renderer::Renderer::create(*device);
  if (!renderer) return std::unexpected(renderer.error());
  auto frame = renderer->render(*s);
  if (!frame) return std::unexpected(frame.error());
  if (auto ok = image::save_png(output, frame->image); !ok) return ok;
  std::printf("%s", frame->stats.format_table().c_str());
  if (instance->validation_enabled() && instance->validation_message_count() > 0)
    return fail(ErrorKind::Internal, "{} validation messages (see above)", instance->validation_message_count());
  std::printf("wrote %s\n", output.c_str());
  return {};
}

}  // namespace

int main(int argc, char** argv) {
  std::string output = "scene_in_code.png";
  unsigned width = 800, height = 500;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    if (arg == "--size" && i + 1 < argc) {
      if (!weft::args::size_into(argv[++i], 8192, width, height)) {
        std::fprintf(stderr, "weft-scene-in-code: --size expects WxH with sides 1..8192, got '%s'\n", argv[i]);
        return 2;
      }
    } else if (arg == "-h" || arg == "--help") {
      std::printf("usage: weft-scene-in-code [out.png] [--size WxH]\n");
      return 0;
    } else if (arg.starts_with("-")) {  // not a file name: `--size` without its value, a typo
      std::fprintf(stderr, "weft-scene-in-code: unknown or incomplete argument '%s'\nusage: weft-scene-in-code [out.png] [--size WxH]\n",
                   arg.c_str());
      return 2;
    } else {
      output = arg;
    }
  }
  if (auto ok = run(output, width, height); !ok) {
    std::fprintf(stderr, "weft-scene-in-code: %s\n", ok.error().what().c_str());
    return 1;
  }
  return 0;
}
