// The renderer end to end: scene text -> graph of only the needed passes -> image, checked
// against analytic expectations, under the validation layer.
#include <doctest/doctest.h>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>
#include <unistd.h>
import weft.core;
import weft.image;
import weft.scene;
import weft.renderer;
import weft.test.gpu;
#include "renderer_support.h"

using namespace weft;

namespace {
using weft::test::load;
using weft::test::shared_renderer;
using weft::test::channel;

const char* furnace = R"({
  "version": 1,
  "output": {"width": 64, "height": 64},
  "camera": {"position": [0, 0, 4], "target": [0, 0, 0], "fov": 40},
  "environment": {"color": [0.5, 0.5, 0.5]},
  "meshes": {"ball": {"primitive": "sphere", "radius": 1.0}},
  "materials": {"white": {"type": "standard", "base_color": [1, 1, 1], "roughness": 0.5}},
  "objects": [{"name": "ball", "mesh": "ball", "material": "white"}]
})";
}  // namespace

TEST_CASE("white furnace through the renderer: the sphere vanishes into a constant sky") {
  auto s = load(furnace);
  auto frame = shared_renderer().render(s, {.aces = false});
  REQUIRE_MESSAGE(frame, (frame ? "" : frame.error().message));
  const int sky = channel(frame->image, 1, 1);
  CHECK(std::abs(sky - 188) <= 1);
  int worst = 0;
  std::uint32_t wx = 0, wy = 0;
  for (std::uint32_t y = 8; y < 56; ++y)
    for (std::uint32_t x = 8; x < 56; ++x)
      if (std::abs(channel(frame->image, x, y) - sky) > worst) {
        worst = std::abs(channel(frame->image, x, y) - sky);
        wx = x;
        wy = y;
      }
  CHECK_MESSAGE(worst <= 3, "at (" << wx << ", " << wy << "): " << channel(frame->image, wx, wy) << " vs sky " << sky);
  weft::test::expect_no_validation_messages();
}

TEST_CASE("a scene with only standard materials and no key light runs only base passes, no shadow map") {
  auto s = load(furnace);
  auto report = shared_renderer().describe(s);
  REQUIRE(report);
  CHECK(report->passes == std::vector<std::string>{"forward", "background", "tonemap"});
  CHECK(report->dot.find("digraph") != std::string::npos);
  weft::test::expect_no_validation_messages();
}

TEST_CASE("a directional light adds the shadow pass; nothing else appears") {
  std::string json = furnace;
  json.insert(json.rfind('}'), R"(, "lights": [{"type": "directional", "direction": [0, -1, 0], "intensity": 1}])");
  auto s = load(json);
  auto report = shared_renderer().describe(s);
  REQUIRE(report);
  CHECK(report->passes == std::vector<std::string>{"shadow_map", "forward", "background", "tonemap"});
  weft::test::expect_no_validation_messages();
}

TEST_CASE("an OBJ mesh renders where its projection says, lit on the side facing the light") {
  const auto dir = std::filesystem::temp_directory_path() / ("weft-renderer-" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  // A 1x1 quad facing +z at z = 0, spanning [-0.5, 0.5]^2.
  std::ofstream(dir / "quad.obj") << "v -0.5 -0.5 0\nv 0.5 -0.5 0\nv 0.5 0.5 0\nv -0.5 0.5 0\nvn 0 0 1\n"
                                     "f 1//1 2//1 3//1\nf 1//1 3//1 4//1\n";
  auto s = load(R"({
    "version": 1, "output": {"width": 80, "height": 80},
    "camera": {"position": [0, 0, 2], "target": [0, 0, 0], "fov": 60},
    "lights": [{"type": "directional", "direction": [0, 0, -1], "intensity": 3.14159265}],
    "meshes": {"quad": {"path": "quad.obj"}},
    "materials": {"white": {"type": "standard", "base_color": [1, 1, 1], "roughness": 1.0}},
    "objects": [{"name": "quad", "mesh": "quad", "material": "white"}]
  })", dir);
  auto frame = shared_renderer().render(s, {.aces = false});
  REQUIRE_MESSAGE(frame, (frame ? "" : frame.error().message));
  // Half-width 0.5 at distance 2 with a 60° field of view covers tan^-1(0.25)/tan(30°) of half the image.
  const float half_px = 40.0f * 0.25f / std::tan((30.0f * pi / 180.0f));
  CHECK(channel(frame->image, 40, 40) > 240);                              // lit, facing the light: ~(1-F)
  CHECK(channel(frame->image, 40 + int(half_px) + 3, 40) == 0);            // beside it: black sky
  CHECK(channel(frame->image, 40 + int(half_px) - 3, 40) > 240);           // just inside the edge
  std::filesystem::remove_all(dir);
  weft::test::expect_no_validation_messages();
}

