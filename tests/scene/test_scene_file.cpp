// weft.scene scene files and JsonReader: a valid file parses and loads; unknown fields,
// wrong types, bad references and missing files are errors at their JSON path, all of a
// file's problems at once; feature materials keep their parameters for their passes.
#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <string>
#include <variant>
#include <vector>

#include <glm/glm.hpp>
#include <nlohmann/json.hpp>

#include "support.h"

import weft.core;
import weft.scene;

using namespace scene_test;
using weft::ErrorKind;
using weft::mat4;
using weft::vec3;
using weft::vec4;
namespace sc = weft::scene;

// The scene knows no features: these tests register the type a fur feature would (the
// registry in weft.feature does this for real features), with its old name as an alias.
const bool fur_type_registered = [] {
  const std::vector<std::string> aliases{"fur"};
  return bool(sc::register_material_type("shell_fur", aliases));
}();

namespace {

bool near3(vec3 a, vec3 b, float eps = 1e-5f) { return glm::length(a - b) <= eps; }

// A scene using every section; "cow.obj" and "sky.hdr" must exist next to it.
const char* full_scene = R"({
  "version": 1,
  "description": "every section once",
  "output": {"width": 640, "height": 360},
  "camera": {"position": [0, 2, 6], "target": [0, 0.5, 0], "up": [0, 1, 0], "fov": 40, "near": 0.05, "far": 50},
  "environment": {"color": [0.1, 0.2, 0.3], "intensity": 1.5, "rotation": 30},
  "lights": [
    {"type": "directional", "name": "sun", "direction": [0, -2, 0], "color": [1, 0.9, 0.8], "intensity": 3},
    {"type": "point", "position": [1, 2, 3], "intensity": 20, "range": 10},
    {"type": "spot", "position": [0, 4, 0], "direction": [0, -1, 0], "inner_cone": 10, "outer_cone": 30}
  ],
  "meshes": {
    "ball": {"primitive": "sphere", "radius": 0.5, "segments": 32},
    "floor": {"primitive": "plane", "size": 10, "subdivisions": 4},
    "ring": {"primitive": "torus", "major_radius": 1, "minor_radius": 0.2, "segments": 32, "sides": 16},
    "box": {"primitive": "cube", "size": 0.5},
    "cow": {"path": "cow.obj", "normalize_to_unit_box": true}
  },
  "materials": {
    "red": {"type": "standard", "base_color": [0.8, 0.1, 0.1], "metallic": 0, "roughness": 0.4, "emissive": [0, 0, 0]},
    "grey": {"base_color": [0.5, 0.5, 0.5]},
    "fur": {"type": "fur", "layers": 32, "photo": "fur.jpg", "anything": {"nested": [1, 2]}}
  },
  "objects": [
    {"name": "ball", "mesh": "ball", "material": "red", "transform": {"translation": [1, 0.5, 0]}},
    {"name": "floor", "mesh": "floor", "material": "grey"},
    {"name": "cow", "mesh": "cow", "material": "fur",
     "transform": {"rotation_degrees": [0, 90, 0], "scale": 2}},
    {"mesh": "ring", "transform": {"quaternion": [0, 0, 0, 2], "scale": [1, 2, 3]}}
  ]
})";

struct SceneDir {
  TempDir dir;
  SceneDir() { write_file(dir / "cow.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n"); }
};

weft::Result<sc::SceneDesc> parse(std::string_view text, const std::filesystem::path& base = {}) {
  return sc::parse_scene(text, base, "test.json");
}

}  // namespace

