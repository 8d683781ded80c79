// weft-skin-example: pre-integrated skin (SkinSSSPass) in scenes built in C++.
//   weft-skin-example [out-dir] [--size WxH] [--head PATH] [--check]
// Writes into out-dir (default: skin-out):
//   lut_adaptive.png, lut_penner.png, lut_specular.png  the LUTs (sRGB pictures of linear data)
//   spheres.png        five spheres of increasing curvature (1/r = 1/16 … 1 mm⁻¹, left to right);
//                      rows: Lambert + GGX, skin with Penner's range, skin with the adaptive range
//   pores.png          a detail normal map with pores: one normal for all channels (left) and
//                      per-channel blurred normals (right)
//   ear.png            a backlit ear-like thin shell with transmittance (left) and without (right)
//   head_*.png         the head scan (../shared/data or assets/ or --head), if present, with its
//                      albedo, normal and specular maps when they lie beside it: standard and skin
//                      under a grazing light and their difference (head_difference.png, x4),
//                      standard and skin front-lit, Penner and adaptive, backlit with transmittance
// --check runs under the validation layer (with synchronization validation) and fails on any
// message; ctest runs it that way at a small size.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <expected>
#include <filesystem>
#include <optional>
#include <random>
#include <string>
#include <utility>
#include <vector>
#include <glm/glm.hpp>
#include <nlohmann/json.hpp>
#include <weft/args.h>
import weft.core;
import weft.feature;
import weft.gpu;
import weft.image;
import weft.scene;
import weft.renderer;
import weft.builtin_features;
import weft.pass.skin_sss;

using namespace weft;
namespace fs = std::filesystem;

