// Regression tests for the crashes and silent failures a held-out run found in weft.scene
// (issue 21): deep glTF hierarchies and JSON, buffer URIs leaving the asset's folder,
// repeated keys, out-of-range scene and camera indices, values that overflow a float.
#include <doctest/doctest.h>

#include <algorithm>
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include <glm/glm.hpp>

#include "support.h"

import weft.core;
import weft.scene;

using namespace scene_test;
using weft::ErrorKind;
namespace sc = weft::scene;

namespace {

// A glTF around the test quad with `nodes` and `scenes` spliced in as given, and `extra`
// top-level members (each ending in a comma).
std::string quad_gltf(const std::string& nodes, const std::string& scenes, const std::string& extra = "",
                      const std::string& buffer_uri = "") {
  const std::string uri =
      buffer_uri.empty() ? "data:application/octet-stream;base64," + base64(quad_buffer()) : buffer_uri;
  return R"({"asset": {"version": "2.0"}, )" + extra + R"( "scenes": )" + scenes + R"(, "nodes": )" + nodes + R"(,
  "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "indices": 1}]}],
  "buffers": [{"byteLength": 140, "uri": ")" + uri + R"("}],
  "bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": 48}, {"buffer": 0, "byteOffset": 128, "byteLength": 12}],
  "accessors": [{"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3", "min": [0, 0, 0], "max": [1, 1, 0]},
                {"bufferView": 1, "componentType": 5123, "count": 6, "type": "SCALAR"}]})";
}

// A chain of `depth` nodes, each moved 0.001 along +Z from its parent; the last draws the quad.
std::string chain_nodes(int depth) {
  std::string nodes = "[";
  for (int i = 0; i < depth; ++i) {
    nodes += R"({"translation": [0, 0, 0.001])";
    nodes += i + 1 < depth ? R"(, "children": [)" + std::to_string(i + 1) + "]}," : R"(, "mesh": 0}])";
  }
  return nodes;
}

std::string nested_array(int depth) { return std::string(std::size_t(depth), '[') + std::string(std::size_t(depth), ']'); }

weft::Result<sc::GltfScene> load_text(const TempDir& dir, const std::string& name, const std::string& text) {
  write_file(dir / name, text);
  return sc::load_gltf(dir / name);
}

const char* minimal_scene_head = R"({"version": 1, "meshes": {"m": {"primitive": "cube"}}, "objects": [{"mesh": "m"}])";

}  // namespace

TEST_CASE("a glTF node chain 20,000 deep loads, with the transforms composed") {
  TempDir dir;
  auto scene = load_text(dir, "chain.gltf", quad_gltf(chain_nodes(20000), R"([{"nodes": [0]}])"));
  REQUIRE_MESSAGE(scene.has_value(), scene.error().what());
  REQUIRE(scene->instances.size() == 1);
  const glm::vec3 origin = glm::vec3(scene->instances[0].transform * glm::vec4(0, 0, 0, 1));
  CHECK(origin.z == doctest::Approx(20.0).epsilon(1e-2));
  CHECK(origin.x == 0.0f);
}

TEST_CASE("a glTF whose JSON nests 20,000 deep is refused before tinygltf reads it (.gltf and .glb)") {
  TempDir dir;
  auto deep = load_text(dir, "deep.gltf", quad_gltf(R"([{"mesh": 0, "extras": )" + nested_array(20000) + "}]",
                                                    R"([{"nodes": [0]}])"));
  REQUIRE_FALSE(deep.has_value());
  CHECK(deep.error().kind == ErrorKind::Parse);
  CHECK_MESSAGE(contains(deep.error().message, "$.nodes[0].extras"), deep.error().message);
  CHECK_MESSAGE(contains(deep.error().message, "nested deeper than 512 levels"), deep.error().message);

  std::string json = R"({"asset": {"version": "2.0"}, "extras": )" + nested_array(20000) + "}";
  while (json.size() % 4 != 0) json.push_back(' ');
  std::vector<std::uint8_t> glb;
  append(glb, std::uint32_t{0x46546C67});
  append(glb, std::uint32_t{2});
  append(glb, std::uint32_t(12 + 8 + json.size()));
  append(glb, std::uint32_t(json.size()));
  append(glb, std::uint32_t{0x4E4F534A});
  glb.insert(glb.end(), json.begin(), json.end());
  write_file(dir / "deep.glb", glb);
  auto deep_glb = sc::load_gltf(dir / "deep.glb");
  REQUIRE_FALSE(deep_glb.has_value());
  CHECK_MESSAGE(contains(deep_glb.error().message, "nested deeper than 512 levels"), deep_glb.error().message);

  // 500 levels of extras are still read.
  auto fine = load_text(dir, "fine.gltf", quad_gltf(R"([{"mesh": 0, "extras": )" + nested_array(500) + "}]",
                                                    R"([{"nodes": [0]}])"));
  CHECK_MESSAGE(fine.has_value(), fine.error().what());
}