TEST_CASE("scene file: a valid file parses into a SceneDesc and loads into a Scene") {
  SceneDir s;
  auto desc = parse(full_scene, s.dir.path);
  REQUIRE_MESSAGE(desc.has_value(), desc.error().what());
  CHECK(desc->version == 1);
  CHECK(desc->output.width == 640);
  CHECK(desc->output.height == 360);
  REQUIRE(desc->camera.has_value());
  CHECK(desc->camera->fov_y_degrees == doctest::Approx(40.0f));
  CHECK(near3(desc->camera->target, {0, 0.5f, 0}));
  CHECK(near3(desc->environment.color, {0.1f, 0.2f, 0.3f}));
  CHECK(desc->environment.intensity == doctest::Approx(1.5f));
  CHECK(desc->environment.rotation_degrees == doctest::Approx(30.0f));

  REQUIRE(desc->lights.size() == 3);
  const auto& sun = std::get<sc::DirectionalLight>(desc->lights[0]);
  CHECK(sun.name == "sun");
  CHECK(near3(sun.direction, {0, -1, 0}));  // normalised
  CHECK(sun.intensity == doctest::Approx(3.0f));
  const auto& point = std::get<sc::PointLight>(desc->lights[1]);
  CHECK(point.name == "light 1");
  CHECK(point.range == doctest::Approx(10.0f));
  const auto& spot = std::get<sc::SpotLight>(desc->lights[2]);
  CHECK(spot.outer_cone_degrees == doctest::Approx(30.0f));

  REQUIRE(desc->meshes.size() == 5);  // sorted by name: ball, box, cow, floor, ring
  CHECK(desc->meshes[0].name == "ball");
  CHECK(desc->meshes[0].primitive == sc::PrimitiveKind::Sphere);
  CHECK(desc->meshes[0].segments == 32);
  CHECK(desc->meshes[2].path == s.dir.path / "cow.obj");  // resolved against the file's folder
  CHECK(desc->meshes[2].options.normalize_to_unit_box);

  const auto material = [&](std::string_view name) -> const sc::Material& {
    return *std::find_if(desc->materials.begin(), desc->materials.end(), [&](const auto& m) { return m.name == name; });
  };
  CHECK(material("red").standard.roughness == doctest::Approx(0.4f));
  CHECK(near3(material("grey").standard.base_color, vec3(0.5f)));
  const sc::Material& fur = material("fur");
  CHECK(fur_type_registered);
  CHECK(fur.type == "shell_fur");  // the alias "fur" resolves to the registered name
  CHECK(fur.json_path == "$.materials.fur");
  CHECK(fur.base_dir == s.dir.path);
  CHECK(fur.params.at("layers") == 32);
  CHECK(fur.params.at("anything").at("nested").size() == 2);
  CHECK_FALSE(fur.params.contains("type"));
  // The object without a material got the built-in "default" standard material.
  CHECK(material("default").type == sc::standard_material);

  REQUIRE(desc->objects.size() == 4);
  CHECK(desc->objects[3].name == "object 3");
  CHECK(near3(desc->objects[0].transform.translation, {1, 0.5f, 0}));
  const mat4 cow = desc->objects[2].transform.matrix();
  CHECK(near3(vec3(cow * vec4(1, 0, 0, 1)), {0, 0, -2}, 1e-5f));  // 90 degrees about +Y, scale 2
  CHECK(near3(desc->objects[3].transform.scale, {1, 2, 3}));

  auto scene = sc::load_scene(*desc);
  REQUIRE_MESSAGE(scene.has_value(), scene.error().what());
  CHECK(scene->meshes.size() == 5);
  CHECK(scene->objects.size() == 4);
  CHECK(scene->meshes[2].bounds.size().x == doctest::Approx(1.0f));  // normalised cow
  CHECK(scene->uses("shell_fur"));
  CHECK(scene->uses(sc::standard_material));
  CHECK_FALSE(scene->uses("skin_sss"));
  CHECK(near3(scene->environment.constant_color, {0.1f, 0.2f, 0.3f}));
  CHECK_FALSE(scene->environment.map.has_value());
  CHECK(scene->bounds().max.x >= 5.0f - 1e-4f);  // the floor
}