TEST_CASE("a glTF file renders: node transform, material colour and camera come from the file") {
  const auto dir = std::filesystem::temp_directory_path() / ("weft-renderer-gltf-" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  // A unit quad facing +z, moved 0.25 to the right by its node; a red material; a camera at z = 2.
  std::ofstream(dir / "quad.gltf") << R"({
    "asset": {"version": "2.0"},
    "scene": 0, "scenes": [{"nodes": [0, 1]}],
    "nodes": [{"mesh": 0, "translation": [0.25, 0, 0]}, {"camera": 0, "translation": [0, 0, 2]}],
    "cameras": [{"type": "perspective", "perspective": {"yfov": 1.0471976, "aspectRatio": 1.0, "znear": 0.1, "zfar": 10}}],
    "materials": [{"pbrMetallicRoughness": {"baseColorFactor": [1, 0, 0, 1], "metallicFactor": 0, "roughnessFactor": 1}}],
    "meshes": [{"primitives": [{"attributes": {"POSITION": 0, "NORMAL": 1}, "indices": 2, "material": 0}]}],
    "buffers": [{"byteLength": 108, "uri": "data:application/octet-stream;base64,AAAAvwAAAL8AAAAAAAAAPwAAAL8AAAAAAAAAPwAAAD8AAAAAAAAAvwAAAD8AAAAAAAAAAAAAAAAAAIA/AAAAAAAAAAAAAIA/AAAAAAAAAAAAAIA/AAAAAAAAAAAAAIA/AAABAAIAAAACAAMA"}],
    "bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": 48}, {"buffer": 0, "byteOffset": 48, "byteLength": 48},
                    {"buffer": 0, "byteOffset": 96, "byteLength": 12}],
    "accessors": [{"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3", "min": [-0.5, -0.5, 0], "max": [0.5, 0.5, 0]},
                  {"bufferView": 1, "componentType": 5126, "count": 4, "type": "VEC3"},
                  {"bufferView": 2, "componentType": 5123, "count": 6, "type": "SCALAR"}],
    "extensionsUsed": ["KHR_lights_punctual"],
    "extensions": {"KHR_lights_punctual": {"lights": [{"type": "directional", "intensity": 3.14159265}]}}
  })";
  auto s = scene::load_scene(dir / "quad.gltf");
  REQUIRE_MESSAGE(s, (s ? "" : s.error().message));
  s->output = {80, 80};
  // The file has no sky and no light placed by a node: a black sky and a light along -z.
  s->environment = scene::Environment{};
  s->lights = {scene::DirectionalLight{.direction = {0, 0, -1}, .intensity = 3.14159265f}};
  auto frame = shared_renderer().render(*s, {.aces = false});
  REQUIRE_MESSAGE(frame, (frame ? "" : frame.error().message));
  // The quad spans x in [-0.25, 0.75] at distance 2 under a 60° field of view: pixels
  // 40 + 40 * x / (2 tan 30°).
  auto px = [](float x) { return std::uint32_t(40.0f + 40.0f * x / (2.0f * std::tan(30.0f * pi / 180.0f))); };
  const std::uint32_t inside = px(0.6f), outside = px(-0.4f);
  CHECK(channel(frame->image, inside, 40, 0) > 200);  // red, lit
  CHECK(channel(frame->image, inside, 40, 1) < 40);  // only the 4 % white specular
  CHECK(channel(frame->image, outside, 40, 0) < 10);  // left of the moved quad: empty
  std::filesystem::remove_all(dir);
  weft::test::expect_no_validation_messages();
}

TEST_CASE("a second frame of the same scene uploads and compiles nothing new") {
  auto s = load(furnace);
  auto& r = shared_renderer();
  auto first = r.render(s);
  REQUIRE(first);
  const auto before = r.cache_stats();
  auto frame = r.render(s);
  REQUIRE(frame);
  const auto after = r.cache_stats();
  CHECK(after.mesh_uploads == before.mesh_uploads);
  CHECK(after.environment_uploads == before.environment_uploads);
  CHECK(after.texture_uploads == before.texture_uploads);
  CHECK(after.pass_creations == before.pass_creations);
  // The same frame again: the graph takes the last plan (and its transients) over, and the
  // image is the same to the byte.
  CHECK(after.graph_plans == before.graph_plans);
  CHECK(after.graph_plans_reused == before.graph_plans_reused + 1);
  CHECK(frame->image.pixels == first->image.pixels);
  // Another size is another plan.
  auto smaller = r.render(s, {.width = 48, .height = 32});
  REQUIRE(smaller);
  CHECK(r.cache_stats().graph_plans == after.graph_plans + 1);
  weft::test::expect_no_validation_messages();
}

TEST_CASE("bad output sizes are errors, not crashes") {
  auto s = load(furnace);
  auto frame = shared_renderer().render(s, {.width = 100000, .height = 10});
  REQUIRE(!frame);
  CHECK(frame.error().message.find("100000x10") != std::string::npos);
}

TEST_CASE("issue 33: a scene camera with NaN or infinity is an error naming the field, for render and describe") {
  // A scene file's camera is checked when read; one built in code (or a viewer's pose) is not.
  auto s = load(furnace);
  s.lights.push_back(scene::DirectionalLight{.name = "sun", .direction = {-0.4f, -1.0f, -0.3f}});
  struct Case {
    void (*spoil)(scene::Camera&);
    const char* expect;
  };
  for (const Case& c : {Case{[](scene::Camera& k) { k.position.x = NAN; }, "scene camera: position (nan, 0, 4) is not finite"},
                        Case{[](scene::Camera& k) { k.target.y = INFINITY; }, "scene camera: target (0, inf, 0) is not finite"},
                        Case{[](scene::Camera& k) { k.up.z = -INFINITY; }, "scene camera: up (0, 1, -inf) is not finite"},
                        Case{[](scene::Camera& k) { k.fov_y_degrees = NAN; }, "scene camera: fov nan is not finite"},
                        Case{[](scene::Camera& k) { k.far = INFINITY; }, "scene camera: far inf is not finite"}}) {
    scene::Scene bad = s;
    c.spoil(bad.camera);
    CAPTURE(c.expect);
    auto frame = shared_renderer().render(bad, {.width = 32, .height = 32});
    REQUIRE_FALSE(frame);
    CHECK(frame.error().kind == ErrorKind::InvalidArgument);
    CHECK(frame.error().message == c.expect);
    auto report = shared_renderer().describe(bad, {.width = 32, .height = 32});
    REQUIRE_FALSE(report);
    CHECK(report.error().message == c.expect);
  }
  // The renderer is fine afterwards.
  CHECK(shared_renderer().render(s, {.width = 32, .height = 32}));
}
