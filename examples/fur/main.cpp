// weft-fur-example: shell fur from one photograph (passes/shell_fur, docs/fur.md), rendered
// through the renderer like any scene: the paper's flat quad seen from above, band vs strand
// from an oblique view, a grazing view with and without fins, Lambert vs Kajiya-Kay, and the
// paper's two mesh sizes with 15 layers — a teapot decimated to 2,082 vertices and a cow
// resampled to 34,832 (the paper's bunny size).
//
//   weft-fur-example [--out DIR] [--photo PATH] [--size WxH] [--only NAME] [--check]
//   weft-fur-example --write-synthetic PATH     (the redistributable procedural photo)
//
// The photo defaults to ../shared/data/fur/cream_long.jpg (WEFT_SHARED_DATA), else a
// procedural one. --check renders small versions of the cheap scenes under validation and
// synchronization validation and fails on any message (ctest runs it).
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <expected>
#include <filesystem>
#include <functional>
#include <optional>
#include <string>
#include <system_error>
#include <vector>
#include <nlohmann/json.hpp>
#include <weft/args.h>
import weft.core;
import weft.feature;
import weft.gpu;
import weft.image;
import weft.scene;
import weft.renderer;
import weft.builtin_features;
import weft.pass.shell_fur;
import weft.example.fur_resample;

using namespace weft;
namespace fs = std::filesystem;

namespace {

fs::path shared_data() {
  if (const char* env = std::getenv("WEFT_SHARED_DATA")) return env;
  return fs::path(WEFT_SOURCE_DIR) / ".." / "shared" / "data";
}

fs::path first_existing(std::initializer_list<fs::path> paths) {
  for (const auto& p : paths)
    if (fs::exists(p)) return p;
  return {};
}

struct Shot {
  std::string name;
  scene::Mesh mesh;
  nlohmann::json material;
  scene::Camera camera;
  vec3 light_direction{-0.35f, -1.0f, -0.55f};
  float light_intensity = 3.0f;
  vec3 sky{0.22f, 0.24f, 0.28f};
  mat4 transform{1.0f};
};

scene::Scene make_scene(const Shot& shot, std::uint32_t w, std::uint32_t h) {
  scene::Scene s;
  s.output = {w, h};
  s.camera = shot.camera;
  s.meshes = {shot.mesh};
  scene::Material m;
  m.name = "fur";
  m.type = passes::shell_fur_feature().name;
  m.params = shot.material;
  m.json_path = "$.materials.fur";
  s.materials = {m};
  s.objects = {scene::Object{.name = shot.name, .mesh = 0, .material = 0, .transform = shot.transform}};
  if (shot.light_intensity > 0.0f)
    s.lights = {scene::DirectionalLight{.name = "key", .direction = shot.light_direction, .intensity = shot.light_intensity}};
  s.environment.constant_color = shot.sky;
  return s;
}

scene::Camera look(vec3 position, vec3 target = vec3(0), vec3 up = vec3(0, 1, 0), float fov = 40.0f) {
  return scene::Camera{.position = position, .target = target, .up = up, .fov_y_degrees = fov, .near = 0.02f, .far = 50.0f};
}

Result<scene::Mesh> load_normalized(const fs::path& path) {
  return scene::load_mesh(path, {.normalize_to_unit_box = true});
}

int run(int argc, char** argv) {
  // This program links one feature and registers it, as any application does.
  // The frame's pass types (the default pipeline's shadow map, scene colour, background, tone map).
  if (auto ok = weft::register_builtin_pass_types(); !ok) {
    std::fprintf(stderr, "%s\n", ok.error().what().c_str());
    return 1;
  }
  if (auto ok = register_feature(passes::shell_fur_feature()); !ok) {
    std::fprintf(stderr, "%s\n", ok.error().what().c_str());
    return 1;
  }
  fs::path out = "fur-images", photo;
  std::uint32_t width = 512, height = 512;
  std::string only;
  bool check = false;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if ((a == "--out" || a == "--photo" || a == "--only" || a == "--write-synthetic") && i + 1 < argc && argv[i + 1][0] == '\0') {
      std::fprintf(stderr, "weft-fur-example: %s was given an empty value\n", a.c_str());
      return 2;
    }
    if (a == "--out" && i + 1 < argc) {
      out = argv[++i];
    } else if (a == "--photo" && i + 1 < argc) {
      photo = argv[++i];
    } else if (a == "--only" && i + 1 < argc) {
      only = argv[++i];
    } else if (a == "--size" && i + 1 < argc) {
      if (!weft::args::size_into(argv[++i], 8192, width, height)) {
        std::fprintf(stderr, "weft-fur-example: --size wants WxH with sides 1..8192 (e.g. 512x512), got '%s'\n", argv[i]);
        return 2;
      }
    } else if (a == "--check") {
      check = true;
    } else if (a == "--write-synthetic" && i + 1 < argc) {
      const auto img = fur::synthesize_fur_photo({.width = 256, .height = 256});
      if (auto ok = image::save_png(argv[++i], img); !ok) {
        std::fprintf(stderr, "%s\n", ok.error().what().c_str());
        return 1;
      }
      return 0;
    } else if (a == "-h" || a == "--help") {
      std::printf("usage: weft-fur-example [--out DIR] [--photo PATH] [--size WxH] [--only NAME] [--check]\n"
                  "       weft-fur-example --write-synthetic PATH\n");
      return 0;
    } else {
      std::fprintf(stderr, "weft-fur-example: unknown or incomplete argument '%s'\n"
                           "usage: weft-fur-example [--out DIR] [--photo PATH] [--size WxH] [--only NAME] [--check]\n"
                           "       weft-fur-example --write-synthetic PATH\n", a.c_str());
      return 2;
    }
  }
  if (check) width = height = std::min(width, 96u);
  // A photo that cannot be read is one error before any work (issue 33: each of the images
  // reported it again, 25 lines), and a folder that cannot be made is named, not thrown.
  if (!photo.empty())
    if (auto ok = image::load_ldr(photo); !ok) {
      std::fprintf(stderr, "weft-fur-example: --photo: %s\n", ok.error().what().c_str());
      return 1;
    }
  std::error_code made_error;
  const bool made_out = fs::create_directories(out, made_error);
  if (made_error) {
    std::fprintf(stderr, "weft-fur-example: --out '%s': %s\n", out.string().c_str(), made_error.message().c_str());
    return 1;
  }
  if (photo.empty()) photo = first_existing({shared_data() / "fur" / "cream_long.jpg"});
  if (photo.empty() || check) {
    photo = out / "synthetic_fur.png";
    if (auto ok = image::save_png(photo, fur::synthesize_fur_photo({.width = 256, .height = 256})); !ok) {
      std::fprintf(stderr, "%s\n", ok.error().what().c_str());
      return 1;
    }
  }
  photo = fs::absolute(photo);
  std::printf("photo: %s\n", photo.string().c_str());