TEST_CASE("scene file: load_scene_file resolves paths against the file's folder") {
  SceneDir s;
  std::filesystem::create_directories(s.dir / "scenes");
  write_file(s.dir / "scenes" / "a.json",
             R"({"meshes": {"cow": {"path": "../cow.obj"}}, "objects": [{"mesh": "cow"}]})");
  auto desc = sc::load_scene_file(s.dir / "scenes" / "a.json");
  REQUIRE_MESSAGE(desc.has_value(), desc.error().what());
  CHECK(desc->source == s.dir / "scenes" / "a.json");
  CHECK(desc->meshes[0].path == s.dir.path / "cow.obj");
  CHECK_FALSE(desc->camera.has_value());
  auto scene = sc::load_scene(s.dir / "scenes" / "a.json");
  REQUIRE_MESSAGE(scene.has_value(), scene.error().what());
  CHECK(sc::validate(scene->camera).has_value());  // framed from the bounds
  CHECK(scene->lights.empty());                    // a scene file says what it wants

  auto missing = sc::load_scene_file(s.dir / "none.json");
  REQUIRE_FALSE(missing.has_value());
  CHECK(missing.error().kind == ErrorKind::NotFound);
}

TEST_CASE("scene file: an unknown field is an error with its JSON path and a suggestion") {
  auto r = parse(R"({"camera": {"fov_y": 40}, "objects": []})");
  REQUIRE_FALSE(r.has_value());
  CHECK(r.error().kind == ErrorKind::Parse);
  CHECK(contains(r.error().message, "test.json"));
  CHECK(contains(r.error().message, "$.camera.fov_y: unknown field (did you mean 'fov'?)"));

  auto top = parse(R"({"objectz": []})");
  REQUIRE_FALSE(top.has_value());
  CHECK(contains(top.error().message, "$.objectz: unknown field (did you mean 'objects'?)"));

  auto far_off = parse(R"({"output": {"width": 10, "colour_space": "srgb"}})");
  REQUIRE_FALSE(far_off.has_value());
  CHECK(contains(far_off.error().message, "$.output.colour_space: unknown field (known fields: height, width)"));
}

TEST_CASE("scene file: a wrong type is an error with its JSON path") {
  SceneDir s;
  auto r = parse(R"({"meshes": {"b": {"primitive": "cube"}},
                     "objects": [{"mesh": "b"}, {"mesh": "b"}, {"mesh": "b", "transform": {"scale": "big"}}]})",
                 s.dir.path);
  REQUIRE_FALSE(r.has_value());
  CHECK(contains(r.error().message,
                 "$.objects[2].transform.scale: expected a number or an array of 3 numbers, got string"));
  auto w = parse(R"({"output": {"width": "wide"}})");
  REQUIRE_FALSE(w.has_value());
  CHECK(contains(w.error().message, "$.output.width: expected an integer, got string"));
  auto v = parse(R"({"camera": {"position": [1, 2]}})");
  REQUIRE_FALSE(v.has_value());
  CHECK(contains(v.error().message, "$.camera.position: expected an array of 3 numbers, got an array of 2"));
  auto e = parse(R"({"camera": {"target": [1, "x", 3]}})");
  REQUIRE_FALSE(e.has_value());
  CHECK(contains(e.error().message, "$.camera.target[1]: expected a number, got string"));
  auto top = parse(R"([1, 2, 3])");
  REQUIRE_FALSE(top.has_value());
  CHECK(contains(top.error().message, "$: a scene file is a JSON object, got array"));
}

TEST_CASE("scene file: unknown mesh and material references name the object and the reference") {
  auto r = parse(R"({"meshes": {"ball": {"primitive": "sphere"}},
                     "materials": {"red": {"base_color": [1, 0, 0]}},
                     "objects": [{"name": "hero", "mesh": "cow", "material": "blue"}]})");
  REQUIRE_FALSE(r.has_value());
  CHECK(contains(r.error().message, "$.objects[0].mesh: object 'hero' uses unknown mesh 'cow' (meshes: ball)"));
  CHECK(contains(r.error().message, "$.objects[0].material: object 'hero' uses unknown material 'blue' (materials: red)"));
  CHECK(contains(r.error().message, "2 problems"));
}