namespace {

struct Options {
  fs::path out = "skin-out";
  std::uint32_t width = 960, height = 600;
  std::string head;
  bool check = false;
};

// The head scan is a bust: its head is 0.167 units wide and 0.222 long at the forehead, which
// an adult head is in 150-155 and 190-195 mm: about 900 mm per unit.
constexpr float kHeadMmPerUnit = 900.0f;
const vec3 kSkinAlbedo{0.84f, 0.6f, 0.5f};

scene::Material skin(std::string name, nlohmann::json params) {
  scene::Material m{.name = std::move(name), .type = passes::skin_sss_feature().name};
  if (!params.contains("albedo")) params["albedo"] = {kSkinAlbedo.x, kSkinAlbedo.y, kSkinAlbedo.z};
  m.params = std::move(params);
  return m;
}

scene::Material standard(std::string name) {
  scene::Material m{.name = std::move(name)};
  m.standard.base_color = kSkinAlbedo;
  m.standard.roughness = 0.45f;
  return m;
}

std::uint32_t add(scene::Scene& s, scene::Material m) {
  s.materials.push_back(std::move(m));
  return std::uint32_t(s.materials.size() - 1);
}

void place(scene::Scene& s, std::uint32_t mesh, std::uint32_t material, vec3 at, std::string name) {
  s.objects.push_back({.name = std::move(name), .mesh = mesh, .material = material,
                       .transform = scene::Transform{.translation = at}.matrix()});
}

scene::Scene base_scene(const Options& o, vec3 light_direction, float light = 3.0f) {
  scene::Scene s;
  s.output = {o.width, o.height};
  s.environment.constant_color = vec3(0.04f, 0.045f, 0.05f);
  s.lights.push_back(scene::DirectionalLight{.name = "key", .direction = light_direction, .intensity = light});
  return s;
}

// Unit spheres whose material says how many mm a unit is: same size on screen, curvature
// 1/r from 1/16 to 1 per mm. Rows: standard, Penner's range, the adaptive range.
Result<scene::Scene> spheres(const Options& o) {
  // Light from the right, a little above and in front; a distant camera keeps every sphere seen
  // head-on, so the terminator falls at the same place on each.
  scene::Scene s = base_scene(o, {-1.0f, -0.3f, -0.45f});
  s.camera = {.position = {0.0f, 0.0f, 80.0f}, .target = {0.0f, 0.0f, 0.0f}, .fov_y_degrees = 7.0f, .near = 40.0f,
              .far = 120.0f};
  auto sphere = scene::make_sphere(1.0f, 96);
  if (!sphere) return std::unexpected(sphere.error());
  s.meshes.push_back(std::move(*sphere));
  const float radii_mm[] = {16.0f, 8.0f, 4.0f, 2.0f, 1.0f};
  const auto plain = add(s, standard("standard"));
  for (int i = 0; i < 5; ++i) {
    const float x = -6.0f + 3.0f * i;
    place(s, 0, plain, {x, 2.5f, 0.0f}, weft::format("standard {}", i));
    for (int row = 0; row < 2; ++row) {
      const char* range = row == 0 ? "penner" : "adaptive";
      const auto m = add(s, skin(weft::format("{} r={}", range, radii_mm[i]),
                                 {{"mm_per_unit", radii_mm[i]}, {"transmittance", false}, {"lut", {{"range", range}}}}));
      place(s, 0, m, {x, row == 0 ? 0.0f : -2.5f, 0.0f}, weft::format("{} {}", range, i));
    }
  }
  return s;
}

// A tangent-space normal map of round pits (pores) on a fine grid.
Result<fs::path> write_pores(const fs::path& dir) {
  const std::uint32_t n = 512;
  image::Image8 img = image::Image8::filled(n, n, 3, 0);
  std::vector<float> height(std::size_t(n) * n, 0.0f);
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  for (int k = 0; k < 2600; ++k) {
    const float cx = u(rng) * n, cy = u(rng) * n, r = 2.0f + 3.0f * u(rng);
    for (int dy = -8; dy <= 8; ++dy)
      for (int dx = -8; dx <= 8; ++dx) {
        const float d2 = float(dx * dx + dy * dy) / (r * r);
        const std::uint32_t x = (std::uint32_t(cx) + dx + n) % n, y = (std::uint32_t(cy) + dy + n) % n;
        height[std::size_t(y) * n + x] -= std::exp(-2.0f * d2);
      }
  }
  for (std::uint32_t y = 0; y < n; ++y)
    for (std::uint32_t x = 0; x < n; ++x) {
      const float hx = height[std::size_t(y) * n + (x + 1) % n] - height[std::size_t(y) * n + (x + n - 1) % n];
      const float hy = height[std::size_t((y + 1) % n) * n + x] - height[std::size_t((y + n - 1) % n) * n + x];
      const vec3 nrm = glm::normalize(vec3(-hx * 1.5f, -hy * 1.5f, 1.0f));
      for (int c = 0; c < 3; ++c) img.at(x, y, c) = std::uint8_t(std::lround((nrm[c] * 0.5f + 0.5f) * 255.0f));
    }
  const fs::path path = dir / "pores_normal.png";
  if (auto ok = image::save_png(path, img); !ok) return std::unexpected(ok.error());
  return path;
}

Result<scene::Scene> pores(const Options& o, const fs::path& normal_map) {
  scene::Scene s = base_scene(o, {-1.0f, -0.4f, -0.6f});
  s.camera = {.position = {0.0f, 0.0f, 24.0f}, .target = {0.0f, 0.0f, 0.0f}, .fov_y_degrees = 7.5f};
  auto sphere = scene::make_sphere(1.0f, 128);
  if (!sphere) return std::unexpected(sphere.error());
  for (auto& uv : sphere->uvs) uv *= vec2(2.0f, 1.0f);  // the pores twice around the ball
  s.meshes.push_back(std::move(*sphere));
  const nlohmann::json common = {{"mm_per_unit", 30.0}, {"normal_texture", normal_map.string()}, {"normal_strength", 1.0}};
  nlohmann::json same = common, blurred = common;
  same["normal_blur"] = {0.0, 0.0, 0.0};
  blurred["normal_blur"] = {0.9, 0.6, 0.4};
  place(s, 0, add(s, skin("one normal", same)), {-1.2f, 0.0f, 0.0f}, "one normal");
  place(s, 0, add(s, skin("blurred per channel", blurred)), {1.2f, 0.0f, 0.0f}, "blurred per channel");
  return s;
}

// An ellipsoid: a unit sphere scaled in its own vertices, so curvature and normals are right.
Result<scene::Mesh> ellipsoid(vec3 radii, std::uint32_t segments) {
  auto mesh = scene::make_sphere(1.0f, segments);
  if (!mesh) return mesh;
  for (auto& p : mesh->positions) p *= radii;
  mesh->normals.clear();
  mesh->tangents.clear();
  if (auto ok = scene::prepare_mesh(*mesh); !ok) return std::unexpected(ok.error());
  mesh->name = "ellipsoid";
  return mesh;
}

// An ear-like shell, 22 x 32 mm and 3 mm thick at most, backlit; the right one has no transmittance.
Result<scene::Scene> ear(const Options& o) {
  scene::Scene s = base_scene(o, {0.35f, -0.3f, 1.0f}, 4.0f);  // from behind, slightly above
  s.camera = {.position = {0.0f, 0.0f, 140.0f}, .target = {0.0f, 0.0f, 0.0f}, .fov_y_degrees = 30.0f, .near = 1.0f,
              .far = 500.0f};
  auto shell = ellipsoid({22.0f, 32.0f, 1.5f}, 128);
  if (!shell) return std::unexpected(shell.error());
  s.meshes.push_back(std::move(*shell));
  const auto on = add(s, skin("transmittance", {{"mm_per_unit", 1.0}}));
  const auto off = add(s, skin("no transmittance", {{"mm_per_unit", 1.0}, {"transmittance", false}}));
  const scene::Transform tilt{.rotation = scene::Transform::rotation_from_euler_degrees({0.0f, 25.0f, 0.0f})};
  for (int i = 0; i < 2; ++i) {
    scene::Transform t = tilt;
    t.translation = {i == 0 ? -28.0f : 28.0f, 0.0f, 0.0f};
    s.objects.push_back({.name = i == 0 ? "ear" : "ear (off)", .mesh = 0, .material = i == 0 ? on : off, .transform = t.matrix()});
  }
  return s;
}

std::optional<fs::path> find_head(const Options& o) {
  std::vector<fs::path> candidates;
  if (!o.head.empty()) candidates.emplace_back(o.head);
  if (const char* d = std::getenv("WEFT_SHARED_DATA")) candidates.push_back(fs::path(d) / "meshes/head/head.obj");
  for (const char* c : {"assets/meshes/head/head.obj", "../shared/data/meshes/head/head.obj"})
    candidates.emplace_back(c);
  for (const auto& c : candidates)
    if (fs::exists(c)) return c;
  return std::nullopt;
}

struct HeadMaps {
  fs::path albedo, normal, specular;
  [[nodiscard]] bool found() const { return !albedo.empty(); }
};

// The scan's maps in the mesh's folder (names as the scan ships them), if all three are there.
HeadMaps find_head_maps(const fs::path& mesh) {
  const fs::path dir = mesh.parent_path();
  HeadMaps m{dir / "Map-COL.jpg", dir / "Infinite-Level_02_Tangent_SmoothUV.jpg", dir / "Map-SPEC.jpg"};
  if (fs::exists(m.albedo) && fs::exists(m.normal) && fs::exists(m.specular)) return m;
  std::printf("the head's maps are not beside %s: the head is drawn with constant colours\n", mesh.string().c_str());
  return {};
}

// |a - b| of two renders, per channel, times 4 so small differences show. Printed: the mean of
// each channel of a and of b, and of |a - b|, over the object's pixels (those where a is not
// the background, its top-left pixel's colour).
Result<void> save_difference(const fs::path& a_path, const fs::path& b_path, const fs::path& out) {
  auto a = image::load_png(a_path);
  if (!a) return std::unexpected(a.error());
  auto b = image::load_png(b_path);
  if (!b) return std::unexpected(b.error());
  if (a->width != b->width || a->height != b->height || a->channels != b->channels)
    return fail(ErrorKind::InvalidArgument, "'{}' and '{}' differ in size", a_path.string(), b_path.string());
  image::Image8 diff = *a;
  const std::size_t channels = a->channels, pixels = std::size_t(a->width) * a->height;
  double sum_a[3] = {0, 0, 0}, sum_b[3] = {0, 0, 0}, sum_d[3] = {0, 0, 0};
  std::size_t object = 0;
  for (std::size_t p = 0; p < pixels; ++p) {
    bool background = true;
    for (std::size_t c = 0; c < 3; ++c) background = background && a->pixels[p * channels + c] == a->pixels[c];
    if (!background) ++object;
    for (std::size_t c = 0; c < 3; ++c) {
      const std::size_t i = p * channels + c;
      const int d = std::abs(int(a->pixels[i]) - int(b->pixels[i]));
      diff.pixels[i] = std::uint8_t(std::min(255, 4 * d));
      if (background) continue;
      sum_a[c] += a->pixels[i];
      sum_b[c] += b->pixels[i];
      sum_d[c] += d;
    }
  }
  if (auto ok = image::save_png(out, diff); !ok) return ok;
  const double n = double(std::max<std::size_t>(object, 1));
  std::printf("wrote %s; over the %zu object pixels, mean sRGB codes: %s %.0f,%.0f,%.0f, %s %.0f,%.0f,%.0f, "
              "|difference| %.1f,%.1f,%.1f\n",
              out.string().c_str(), object, a_path.filename().string().c_str(), sum_a[0] / n, sum_a[1] / n, sum_a[2] / n,
              b_path.filename().string().c_str(), sum_b[0] / n, sum_b[1] / n, sum_b[2] / n, sum_d[0] / n, sum_d[1] / n,
              sum_d[2] / n);
  return {};
}

Result<scene::Scene> head_scene(const Options& o, const fs::path& path, scene::Material material, vec3 light_direction,
                                vec3 eye, vec3 target) {
  scene::Scene s = base_scene(o, light_direction, 4.0f);
  s.camera = {.position = eye, .target = target, .fov_y_degrees = 32.0f, .near = 0.05f, .far = 5.0f};
  auto mesh = scene::load_mesh(path);
  if (!mesh) return std::unexpected(mesh.error());
  s.meshes.push_back(std::move(*mesh));
  place(s, 0, add(s, std::move(material)), vec3(0.0f), "head");
  return s;
}

Result<void> save(renderer::Renderer& r, const scene::Scene& s, const fs::path& path) {
  auto frame = r.render(s);
  if (!frame) return with_context(path.filename().string(), frame.error());
  for (const auto& w : frame->warnings) log::warn(w);
  if (auto ok = image::save_png(path, frame->image); !ok) return ok;
  std::printf("wrote %s (%.1f ms GPU)\n", path.string().c_str(), frame->stats.gpu_total_ms);
  return {};
}

Result<void> run(const Options& o) {
  std::error_code ec;
  fs::create_directories(o.out, ec);
  for (auto [name, range] : {std::pair{"lut_adaptive.png", skin::IntegrationRange::Adaptive},
                             std::pair{"lut_penner.png", skin::IntegrationRange::Penner}}) {
    auto lut = skin::cached_lut({.range = range});
    if (!lut) return std::unexpected(lut.error());
    if (auto ok = skin::save_lut(o.out / name, **lut); !ok) return ok;
    if (range == skin::IntegrationRange::Adaptive) {
      image::Image spec = image::Image::filled((*lut)->width, (*lut)->height, 1);
      for (std::size_t i = 0; i < (*lut)->texels.size(); ++i) spec.pixels[i] = (*lut)->texels[i].a;
      if (auto ok = image::save_png(o.out / "lut_specular.png", image::to_srgb8(spec)); !ok) return ok;
    }
  }
  std::printf("wrote the LUTs into %s\n", o.out.string().c_str());

  auto instance = gpu::Instance::create({.application_name = "weft-skin-example", .validation = o.check,
                                         .synchronization_validation = o.check});
  if (!instance) return std::unexpected(instance.error());
  auto adapter = instance->request_adapter();
  if (!adapter) return std::unexpected(adapter.error());
  auto device = adapter->request_device();
  if (!device) return std::unexpected(device.error());
  auto r = renderer::Renderer::create(*device);
  if (!r) return std::unexpected(r.error());

  auto sphere_scene = spheres(o);
  if (!sphere_scene) return std::unexpected(sphere_scene.error());
  if (auto ok = save(*r, *sphere_scene, o.out / "spheres.png"); !ok) return ok;
  auto normal_map = write_pores(o.out);
  if (!normal_map) return std::unexpected(normal_map.error());
  auto pore_scene = pores(o, *normal_map);
  if (!pore_scene) return std::unexpected(pore_scene.error());
  if (auto ok = save(*r, *pore_scene, o.out / "pores.png"); !ok) return ok;
  auto ear_scene = ear(o);
  if (!ear_scene) return std::unexpected(ear_scene.error());
  if (auto ok = save(*r, *ear_scene, o.out / "ear.png"); !ok) return ok;

  if (const auto head = find_head(o)) {
    // The scan's own maps beside the mesh (assets/meshes/head/, CC BY 3.0): albedo, tangent-
    // space normals and specular intensity. Both materials take them; skin blurs the normal
    // map per channel and scales rho_s by the specular map.
    const HeadMaps maps = find_head_maps(*head);
    nlohmann::json mm = {{"mm_per_unit", kHeadMmPerUnit}};
    if (maps.found()) {
      mm["albedo"] = {1.0, 1.0, 1.0};
      mm["albedo_texture"] = maps.albedo.string();
      mm["normal_texture"] = maps.normal.string();
      mm["specular_texture"] = maps.specular.string();
    }
    const auto standard_head = [&](std::string name) {
      scene::Material m = standard(std::move(name));
      if (maps.found()) {
        m.standard.base_color = vec3(1.0f);
        m.standard.base_color_texture.path = maps.albedo;
        m.standard.normal_texture.path = maps.normal;
      }
      return m;
    };
    const vec3 front_left{-0.75f, -0.2f, -0.65f};
    struct Shot {
      const char* file;
      scene::Material material;
      vec3 light;
      vec3 eye;
      vec3 target{0.0f, -0.08f, 0.0f};
    };
    nlohmann::json penner = mm, adaptive = mm, back = mm;
    penner["lut"] = {{"range", "penner"}};
    adaptive["lut"] = {{"range", "adaptive"}};
    // A light that grazes the face from the side, nearly along it: what skin does to relief
    // (pores, wrinkles) and to the terminator shows most there.
    const vec3 grazing{-1.0f, -0.15f, 0.12f};
    const Shot shots[] = {
        {"head_standard_grazing.png", standard_head("head standard grazing"), grazing, {0.0f, 0.0f, 0.62f}, {0.0f, -0.02f, 0.0f}},
        {"head_skin_grazing.png", skin("head skin grazing", adaptive), grazing, {0.0f, 0.0f, 0.62f}, {0.0f, -0.02f, 0.0f}},
        {"head_standard.png", standard_head("head standard"), front_left, {0.22f, 0.02f, 0.7f}},
        {"head_skin.png", skin("head skin", adaptive), front_left, {0.22f, 0.02f, 0.7f}},
        {"head_penner.png", skin("head penner", penner), {-0.95f, -0.05f, -0.3f}, {0.05f, -0.02f, 0.72f}},
        {"head_adaptive.png", skin("head adaptive", adaptive), {-0.95f, -0.05f, -0.3f}, {0.05f, -0.02f, 0.72f}},
        // Lit from behind: the ear's rim glows red through its thin parts.
        {"head_backlit.png", skin("head backlit", back), {-0.2f, -0.1f, 0.97f}, {0.6f, 0.05f, 0.1f}, {0.0f, -0.04f, -0.08f}},
    };
    for (const auto& shot : shots) {
      auto s = head_scene(o, *head, shot.material, shot.light, shot.eye, shot.target);
      if (!s) return std::unexpected(s.error());
      if (auto ok = save(*r, *s, o.out / shot.file); !ok) return ok;
    }
    if (auto ok = save_difference(o.out / "head_standard_grazing.png", o.out / "head_skin_grazing.png",
                                  o.out / "head_difference.png");
        !ok)
      return ok;
  } else {
    std::printf("head scan not found (give --head PATH or set WEFT_SHARED_DATA): head images skipped\n");
  }
  if (o.check && instance->validation_message_count() > 0) {
    for (const auto& m : instance->take_validation_messages()) std::fprintf(stderr, "validation: %s\n", m.c_str());
    return fail(ErrorKind::Internal, "the validation layer reported problems (above)");
  }
  return {};
}

}  // namespace