  auto instance = gpu::Instance::create({.application_name = "weft-fur-example", .validation = check,
                                         .synchronization_validation = check});
  if (!instance) return std::fprintf(stderr, "%s\n", instance.error().what().c_str()), 1;
  auto adapter = instance->request_adapter();
  if (!adapter) return std::fprintf(stderr, "%s\n", adapter.error().what().c_str()), 1;
  auto device = adapter->request_device();
  if (!device) return std::fprintf(stderr, "%s\n", device.error().what().c_str()), 1;
  std::printf("adapter: %s (%s)\n", adapter->info().name.c_str(), adapter->info().driver.c_str());
  auto renderer = renderer::Renderer::create(*device);
  if (!renderer) return std::fprintf(stderr, "%s\n", renderer.error().what().c_str()), 1;

  auto quad = scene::make_plane(1.0f, 1);
  if (!quad) return std::fprintf(stderr, "%s\n", quad.error().what().c_str()), 1;
  const std::string p = photo.string();
  auto fur = [&](std::uint32_t layers, float thickness) {
    return nlohmann::json{{"photo", p}, {"layers", layers}, {"thickness", thickness}};
  };

  std::vector<std::function<Result<Shot>()>> shots;
  // The paper's figure 3: a square seen from straight above, 8 layers, Lambert, lit from above.
  shots.push_back([&]() -> Result<Shot> {
    Shot s{"quad_top", *quad, fur(8, 0.04f), look({0, 1.25f, 0}, vec3(0), {0, 0, -1}, 45.0f)};
    s.material["lighting"] = "lambert";
    s.light_direction = {0, -1, 0};
    s.light_intensity = pi;
    s.sky = vec3(0.0f);
    return s;
  });
  for (const char* layout : {"band", "strand"})
    shots.push_back([&, layout]() -> Result<Shot> {
      Shot s{std::string("quad_oblique_") + layout, *quad, fur(15, 0.12f), look({0, 0.75f, 0.95f}, {0, 0.02f, 0.05f})};
      s.material["layout"] = layout;
      s.material["fins"] = false;
      return s;
    });
  for (const char* layout : {"band", "strand"})
    shots.push_back([&, layout]() -> Result<Shot> {
      auto sphere = scene::make_sphere(0.5f, 64);
      if (!sphere) return std::unexpected(sphere.error());
      Shot s{std::string("sphere_") + layout, *sphere, fur(15, 0.07f), look({0, 0.6f, 2.0f}, vec3(0), {0, 1, 0}, 38.0f)};
      s.material["layout"] = layout;
      s.material["uv_scale"] = {3, 1.5};
      s.light_direction = {-0.8f, -0.4f, -0.6f};
      return s;
    });
  for (bool fins : {false, true})
    shots.push_back([&, fins]() -> Result<Shot> {
      auto sphere = scene::make_sphere(0.5f, 64);
      if (!sphere) return std::unexpected(sphere.error());
      Shot s{std::string("sphere_fins_") + (fins ? "on" : "off"), *sphere, fur(15, 0.09f), look({0, 0.25f, 2.2f}, vec3(0), {0, 1, 0}, 38.0f)};
      s.material["fins"] = fins;
      s.material["uv_scale"] = {3, 1.5};
      s.light_direction = {0.4f, -0.5f, -1.0f};
      return s;
    });
  for (const char* lighting : {"lambert", "kajiya_kay"})
    shots.push_back([&, lighting]() -> Result<Shot> {
      auto sphere = scene::make_sphere(0.5f, 64);
      if (!sphere) return std::unexpected(sphere.error());
      Shot s{std::string("sphere_") + lighting, *sphere, fur(15, 0.07f), look({0, 0.6f, 2.0f}, vec3(0), {0, 1, 0}, 38.0f)};
      s.material["lighting"] = lighting;
      s.material["uv_scale"] = {3, 1.5};
      s.light_direction = {-0.8f, -0.4f, -0.6f};
      return s;
    });
  if (!check) {
    // The paper's table 1: a 2,082-vertex teapot and a 34,832-vertex bunny, 15 layers.
    shots.push_back([&]() -> Result<Shot> {
      const fs::path teapot = first_existing({shared_data() / "meshes" / "teapot" / "teapot.obj"});
      auto source = teapot.empty() ? scene::make_sphere(0.5f, 64) : load_normalized(teapot);
      if (!source) return std::unexpected(source.error());
      auto mesh = examples::resample(*source, 2082);
      if (!mesh) return std::unexpected(mesh.error());
      mesh->name = "teapot_2082";
      const scene::Bounds bounds = mesh->bounds;
      Shot s{"teapot_2k", std::move(*mesh), fur(15, 0.035f), scene::camera_framing(bounds, 40.0f)};
      s.material["uv_scale"] = {2, 2};
      return s;
    });
    shots.push_back([&]() -> Result<Shot> {
      const fs::path spot = first_existing({fs::path(WEFT_SOURCE_DIR) / "assets" / "meshes" / "spot" / "spot_triangulated.obj",
                                            shared_data() / "meshes" / "spot" / "spot_triangulated.obj"});
      auto source = spot.empty() ? scene::make_sphere(0.5f, 64) : load_normalized(spot);
      if (!source) return std::unexpected(source.error());
      auto mesh = examples::resample(*source, 34832);
      if (!mesh) return std::unexpected(mesh.error());
      mesh->name = "spot_34832";
      const scene::Bounds bounds = mesh->bounds;
      Shot s{"spot_35k", std::move(*mesh), fur(15, 0.03f), scene::camera_framing(bounds, 40.0f)};
      s.camera.position = vec3(1.0f, 0.45f, -1.3f);  // from the front left, the face in view
      s.material["uv_scale"] = {3, 3};
      return s;
    });
  }