TEST_CASE("scene file: every problem of a file is reported at once, one per line") {
  auto r = parse(R"({
    "version": 2,
    "output": {"width": 0},
    "camera": {"fov": 200, "near": -1},
    "environment": {"intensity": -3, "color": [1, 1]},
    "lights": [{"type": "laser"}, {"direction": [0, 0, 0], "type": "directional"}, 7],
    "meshes": {"m": {"primitive": "sphere", "radius": 0}, "n": {}, "o": {"path": "x.obj", "primitive": "cube"}},
    "materials": {"a": {"type": "velvet"}, "b": {"roughness": 2, "shininess": 1}},
    "objects": [{"material": "a"}, {"mesh": "m", "transform": {"rotation_degrees": [0, 0, 0], "quaternion": [0, 0, 0, 1]}}]
  })");
  REQUIRE_FALSE(r.has_value());
  const std::string& msg = r.error().message;
  const std::vector<std::string> expected = {
      "$.version: unsupported version 2",
      "$.output.width: 0 is out of range [1, 8192]",
      "$.camera.fov: 200 is out of range [0.01, 179]",
      "$.camera.near: -1 is out of range: must be > 0",
      "$.environment.color: expected an array of 3 numbers, got an array of 2",
      "$.environment.intensity: -3 is out of range: must be >= 0",
      "$.lights[0].type: 'laser' is not one of: directional, point, spot",
      "$.lights[1].direction: a direction must not be zero",
      "$.lights[2]: expected an object, got number",
      "$.meshes.m.radius: 0 is out of range: must be > 0",
      "$.meshes.n: a mesh needs a \"path\" or a \"primitive\"",
      "$.meshes.o: give either \"path\" or \"primitive\", not both",
      "$.meshes.o.path: file not found",
      "$.materials.a.type: unknown material type 'velvet'; known: standard, shell_fur (fur)",
      "$.materials.b.roughness: 2 is out of range [0, 1]",
      "$.materials.b.shininess: unknown field",
      "$.objects[0].mesh: missing required field",
      "$.objects[1].transform: give either \"rotation_degrees\" or \"quaternion\", not both",
  };
  for (const std::string& e : expected) CHECK_MESSAGE(contains(msg, e), e);
  // One line per problem after the summary line.
  const auto lines = std::count(msg.begin(), msg.end(), '\n');
  CHECK(contains(msg, weft::format("{} problems", lines)));
  CHECK(lines >= std::ptrdiff_t(expected.size()));
}

TEST_CASE("scene file: invalid JSON gives the line and column") {
  auto r = parse("{\n  \"output\": {\"width\": 10,}\n}");
  REQUIRE_FALSE(r.has_value());
  CHECK(r.error().kind == ErrorKind::Parse);
  CHECK(contains(r.error().message, "test.json: invalid JSON"));
  CHECK(contains(r.error().message, "line 2"));
  auto empty = parse("");
  REQUIRE_FALSE(empty.has_value());
  CHECK(contains(empty.error().message, "invalid JSON"));
}

TEST_CASE("scene file: an environment map and textures must exist; hdr and color exclude each other") {
  SceneDir s;
  auto r = parse(R"({"environment": {"hdr": "sky.hdr", "color": [1, 1, 1]},
                     "materials": {"t": {"base_color_texture": "albedo.png", "normal_texture": 3}}})",
                 s.dir.path);
  REQUIRE_FALSE(r.has_value());
  const std::string& msg = r.error().message;
  CHECK(contains(msg, "$.environment: give either \"hdr\" or \"color\", not both"));
  CHECK(contains(msg, "$.environment.hdr: file not found: '" + (s.dir / "sky.hdr").string() + "'"));
  CHECK(contains(msg, "$.materials.t.base_color_texture: file not found"));
  CHECK(contains(msg, "$.materials.t.normal_texture: expected a path (a string), got number"));
}