int main(int argc, char** argv) {
  // This program links one feature and registers it, as any application does.
  // The frame's pass types (the default pipeline's shadow map, scene colour, background, tone map).
  if (auto ok = weft::register_builtin_pass_types(); !ok) {
    std::fprintf(stderr, "%s\n", ok.error().what().c_str());
    return 1;
  }
  if (auto ok = register_feature(passes::skin_sss_feature()); !ok) {
    std::fprintf(stderr, "%s\n", ok.error().what().c_str());
    return 1;
  }
  Options o;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--check") o.check = true;
    else if (a == "--head" && i + 1 < argc && argv[i + 1][0] == '\0') {
      std::fprintf(stderr, "weft-skin-example: --head was given an empty value\n");
      return 2;
    } else if (a == "--head" && i + 1 < argc) o.head = argv[++i];
    else if (a == "--size" && i + 1 < argc) {
      if (!weft::args::size_into(argv[++i], 8192, o.width, o.height)) {
        std::fprintf(stderr, "weft-skin-example: --size expects WxH with sides 1..8192, got '%s'\n", argv[i]);
        return 2;
      }
    } else if (a == "-h" || a == "--help") {
      std::printf("usage: weft-skin-example [out-dir] [--size WxH] [--head PATH] [--check]\n");
      return 0;
    } else if (a.starts_with("-")) {
      std::fprintf(stderr, "weft-skin-example: unknown or incomplete argument '%s'\n"
                           "usage: weft-skin-example [out-dir] [--size WxH] [--head PATH] [--check]\n", a.c_str());
      return 2;
    } else {
      o.out = a;
    }
  }
  // A --head that is not a mesh is named before any work (issue 33: a missing one fell back to
  // another head silently, a FIFO, a device or a text file wrote every LUT first, a symlink loop threw).
  if (!o.head.empty())
    if (auto head = scene::load_mesh(o.head); !head) {
      std::fprintf(stderr, "weft-skin-example: --head: %s\n", head.error().what().c_str());
      return 1;
    }
  if (auto ok = run(o); !ok) {
    std::fprintf(stderr, "weft-skin-example: %s\n", ok.error().what().c_str());
    return 1;
  }
  return 0;
}