  std::printf("| image | vertices | layers | shell_fur GPU ms | frame ms |\n|---|---:|---:|---:|---:|\n");
  int failures = 0, rendered = 0;
  std::string names;
  for (const auto& make : shots) {
    auto shot = make();
    if (!shot) {
      std::fprintf(stderr, "%s\n", shot.error().what().c_str());
      ++failures;
      continue;
    }
    names += (names.empty() ? "" : ", ") + shot->name;
    if (!only.empty() && shot->name.find(only) == std::string::npos) continue;
    ++rendered;
    const scene::Scene s = make_scene(*shot, width, height);
    auto frame = renderer->render(s);
    if (!frame) {
      std::fprintf(stderr, "%s: %s\n", shot->name.c_str(), frame.error().what().c_str());
      ++failures;
      continue;
    }
    for (const auto& w : frame->warnings) std::printf("  warning: %s\n", w.c_str());
    double fur_ms = -1.0;
    for (const auto& pass : frame->stats.passes)
      if (pass.name == "shell_fur") fur_ms = pass.gpu_ms;
    const fs::path file = out / (shot->name + ".png");
    if (auto ok = image::save_png(file, frame->image); !ok) {
      std::fprintf(stderr, "%s\n", ok.error().what().c_str());
      ++failures;
      continue;
    }
    std::printf("| %s | %zu | %d | %.2f | %.1f |\n", file.string().c_str(), shot->mesh.vertex_count(),
                shot->material.value("layers", 15), fur_ms, frame->stats.cpu_frame_ms);
  }
  if (!only.empty() && rendered == 0) {
    std::fprintf(stderr, "weft-fur-example: --only '%s' names none of the images (%s)\n", only.c_str(), names.c_str());
    if (made_out) fs::remove(out, made_error);  // the folder this run made, still empty
    return 2;
  }
  if (check) {
    const auto messages = instance->take_validation_messages();
    for (const auto& m : messages) std::fprintf(stderr, "validation: %s\n", m.c_str());
    if (!messages.empty()) ++failures;
  }
  return failures == 0 ? 0 : 1;
}

}  // namespace

int main(int argc, char** argv) { return run(argc, argv); }
