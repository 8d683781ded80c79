// The standard material as glTF defines it, through the renderer: embedded and external
// images, two UV sets, samplers, metallic-roughness / occlusion / emissive maps against
// their factors, a normal map's measurable tilt (and its axes), and punctual lights against
// KHR_lights_punctual's analytic falloff. Small files written by the tests themselves.
#include <doctest/doctest.h>
#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <utility>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <optional>
#include <string>
#include <vector>
#include <unistd.h>
#include <glm/glm.hpp>
#include <nlohmann/json.hpp>
import weft.core;
import weft.image;
import weft.scene;
import weft.renderer;
import weft.test.gpu;
#include "renderer_support.h"

using namespace weft;
using nlohmann::json;
namespace fs = std::filesystem;

namespace {

struct TempFolder {
  fs::path path = fs::temp_directory_path() / ("weft-materials-" + std::to_string(::getpid()));
  TempFolder() { fs::create_directories(path); }
  ~TempFolder() {
    std::error_code ec;
    fs::remove_all(path, ec);
  }
  fs::path operator/(const std::string& name) const { return path / name; }
};

std::vector<std::uint8_t> png_bytes(const image::Image8& img, const fs::path& scratch) {
  REQUIRE(image::save_png(scratch, img));
  std::ifstream in(scratch, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

image::Image8 constant_image(std::uint8_t r, std::uint8_t g, std::uint8_t b) {
  image::Image8 img = image::Image8::filled(2, 2, 3, 0);
  for (std::uint32_t y = 0; y < 2; ++y)
    for (std::uint32_t x = 0; x < 2; ++x) {
      img.at(x, y, 0) = r;
      img.at(x, y, 1) = g;
      img.at(x, y, 2) = b;
    }
  return img;
}

// The four texels of a 2x2 image stored top row first: red, green / blue, white.
image::Image8 corner_image() {
  image::Image8 img = image::Image8::filled(2, 2, 3, 0);
  img.at(0, 0, 0) = 255;
  img.at(1, 0, 1) = 255;
  img.at(0, 1, 2) = 255;
  img.at(1, 1, 0) = img.at(1, 1, 1) = img.at(1, 1, 2) = 255;
  return img;
}

std::string base64(const std::vector<std::uint8_t>& data) {
  static constexpr char table[] = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  for (std::size_t i = 0; i < data.size(); i += 3) {
    std::uint32_t v = std::uint32_t(data[i]) << 16;
    if (i + 1 < data.size()) v |= std::uint32_t(data[i + 1]) << 8;
    if (i + 2 < data.size()) v |= data[i + 2];
    out += table[(v >> 18) & 63];
    out += table[(v >> 12) & 63];
    out += i + 1 < data.size() ? table[(v >> 6) & 63] : '=';
    out += i + 2 < data.size() ? table[v & 63] : '=';
  }
  return out;
}

// An image of the test glTF: an external file, a data URI, or bytes in a buffer view.
struct GltfImage {
  enum class Where { File, DataUri, BufferView } where = Where::File;
  std::string uri;                 // File: the file name next to the glTF
  std::vector<std::uint8_t> png;   // DataUri, BufferView
};

// A quad facing +Z spanning [-h, h]^2 at z = 0 (normal +Z), TEXCOORD_0 upright (v = 0 at the
// top), an optional TEXCOORD_1, one material; texture i shows image i with sampler
// `texture_samplers[i]` (-1: none). Written as .gltf (buffer in a data URI) or .glb.
struct QuadGltf {
  json material = json::object();
  std::vector<GltfImage> images;
  json samplers = json::array();
  std::vector<int> texture_samplers;
  std::vector<float> uv0 = {0, 1, 1, 1, 1, 0, 0, 0};
  std::optional<std::vector<float>> uv1;
  float half = 0.5f;
};

void write_quad(const fs::path& path, const QuadGltf& q) {
  std::vector<std::uint8_t> bin;
  const auto put = [&](auto value) {
    const auto* p = reinterpret_cast<const std::uint8_t*>(&value);
    bin.insert(bin.end(), p, p + sizeof(value));
  };
  const auto align = [&] { while (bin.size() % 4 != 0) bin.push_back(0); };
  json views = json::array(), accessors = json::array();
  const auto view = [&](std::size_t begin) {
    views.push_back({{"buffer", 0}, {"byteOffset", begin}, {"byteLength", bin.size() - begin}});
    return int(views.size() - 1);
  };
  const float h = q.half;
  std::size_t at = bin.size();
  for (float f : {-h, -h, 0.0f, h, -h, 0.0f, h, h, 0.0f, -h, h, 0.0f}) put(f);
  accessors.push_back({{"bufferView", view(at)}, {"componentType", 5126}, {"count", 4}, {"type", "VEC3"},
                       {"min", {-h, -h, 0}}, {"max", {h, h, 0}}});
  at = bin.size();
  for (int v = 0; v < 4; ++v)
    for (float f : {0.0f, 0.0f, 1.0f}) put(f);
  accessors.push_back({{"bufferView", view(at)}, {"componentType", 5126}, {"count", 4}, {"type", "VEC3"}});
  json attributes = {{"POSITION", 0}, {"NORMAL", 1}};
  for (int set = 0; set < 2; ++set) {
    const std::vector<float>* uv = set == 0 ? &q.uv0 : (q.uv1 ? &*q.uv1 : nullptr);
    if (!uv) continue;
    at = bin.size();
    for (float f : *uv) put(f);
    accessors.push_back({{"bufferView", view(at)}, {"componentType", 5126}, {"count", 4}, {"type", "VEC2"}});
    attributes["TEXCOORD_" + std::to_string(set)] = accessors.size() - 1;
  }
  at = bin.size();
  for (std::uint16_t i : {0, 1, 2, 0, 2, 3}) put(i);
  accessors.push_back({{"bufferView", view(at)}, {"componentType", 5123}, {"count", 6}, {"type", "SCALAR"}});
  align();
  json images = json::array(), textures = json::array();
  for (std::size_t i = 0; i < q.images.size(); ++i) {
    const GltfImage& img = q.images[i];
    if (img.where == GltfImage::Where::File) {
      images.push_back({{"uri", img.uri}});
    } else if (img.where == GltfImage::Where::DataUri) {
      images.push_back({{"uri", "data:image/png;base64," + base64(img.png)}});
    } else {
      at = bin.size();
      bin.insert(bin.end(), img.png.begin(), img.png.end());
      images.push_back({{"bufferView", view(at)}, {"mimeType", "image/png"}});
      align();
    }
    json texture = {{"source", i}};
    if (i < q.texture_samplers.size() && q.texture_samplers[i] >= 0) texture["sampler"] = q.texture_samplers[i];
    textures.push_back(texture);
  }
  const bool glb = path.extension() == ".glb";
  json buffer = {{"byteLength", bin.size()}};
  if (!glb) buffer["uri"] = "data:application/octet-stream;base64," + base64(bin);
  json doc = {{"asset", {{"version", "2.0"}}}, {"scene", 0}, {"scenes", {{{"nodes", {0}}}}}, {"nodes", {{{"mesh", 0}}}},
              {"meshes", {{{"primitives", {{{"attributes", attributes}, {"indices", accessors.size() - 1}, {"material", 0}}}}}}},
              {"materials", {q.material}}, {"buffers", {buffer}}, {"bufferViews", views}, {"accessors", accessors}};
  if (!images.empty()) {
    doc["images"] = images;
    doc["textures"] = textures;
  }
  if (!q.samplers.empty()) doc["samplers"] = q.samplers;
  std::string text = doc.dump();
  std::ofstream out(path, std::ios::binary);
  if (!glb) {
    out << text;
    return;
  }
  while (text.size() % 4 != 0) text.push_back(' ');
  const auto u32 = [&](std::uint32_t v) { out.write(reinterpret_cast<const char*>(&v), 4); };
  u32(0x46546C67);
  u32(2);
  u32(std::uint32_t(12 + 8 + text.size() + 8 + bin.size()));
  u32(std::uint32_t(text.size()));
  u32(0x4E4F534A);
  out.write(text.data(), std::streamsize(text.size()));
  u32(std::uint32_t(bin.size()));
  u32(0x004E4942);
  out.write(reinterpret_cast<const char*>(bin.data()), std::streamsize(bin.size()));
}

// The glTF at `path` in front of a camera at z = 2 (60 degrees), 80x80, black sky, a light
// straight on (intensity pi) unless `lights` says otherwise.
scene::Scene quad_scene(const fs::path& path, std::vector<scene::Light> lights = {
                                                  scene::DirectionalLight{.direction = {0, 0, -1}, .intensity = 3.14159265f}}) {
  auto s = scene::load_scene(path);
  REQUIRE_MESSAGE(s, (s ? "" : s.error().message));
  s->output = {80, 80};
  s->camera = scene::Camera{.position = {0, 0, 2}, .target = {0, 0, 0}, .fov_y_degrees = 60};
  s->environment = scene::Environment{};
  s->lights = std::move(lights);
  return std::move(*s);
}

renderer::Frame render(const scene::Scene& s, bool hdr = false) {
  auto frame = weft::test::shared_renderer().render(s, {.aces = false, .read_hdr = hdr});
  REQUIRE_MESSAGE(frame, (frame ? "" : frame.error().message));
  for (const auto& w : frame->warnings) MESSAGE(w);
  return std::move(*frame);
}

std::string texel_seen(const image::Image8& img, int dx, int dy) {
  const auto x = std::uint32_t(40 + dx), y = std::uint32_t(40 + dy);
  const int r = weft::test::channel(img, x, y, 0), g = weft::test::channel(img, x, y, 1), b = weft::test::channel(img, x, y, 2);
  const bool R = r > 180, G = g > 180, B = b > 180;
  if (R && G && B) return "white";
  if (R && !G && !B) return "red";
  if (G && !R && !B) return "green";
  if (B && !R && !G) return "blue";
  return "(" + std::to_string(r) + "," + std::to_string(g) + "," + std::to_string(b) + ")";
}

void check_upright(const image::Image8& img) {
  CHECK(texel_seen(img, -8, -8) == "red");
  CHECK(texel_seen(img, 8, -8) == "green");
  CHECK(texel_seen(img, -8, 8) == "blue");
  CHECK(texel_seen(img, 8, 8) == "white");
}

vec3 hdr_at(const image::Image& img, std::uint32_t x, std::uint32_t y) {
  return {img.at(x, y, 0), img.at(x, y, 1), img.at(x, y, 2)};
}

int max_difference(const image::Image8& a, const image::Image8& b) {
  REQUIRE(a.pixels.size() == b.pixels.size());
  int worst = 0;
  for (std::size_t i = 0; i < a.pixels.size(); ++i) worst = std::max(worst, std::abs(int(a.pixels[i]) - int(b.pixels[i])));
  return worst;
}

const json textured_base = {{"pbrMetallicRoughness", {{"baseColorTexture", {{"index", 0}}}, {"metallicFactor", 0}, {"roughnessFactor", 1}}}};

}  // namespace

TEST_CASE("texture orientation: OBJ's vt (0, 0) is the image's bottom-left, and the image shows upright") {
  TempFolder dir;
  REQUIRE(image::save_png(dir / "corners.png", corner_image()));
  std::ofstream(dir / "quad.obj") << "v -0.5 -0.5 0\nv 0.5 -0.5 0\nv 0.5 0.5 0\nv -0.5 0.5 0\nvn 0 0 1\n"
                                     "vt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nf 1/1/1 2/2/1 3/3/1 4/4/1\n";
  check_upright(render(weft::test::load(R"({
    "version": 1, "output": {"width": 80, "height": 80},
    "camera": {"position": [0, 0, 2], "target": [0, 0, 0], "fov": 60},
    "lights": [{"type": "directional", "direction": [0, 0, -1], "intensity": 3.14159265}],
    "meshes": {"quad": {"path": "quad.obj"}},
    "materials": {"m": {"type": "standard", "base_color": [1, 1, 1], "roughness": 1.0, "base_color_texture": "corners.png"}},
    "objects": [{"name": "quad", "mesh": "quad", "material": "m"}]})", dir.path)).image);
  weft::test::expect_no_validation_messages();
}

TEST_CASE("glTF images (TEXCOORD_0's v = 0 the top): external, data URI and GLB buffer view all render upright") {
  TempFolder dir;
  const auto png = png_bytes(corner_image(), dir / "scratch.png");
  REQUIRE(image::save_png(dir / "corners.png", corner_image()));
  SUBCASE("external file") {
    write_quad(dir / "file.gltf", {.material = textured_base, .images = {{.uri = "corners.png"}}});
    check_upright(render(quad_scene(dir / "file.gltf")).image);
  }
  SUBCASE("data URI") {
    write_quad(dir / "uri.gltf", {.material = textured_base, .images = {{.where = GltfImage::Where::DataUri, .png = png}}});
    check_upright(render(quad_scene(dir / "uri.gltf")).image);
  }
  SUBCASE("GLB buffer view") {
    write_quad(dir / "view.glb", {.material = textured_base, .images = {{.where = GltfImage::Where::BufferView, .png = png}}});
    const auto frame = render(quad_scene(dir / "view.glb"));
    check_upright(frame.image);
    CHECK(frame.warnings.empty());
  }
  weft::test::expect_no_validation_messages();
}

TEST_CASE("glTF texCoord 1 reads TEXCOORD_1; samplers' wrap and filter are followed") {
  TempFolder dir;
  REQUIRE(image::save_png(dir / "corners.png", corner_image()));
  SUBCASE("two UV sets: TEXCOORD_0 pinned to the red texel, TEXCOORD_1 upright") {
    json material = textured_base;
    material["pbrMetallicRoughness"]["baseColorTexture"]["texCoord"] = 1;
    write_quad(dir / "two.gltf", {.material = material, .images = {{.uri = "corners.png"}},
                                  .uv0 = {0.25f, 0.25f, 0.25f, 0.25f, 0.25f, 0.25f, 0.25f, 0.25f},
                                  .uv1 = std::vector<float>{0, 1, 1, 1, 1, 0, 0, 0}});
    check_upright(render(quad_scene(dir / "two.gltf")).image);
  }
  SUBCASE("clamp to edge in u, mirrored repeat in v, nearest: UVs in [0, 2]^2") {
    // u: clamped, so the right half of the quad (u > 1) repeats the image's right column;
    // v: mirrored, so the bottom half (v > 1) shows the image upside down (v -> 2 - v).
    // A pixel dx from the centre sees u = (dx + 17.3) / 17.3 (the quad is ~17.3 px wide a side).
    write_quad(dir / "wrap.gltf", {.material = textured_base, .images = {{.uri = "corners.png"}},
                                   .samplers = json::array({{{"wrapS", 33071}, {"wrapT", 33648}, {"magFilter", 9728}, {"minFilter", 9728}}}),
                                   .texture_samplers = {0},
                                   .uv0 = {0, 2, 2, 2, 2, 0, 0, 0}});
    const auto img = render(quad_scene(dir / "wrap.gltf")).image;
    CHECK(texel_seen(img, -12, -12) == "red");    // (u, v) ~ (0.3, 0.3)
    CHECK(texel_seen(img, -4, -12) == "green");   // u ~ 0.8
    CHECK(texel_seen(img, 12, -12) == "green");   // u ~ 1.7, clamped to the right column
    CHECK(texel_seen(img, -12, 4) == "blue");     // v ~ 1.23 -> 0.77: the bottom row
    CHECK(texel_seen(img, -12, 12) == "red");     // v ~ 1.69 -> 0.31: the top row again
  }
  weft::test::expect_no_validation_messages();
}

TEST_CASE("glTF metallic-roughness, occlusion and emissive maps act as their factors say") {
  TempFolder dir;
  const vec3 grey{0.5f};
  SUBCASE("a metallic-roughness map equals the same values given as factors") {
    const std::uint8_t g = 77, b = 255;  // roughness 77/255, metallic 1
    REQUIRE(image::save_png(dir / "mr.png", constant_image(0, g, b)));
    json by_map = {{"pbrMetallicRoughness", {{"baseColorFactor", {0.9, 0.5, 0.2, 1}}, {"metallicFactor", 1}, {"roughnessFactor", 1},
                                             {"metallicRoughnessTexture", {{"index", 0}}}}}};
    json by_factor = {{"pbrMetallicRoughness", {{"baseColorFactor", {0.9, 0.5, 0.2, 1}}, {"metallicFactor", 1},
                                                {"roughnessFactor", g / 255.0}}}};
    write_quad(dir / "map.gltf", {.material = by_map, .images = {{.uri = "mr.png"}}});
    write_quad(dir / "factor.gltf", {.material = by_factor});
    const std::vector<scene::Light> lights = {scene::DirectionalLight{.direction = glm::normalize(vec3(0.3f, -0.2f, -1.0f)), .intensity = 3.0f}};
    auto a = quad_scene(dir / "map.gltf", lights), f = quad_scene(dir / "factor.gltf", lights);
    a.environment.constant_color = f.environment.constant_color = grey;
    const auto map_frame = render(a), factor_frame = render(f);
    CHECK(max_difference(map_frame.image, factor_frame.image) <= 2);
    // And not a test of nothing: the metal differs from the dielectric default.
    CHECK(weft::test::channel(map_frame.image, 40, 40, 2) < weft::test::channel(map_frame.image, 40, 40, 0) - 40);
  }
  SUBCASE("occlusion dims the image-based light by the map's red times strength, not the lights") {
    REQUIRE(image::save_png(dir / "ao.png", constant_image(128, 0, 0)));
    for (const double strength : {1.0, 0.5}) {
      CAPTURE(strength);
      json occluded = {{"pbrMetallicRoughness", {{"metallicFactor", 0}, {"roughnessFactor", 1}}},
                       {"occlusionTexture", {{"index", 0}, {"strength", strength}}}};
      write_quad(dir / "ao.gltf", {.material = occluded, .images = {{.uri = "ao.png"}}});
      write_quad(dir / "open.gltf", {.material = {{"pbrMetallicRoughness", {{"metallicFactor", 0}, {"roughnessFactor", 1}}}}});
      auto a = quad_scene(dir / "ao.gltf", {}), b = quad_scene(dir / "open.gltf", {});
      a.environment.constant_color = b.environment.constant_color = grey;
      const float ao = 128.0f / 255.0f;  // linear data, not sRGB
      const float expected = float(1.0 - strength + strength * ao);
      const vec3 lit = hdr_at(render(a, true).hdr, 40, 40), open = hdr_at(render(b, true).hdr, 40, 40);
      CHECK(lit.x / open.x == doctest::Approx(expected).epsilon(0.01));
      // Under a direct light alone, occlusion changes nothing.
      auto c = quad_scene(dir / "ao.gltf"), d = quad_scene(dir / "open.gltf");
      CHECK(max_difference(render(c).image, render(d).image) <= 1);
    }
  }
  SUBCASE("emissive: factor times the sRGB-decoded map, with no light at all") {
    REQUIRE(image::save_png(dir / "glow.png", constant_image(255, 128, 64)));
    json glowing = {{"pbrMetallicRoughness", {{"baseColorFactor", {0, 0, 0, 1}}}}, {"emissiveFactor", {1.0, 0.5, 0.25}},
                    {"emissiveTexture", {{"index", 0}}}};
    write_quad(dir / "glow.gltf", {.material = glowing, .images = {{.uri = "glow.png"}}});
    const vec3 e = hdr_at(render(quad_scene(dir / "glow.gltf", {}), true).hdr, 40, 40);
    CHECK(e.x == doctest::Approx(1.0f).epsilon(0.01));
    CHECK(e.y == doctest::Approx(0.5f * image::srgb_to_linear(128.0f / 255.0f)).epsilon(0.01));
    CHECK(e.z == doctest::Approx(0.25f * image::srgb_to_linear(64.0f / 255.0f)).epsilon(0.02));
  }
  weft::test::expect_no_validation_messages();
}

TEST_CASE("glTF normal map: +X follows +u, +Y the image's top, and the tilt changes N.L as it should") {
  TempFolder dir;
  // A constant map tilting the normal by 30 degrees towards +X or +Y of the tangent frame.
  const auto tilt_map = [&](const std::string& name, float x, float y) {
    const float z = std::sqrt(1.0f - x * x - y * y);
    const auto code = [](float c) { return std::uint8_t(std::lround((c * 0.5f + 0.5f) * 255.0f)); };
    REQUIRE(image::save_png(dir / name, constant_image(code(x), code(y), code(z))));
  };
  tilt_map("east.png", 0.5f, 0.0f);
  tilt_map("west.png", -0.5f, 0.0f);
  tilt_map("north.png", 0.0f, 0.5f);
  const auto brightness = [&](const std::string& map, vec3 towards_light) {
    json material = {{"pbrMetallicRoughness", {{"metallicFactor", 0}, {"roughnessFactor", 1}}}};
    QuadGltf q{.material = material};
    if (!map.empty()) {
      q.material["normalTexture"] = {{"index", 0}};
      q.images = {{.uri = map}};
    }
    write_quad(dir / "n.gltf", q);
    const vec3 hdr = hdr_at(render(quad_scene(dir / "n.gltf", {scene::DirectionalLight{.direction = -towards_light, .intensity = 1.0f}}),
                                   true).hdr, 40, 40);
    return hdr.x;
  };
  const vec3 east = glm::normalize(vec3(1, 0, 1)), north = glm::normalize(vec3(0, 1, 1));
  const float flat = brightness("", east);
  // N.L: flat 0.707, tilted towards the light 0.966, away 0.259 (Lambert dominates at roughness 1).
  const float towards = brightness("east.png", east), away = brightness("west.png", east);
  CHECK(towards / flat == doctest::Approx(0.966 / 0.707).epsilon(0.12));
  CHECK(away / flat == doctest::Approx(0.259 / 0.707).epsilon(0.2));
  // Upright UVs put the image's top at +Y: a map tilting to +Y leans the surface up.
  const float up = brightness("north.png", north), flat_north = brightness("", north);
  CHECK(up / flat_north == doctest::Approx(0.966 / 0.707).epsilon(0.12));
  weft::test::expect_no_validation_messages();
}

TEST_CASE("point and spot lights: inverse square, range window and cone falloff as KHR_lights_punctual defines") {
  // A grey floor seen from above; the lights hang above its centre.
  const auto floor_scene = [](const std::string& light) {
    return weft::test::load(R"({
      "version": 1, "output": {"width": 81, "height": 81},
      "camera": {"position": [0, 2, 0], "target": [0, 0, 0], "up": [0, 0, -1], "fov": 60},
      "lights": [)" + light + R"(],
      "meshes": {"floor": {"primitive": "plane", "size": 8}},
      "materials": {"grey": {"type": "standard", "base_color": [0.5, 0.5, 0.5], "roughness": 1.0}},
      "objects": [{"mesh": "floor", "material": "grey"}]})");
  };
  const auto centre = [&](const std::string& light, std::uint32_t x = 40) {
    return render(floor_scene(light), true).hdr.at(x, 40, 0);
  };
  const float near1 = centre(R"({"type": "point", "position": [0, 1, 0], "intensity": 1})");
  const float far1 = centre(R"({"type": "point", "position": [0, 2, 0], "intensity": 1})");
  const float far4 = centre(R"({"type": "point", "position": [0, 2, 0], "intensity": 4})");
  REQUIRE(near1 > 0.0f);
  CHECK(far1 / near1 == doctest::Approx(0.25).epsilon(0.01));  // 1 / d^2
  CHECK(far4 / near1 == doctest::Approx(1.0).epsilon(0.01));
  // The range window (1 - (d / range)^4)^2 at d = 1, range 2: 0.8789.
  const float ranged = centre(R"({"type": "point", "position": [0, 1, 0], "intensity": 1, "range": 2})");
  CHECK(ranged / near1 == doctest::Approx(std::pow(1.0 - std::pow(0.5, 4.0), 2.0)).epsilon(0.01));
  CHECK(centre(R"({"type": "point", "position": [0, 1, 0], "intensity": 1, "range": 0.9})") == 0.0f);
  // A spot light straight down, inner 10 and outer 30 degrees, against a point light at the
  // same place: at the centre 1, at a pixel 20 degrees off the axis the smooth cone's
  // ((cos a - cos 30) / (cos 10 - cos 30))^2, beyond 30 degrees nothing.
  const std::string spot = R"({"type": "spot", "position": [0, 1, 0], "direction": [0, -1, 0], "intensity": 1, "inner_cone": 10, "outer_cone": 30})";
  const std::string point = R"({"type": "point", "position": [0, 1, 0], "intensity": 1})";
  CHECK(centre(spot) / near1 == doctest::Approx(1.0).epsilon(0.01));
  // Pixel column x sees the floor at world x = (x + 0.5 - 40.5) / 40.5 * 2 tan 30 (camera 2 above it).
  const auto angle_at = [](std::uint32_t x) {
    const double wx = (double(x) + 0.5 - 40.5) / 40.5 * 2.0 * std::tan(30.0 * pi / 180.0);
    return std::atan(std::abs(wx));
  };
  const std::uint32_t column = 53;  // ~19.9 degrees
  const double c = (std::cos(angle_at(column)) - std::cos(30.0 * pi / 180.0)) / (std::cos(10.0 * pi / 180.0) - std::cos(30.0 * pi / 180.0));
  CHECK(centre(spot, column) / centre(point, column) == doctest::Approx(c * c).epsilon(0.02));
  CHECK(centre(spot, 70) == 0.0f);  // ~40 degrees off the axis
  weft::test::expect_no_validation_messages();
}

TEST_CASE("glTF material inputs that cannot be used are warnings naming the material and the slot") {
  TempFolder dir;
  std::ofstream(dir / "broken.png") << "not a png";
  const json cracked = {{"name", "cracked"}, {"pbrMetallicRoughness", {{"baseColorTexture", {{"index", 0}}}, {"metallicFactor", 0}}}};
  const auto check_named = [&](const fs::path& gltf, const std::string& image) {
    const auto frame = render(quad_scene(gltf));
    bool named = false;
    for (const auto& w : frame.warnings) named = named || (w.find("'cracked' base colour map") != std::string::npos &&
                                                           w.find(image) != std::string::npos);
    CHECK_MESSAGE(named, "no warning names the material, the slot and " << image);
    CHECK(weft::test::channel(frame.image, 40, 40, 0) > 200);  // drawn without the map: white
  };
  SUBCASE("embedded bytes that are no image") {
    write_quad(dir / "bad.gltf", {.material = cracked, .images = {{.where = GltfImage::Where::DataUri, .png = {1, 2, 3, 4}}}});
    check_named(dir / "bad.gltf", "image 0");
  }
  SUBCASE("an external file that is no image") {
    write_quad(dir / "bad_file.gltf", {.material = cracked, .images = {{.uri = "broken.png"}}});
    check_named(dir / "bad_file.gltf", "broken.png");
  }
  weft::test::expect_no_validation_messages();
}

TEST_CASE("a glTF made elsewhere (examples/gltf/water_bottle, CC0) renders with each of its maps") {
  const char* root = std::getenv("WEFT_SOURCE_DIR");
  REQUIRE_MESSAGE(root, "WEFT_SOURCE_DIR must name the source tree (ctest sets it)");
  auto loaded = scene::load_scene(fs::path(root) / "examples/gltf/water_bottle/WaterBottle.glb");
  REQUIRE_MESSAGE(loaded, (loaded ? "" : loaded.error().what()));
  loaded->output = {128, 128};
  const auto full = render(*loaded).image;
  // Over the bottle's pixels (those not the background's colour): each map must move them.
  std::vector<std::size_t> bottle;
  for (std::size_t p = 0; p < std::size_t(full.width) * full.height; ++p) {
    int from_background = 0;
    for (std::size_t c = 0; c < 3; ++c) from_background += std::abs(int(full.pixels[p * full.channels + c]) - int(full.pixels[c]));
    if (from_background > 12) bottle.push_back(p);
  }
  REQUIRE(bottle.size() > 1000);  // the camera frames the bottle's bounds
  auto changed_share = [&](const image::Image8& a, const image::Image8& b) {
    std::size_t n = 0;
    for (std::size_t p : bottle)
      for (std::size_t c = 0; c < 3; ++c)
        if (std::abs(int(a.pixels[p * a.channels + c]) - int(b.pixels[p * b.channels + c])) >= 2) {
          ++n;
          break;
        }
    return double(n) / double(bottle.size());
  };
  auto mean_difference = [&](const image::Image8& a, const image::Image8& b) {
    double sum = 0.0;
    for (std::size_t p : bottle)
      for (std::size_t c = 0; c < 3; ++c) sum += std::abs(int(a.pixels[p * a.channels + c]) - int(b.pixels[p * b.channels + c]));
    return sum / double(bottle.size() * 3);
  };
  using Slot = scene::Texture scene::StandardMaterial::*;
  for (auto [name, slot] : {std::pair<std::string, Slot>{"base colour", &scene::StandardMaterial::base_color_texture},
                            {"metallic-roughness", &scene::StandardMaterial::metallic_roughness_texture},
                            {"normal", &scene::StandardMaterial::normal_texture},
                            {"occlusion", &scene::StandardMaterial::occlusion_texture}}) {
    scene::Scene without = *loaded;
    for (auto& m : without.materials) m.standard.*slot = {};
    const auto image = render(without).image;
    const double d = mean_difference(full, image), share = changed_share(full, image);
    CAPTURE(name);
    MESSAGE(name << ": mean difference " << d << " levels over the bottle, " << 100.0 * share << " % of its pixels by 2 or more");
    // The asset's colour and metallic-roughness maps shape the whole bottle; its normal map
    // is flat but for the cap's ridges and an embossed logo, and occlusion scales only the
    // dim ambient light: those two move the bottle by fractions of a level (0.15 and 0.22 here,
    // rendering being deterministic, any difference is the map's), the cap's few pixels most.
    if (name == "base colour" || name == "metallic-roughness")
      CHECK(d > 5.0);
    else
      CHECK(d > 0.05);
  }
  weft::test::expect_no_validation_messages();
}