TEST_CASE("glTF buffer and image URIs must stay inside the asset's folder") {
  TempDir dir;
  std::filesystem::create_directories(dir / "asset");
  write_file(dir / "outside.bin", quad_buffer());  // the right size: only the folder rule refuses it
  write_file(dir / "asset" / "inside.bin", quad_buffer());
  const std::string nodes = R"([{"mesh": 0}])", scenes = R"([{"nodes": [0]}])";

  auto inside = load_text(dir, "asset/inside.gltf", quad_gltf(nodes, scenes, "", "inside.bin"));
  CHECK_MESSAGE(inside.has_value(), inside.error().what());
  auto dotted = load_text(dir, "asset/dotted.gltf", quad_gltf(nodes, scenes, "", "./sub/../inside.bin"));
  CHECK_MESSAGE(dotted.has_value(), dotted.error().what());

  for (const std::string& uri : std::vector<std::string>{"../outside.bin", "../../../../../../etc/passwd", (dir / "outside.bin").string()}) {
    auto out = load_text(dir, "asset/escape.gltf", quad_gltf(nodes, scenes, "", uri));
    REQUIRE_FALSE(out.has_value());
    CHECK_MESSAGE(contains(out.error().message, "outside the glTF file's folder"), uri << ": " << out.error().message);
  }

  const std::string image = R"("images": [{"uri": "../outside.png"}], "textures": [{"source": 0}],
    "materials": [{"pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}}],)";
  auto texture = load_text(dir, "asset/texture.gltf", quad_gltf(nodes, scenes, image));
  REQUIRE_FALSE(texture.has_value());
  CHECK_MESSAGE(contains(texture.error().message, "leads outside the glTF file's folder"), texture.error().message);
}

TEST_CASE("glTF: a \"scene\" that does not exist, version 1.0 and repeated keys are errors") {
  TempDir dir;
  const std::string nodes = R"([{"mesh": 0}])", scenes = R"([{"nodes": [0]}])";
  auto missing = load_text(dir, "scene5.gltf", quad_gltf(nodes, scenes, R"("scene": 5,)"));
  REQUIRE_FALSE(missing.has_value());
  CHECK_MESSAGE(contains(missing.error().message, "\"scene\" is 5, but there are 1 scenes"), missing.error().message);

  std::string v1 = quad_gltf(nodes, scenes);
  v1.replace(v1.find("\"2.0\""), 5, "\"1.0\"");
  auto old = load_text(dir, "v1.gltf", v1);
  REQUIRE_FALSE(old.has_value());
  CHECK(old.error().kind == ErrorKind::Unsupported);
  CHECK_MESSAGE(contains(old.error().message, "asset.version is '1.0'"), old.error().message);

  auto twice = load_text(dir, "twice.gltf", quad_gltf(R"([{"mesh": 0, "mesh": 0}])", scenes));
  REQUIRE_FALSE(twice.has_value());
  CHECK_MESSAGE(contains(twice.error().message, "$.nodes[0]: the key 'mesh' appears twice"), twice.error().message);
}

TEST_CASE("glTF: a camera with a 1e-30 fov is skipped, lights too bright to shade are errors") {
  TempDir dir;
  const std::string scenes = R"([{"nodes": [0, 1]}])";
  auto narrow = load_text(dir, "narrow.gltf",
                          quad_gltf(R"([{"mesh": 0}, {"camera": 0, "translation": [0, 0, 5]}])", scenes,
                                    R"("cameras": [{"type": "perspective", "perspective": {"yfov": 1e-30, "znear": 0.1}}],)"));
  REQUIRE_MESSAGE(narrow.has_value(), narrow.error().what());
  CHECK(narrow->cameras.empty());
  CHECK(std::any_of(narrow->warnings.begin(), narrow->warnings.end(),
                    [](const std::string& w) { return contains(w, "camera 0 of node 'node 1' skipped: camera fov"); }));

  auto bright = load_text(
      dir, "bright.gltf",
      quad_gltf(R"([{"mesh": 0}, {"extensions": {"KHR_lights_punctual": {"light": 0}}}])", scenes,
                R"("extensions": {"KHR_lights_punctual": {"lights": [{"type": "point", "intensity": 1e38}]}},)"));
  REQUIRE_FALSE(bright.has_value());
  CHECK_MESSAGE(contains(bright.error().message, "weft draws up to intensity"), bright.error().message);
}

TEST_CASE("scene files: repeated keys, huge numbers, a 1e-30 fov and a 1e38 light are reported at their path") {
  struct Case {
    std::string json, expect;
  };
  const std::string head = minimal_scene_head;
  for (const Case& c : {
           Case{R"({"version": 1, "version": 1})", "$: the key 'version' appears twice in one object"},
           Case{head + R"(, "materials": {"a": {"roughness": 0.1, "roughness": 0.9}}})",
                "$.materials.a: the key 'roughness' appears twice"},
           Case{head + R"(, "camera": {"position": [0, 0, 1e+308]}})",
                "$.camera.position[2]: 1e+308 is too large: the limit is 3.4e+38"},
           Case{head + R"(, "camera": {"near": 1e+300}})", "$.camera.near: 1e+300 is too large"},
           Case{head + R"(, "camera": {"fov": 1e-30}})", "$.camera.fov: 1e-30 is out of range [0.01, 179]"},
           Case{head + R"(, "lights": [{"type": "point", "intensity": 1e38}]})", "$.lights[0].intensity: 1e+38 is out of range [0, 10000000]"},
           Case{head + R"(, "lights": [{"type": "point", "color": [1, 1000, 1]}]})", "$.lights[0].color[1]: 1000 is out of range [0, 100]"},
           Case{R"({"version": 1, "meshes": {"p": {"primitive": "plane", "subdivisions": 4096}}, "objects": [{"mesh": "p"}]})",
                "$.meshes.p.subdivisions: 4096 is out of range [1, 1024]"},
           Case{R"({"version": 1, "output": {"width": 16384}})", "$.output.width: 16384 is out of range [1, 8192]"},
           Case{R"({"version": 1, "description": )" + nested_array(300) + "}", "$.description[0][0]"},
           Case{R"({"version": 1, "description": )" + nested_array(300) + "}", ": nested deeper than 256 levels"},
       }) {
    auto desc = sc::parse_scene(c.json, ".", "scene 't.json'");
    REQUIRE_FALSE_MESSAGE(desc.has_value(), c.json);
    CHECK_MESSAGE(contains(desc.error().message, c.expect), desc.error().message);
    CHECK_FALSE(contains(desc.error().message, "must be finite"));
  }
}

TEST_CASE("OBJ: a vertex of nan is reported at its line, not as indices out of range") {
  TempDir dir;
  write_file(dir / "nan.obj", "v 0 0 0\nv 1 0 0\nv nan nan nan\nf 1 2 3\n");
  auto mesh = sc::load_mesh(dir / "nan.obj");
  REQUIRE_FALSE(mesh.has_value());
  CHECK_MESSAGE(contains(mesh.error().message, "line 3: 'nan' in a 'v' line is not a finite number"), mesh.error().message);
  write_file(dir / "big.obj", "v 0 0 0\nv 1 0 0\nvt 1e999 0\nv 0 1 0\nf 1 2 3\n");
  auto big = sc::load_mesh(dir / "big.obj");
  REQUIRE_FALSE(big.has_value());
  CHECK_MESSAGE(contains(big.error().message, "line 3: '1e999'"), big.error().message);
  // Signs, exponents and comments are still read.
  write_file(dir / "ok.obj", "v +0 -0 0\nv 1e0 0 0\nv 0 1.0E+0 0\nvn 0 0 1\nf 1//1 2//1 3//1\n");
  auto ok = sc::load_mesh(dir / "ok.obj");
  CHECK_MESSAGE(ok.has_value(), ok.error().what());
}