TEST_CASE("JsonReader: typed fields with defaults and ranges, for a feature's params") {
  SceneDir s;
  write_file(s.dir / "fur.jpg", "x");
  auto desc = parse(full_scene, s.dir.path);
  REQUIRE(desc.has_value());
  const sc::Material& fur = *std::find_if(desc->materials.begin(), desc->materials.end(),
                                          [](const auto& m) { return m.type == "shell_fur"; });
  sc::JsonErrors errors;
  sc::JsonReader reader(fur.params, fur.json_path, errors, fur.base_dir);
  CHECK(reader.integer("layers", 15, {.min = 1, .max = 256}) == 32);
  CHECK(reader.number("density", 0.5, {.min = 0, .max = 1}) == 0.5);  // absent: the default
  CHECK(reader.path("photo") == s.dir.path / "fur.jpg");
  (void)reader.value("anything");
  reader.finish();
  CHECK(errors.empty());

  sc::JsonErrors errors2;
  sc::JsonReader strict(fur.params, fur.json_path, errors2, fur.base_dir);
  CHECK(strict.integer("layers", 15, {.min = 1, .max = 16}) == 15);  // out of range: the default
  strict.finish();  // "photo" and "anything" were never asked about
  REQUIRE(errors2.size() == 3);
  CHECK(errors2.lines()[0] == "$.materials.fur.layers: 32 is out of range [1, 16]");
  CHECK(contains(errors2.lines()[1], "$.materials.fur.anything: unknown field"));
  const weft::Error e = errors2.to_error("fur");
  CHECK(e.kind == ErrorKind::Parse);
  CHECK(contains(e.message, "fur: 3 problems:\n$.materials.fur.layers"));
}

TEST_CASE("JsonReader: each type check") {
  const nlohmann::json j = nlohmann::json::parse(R"({"i": 1.5, "n": 2, "b": "yes", "s": 4, "c": "blue",
    "v": [1, 2, 3, 4], "odd key": 1, "o": [1], "a": {"x": 1}, "list": [{"k": 1}, 2], "big": 1e300})");
  sc::JsonErrors errors;
  sc::JsonReader r(j, "$", errors);
  CHECK(r.integer("i", 7) == 7);
  CHECK(r.integer("n", 7) == 2);
  CHECK(r.number("n", 0, {.max = 2, .max_exclusive = true}) == 0);
  CHECK(r.boolean("b", true));
  CHECK(r.string("s", "d") == "d");
  CHECK(r.string("c", "red", {"red", "green"}) == "red");
  CHECK(r.vec3_of("v", vec3(9)) == vec3(9));
  CHECK(r.vec4_of("v", weft::vec4(0)) == weft::vec4(1, 2, 3, 4));
  CHECK(r.number("odd key", 0) == 1);
  CHECK_FALSE(r.object("o").has_value());
  auto a = r.object("a");
  REQUIRE(a.has_value());
  CHECK(a->json_path() == "$.a");
  CHECK(a->number("x", 0) == 1);
  a->finish();
  auto list = r.array("list");
  REQUIRE(list.size() == 2);
  CHECK(list[0].json_path() == "$.list[0]");
  CHECK(list[0].number("k", 0) == 1);
  CHECK(list[1].number("k", 5) == 5);  // not an object: reported once
  CHECK(list[1].number("q", 5) == 5);
  CHECK(r.vec2_of("big", weft::vec2(0)) == weft::vec2(0));
  CHECK(r.path_of("odd key") == "$['odd key']");
  r.finish();
  const auto& l = errors.lines();
  const std::vector<std::string> expected = {
      "$.i: expected an integer, got 1.5",
      "$.n: 2 is out of range: must be < 2",
      "$.b: expected true or false, got string",
      "$.s: expected a string, got number",
      "$.c: 'blue' is not one of: red, green",
      "$.v: expected an array of 3 numbers, got an array of 4",
      "$.o: expected an object, got array",
      "$.list[1]: expected an object, got number",
      "$.big: expected an array of 2 numbers, got number",
  };
  for (const std::string& e : expected) CHECK_MESSAGE(std::find(l.begin(), l.end(), e) != l.end(), e);
  CHECK(l.size() == expected.size());
}
