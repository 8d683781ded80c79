// weft.scene glTF: a hierarchy with a camera and a KHR light (embedded base64 buffer and
// GLB), materials, merging into one mesh, and the error and warning paths.
#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <string>
#include <variant>
#include <vector>
#include <sys/stat.h>
#include <unistd.h>

#include <glm/glm.hpp>

#include <nlohmann/json.hpp>

#include "support.h"

import weft.core;
import weft.scene;
import weft.image;

using namespace scene_test;
using weft::ErrorKind;
using weft::mat4;
using weft::vec3;
using weft::vec4;
namespace sc = weft::scene;

namespace {

bool near3(vec3 a, vec3 b, float eps = 1e-5f) { return glm::length(a - b) <= eps; }
vec3 apply(const mat4& m, vec3 p) { return vec3(m * vec4(p, 1.0f)); }

const sc::Object* instance(const sc::GltfScene& s, std::string_view name) {
  for (const auto& o : s.instances) {
    if (o.name == name) return &o;
  }
  return nullptr;
}

void check_quad_scene(const sc::GltfScene& s) {
  REQUIRE(s.meshes.size() == 1);
  const sc::Mesh& quad = s.meshes[0];
  CHECK(quad.name == "quad");
  CHECK(quad.vertex_count() == 4);
  CHECK(quad.triangle_count() == 2);
  CHECK(quad.has_uvs());
  for (std::size_t i = 0; i < 4; ++i) {
    CHECK(near3(quad.normals[i], {0, 0, 1}));
    CHECK(near3(vec3(quad.tangents[i]), {1, 0, 0}));  // u along +X
    // v grows along +Y = cross(n, t), so the image's top (v = 0) is at the bottom: mirrored.
    CHECK(quad.tangents[i].w == -1.0f);
  }

  REQUIRE(s.instances.size() == 2);
  const sc::Object* child = instance(s, "child");
  const sc::Object* turned = instance(s, "turned");
  REQUIRE(child != nullptr);
  REQUIRE(turned != nullptr);
  // child = T(1,0,0) S(2) T(0,1,0): its origin lands at (1,2,0), the quad's far corner at (3,4,0).
  CHECK(near3(apply(child->transform, {0, 0, 0}), {1, 2, 0}));
  CHECK(near3(apply(child->transform, {1, 1, 0}), {3, 4, 0}));
  // turned: 90 degrees about +Y takes +X to -Z.
  CHECK(near3(apply(turned->transform, {1, 0, 0}), {0, 0, -1}, 1e-4f));

  REQUIRE(s.materials.size() == 1);
  const sc::Material& red = s.materials[child->material];
  CHECK(red.name == "red");
  CHECK(red.type == sc::standard_material);
  CHECK(near3(red.standard.base_color, {1, 0, 0}));
  CHECK(red.standard.metallic == doctest::Approx(0.25f));
  CHECK(red.standard.roughness == doctest::Approx(0.75f));
  CHECK(near3(red.standard.emissive, {0.5f, 0, 0}));

  REQUIRE(s.cameras.size() == 1);
  const sc::Camera& cam = s.cameras[0];
  CHECK(near3(cam.position, {0, 0, 5}));
  CHECK(near3(cam.forward(), {0, 0, -1}));
  CHECK(cam.fov_y_degrees == doctest::Approx(45.0f));
  CHECK(cam.near == doctest::Approx(0.05f));
  CHECK(cam.far == doctest::Approx(50.0f));

  REQUIRE(s.lights.size() == 1);
  const auto* spot = std::get_if<sc::SpotLight>(&s.lights[0]);
  REQUIRE(spot != nullptr);
  CHECK(spot->name == "spot");
  CHECK(near3(spot->position, {1, 0, 2}));  // lamp: T(1,0,0) S(2) T(0,0,1)
  CHECK(near3(spot->direction, {0, 0, -1}));
  CHECK(near3(spot->color, {1, 0.5f, 0.25f}));
  CHECK(spot->intensity == doctest::Approx(10.0f));
  CHECK(spot->range == doctest::Approx(20.0f));
  CHECK(spot->inner_cone_degrees == doctest::Approx(0.2 * 180.0 / 3.14159265358979));
  CHECK(spot->outer_cone_degrees == doctest::Approx(0.5 * 180.0 / 3.14159265358979));
}

}  // namespace

TEST_CASE("glTF: hierarchy, camera, KHR light and material from an embedded buffer") {
  TempDir dir;
  write_file(dir / "scene.gltf", gltf_json());
  auto s = sc::load_gltf(dir / "scene.gltf");
  REQUIRE_MESSAGE(s.has_value(), s.error().what());
  check_quad_scene(*s);
  CHECK(s->warnings.empty());
}

TEST_CASE("glTF: the same scene as a binary .glb") {
  TempDir dir;
  write_file(dir / "scene.glb", glb_bytes());
  auto s = sc::load_gltf(dir / "scene.glb");
  REQUIRE_MESSAGE(s.has_value(), s.error().what());
  check_quad_scene(*s);
}

TEST_CASE("glTF: load_mesh merges every instance in world space; load_scene builds a Scene") {
  TempDir dir;
  write_file(dir / "scene.gltf", gltf_json());
  auto mesh = sc::load_mesh(dir / "scene.gltf");
  REQUIRE_MESSAGE(mesh.has_value(), mesh.error().what());
  CHECK(mesh->vertex_count() == 8);
  CHECK(mesh->triangle_count() == 4);
  CHECK(std::any_of(mesh->positions.begin(), mesh->positions.end(), [](vec3 p) { return near3(p, {3, 4, 0}); }));
  CHECK(near3(mesh->bounds.max, {3, 4, 0}, 1e-4f));

  auto scene = sc::load_scene(dir / "scene.gltf");
  REQUIRE_MESSAGE(scene.has_value(), scene.error().what());
  CHECK(scene->objects.size() == 2);
  CHECK(near3(scene->camera.position, {0, 0, 5}));  // the file's camera
  CHECK(scene->lights.size() == 1);                   // its own light: no default added
  CHECK(scene->uses(sc::standard_material));
  CHECK_FALSE(scene->uses("shell_fur"));
}

TEST_CASE("glTF: a missing texture file is a warning naming the material and the path") {
  TempDir dir;
  GltfOptions o;
  o.texture_uri = "textures/missing%20file.png";
  write_file(dir / "textured.gltf", gltf_json(o));
  auto s = sc::load_gltf(dir / "textured.gltf");
  REQUIRE_MESSAGE(s.has_value(), s.error().what());
  REQUIRE(s->warnings.size() == 1);
  CHECK(contains(s->warnings[0], "'red'"));
  CHECK(contains(s->warnings[0], "missing file.png"));  // percent-decoded
  CHECK(s->materials[0].standard.base_color_texture.empty());

  // Once the file is there, the material points at it.
  std::filesystem::create_directories(dir / "textures");
  write_file(dir / "textures" / "missing file.png", "not decoded here");
  auto again = sc::load_gltf(dir / "textured.gltf");
  REQUIRE(again.has_value());
  CHECK(again->warnings.empty());
  CHECK(again->materials[0].standard.base_color_texture.path == dir / "textures" / "missing file.png");
  CHECK(again->materials[0].standard.base_color_texture.mime_type == "image/png");
}

namespace {
// support.h's glTF with every texture slot of material "red" filled from image 0 (a data
// URI), changed by `edit` before it is written.
template <class Edit>
std::string full_material_gltf(Edit edit) {
  nlohmann::json doc = nlohmann::json::parse(gltf_json());
  doc["images"] = nlohmann::json::array({{{"uri", "data:image/png;base64,iVBORw0KGgo="}, {"name", "tiny"}}});
  doc["samplers"] = nlohmann::json::array({{{"wrapS", 33071}, {"wrapT", 33648}, {"magFilter", 9728}, {"minFilter", 9986}}});
  doc["textures"] = nlohmann::json::array({{{"source", 0}}, {{"source", 0}, {"sampler", 0}}});
  auto& m = doc["materials"][0];
  m["pbrMetallicRoughness"]["baseColorTexture"] = {{"index", 0}};
  m["pbrMetallicRoughness"]["metallicRoughnessTexture"] = {{"index", 1}, {"texCoord", 1}};
  m["normalTexture"] = {{"index", 0}, {"scale", 0.5}};
  m["occlusionTexture"] = {{"index", 1}, {"strength", 0.25}};
  m["emissiveTexture"] = {{"index", 0}};
  m["extensions"] = {{"KHR_materials_emissive_strength", {{"emissiveStrength", 4.0}}}};
  // TEXCOORD_1: the quad's UVs again (accessor 2).
  doc["meshes"][0]["primitives"][0]["attributes"]["TEXCOORD_1"] = 2;
  edit(doc);
  return doc.dump();
}
}  // namespace

TEST_CASE("glTF: the metallic-roughness material's five textures, their samplers, UV sets and factors") {
  TempDir dir;
  write_file(dir / "full.gltf", full_material_gltf([](nlohmann::json&) {}));
  auto s = sc::load_gltf(dir / "full.gltf");
  REQUIRE_MESSAGE(s.has_value(), s.error().what());
  const sc::StandardMaterial& m = s->materials[0].standard;
  for (const sc::Texture* t : {&m.base_color_texture, &m.metallic_roughness_texture, &m.normal_texture,
                               &m.occlusion_texture, &m.emissive_texture}) {
    CHECK_FALSE(t->empty());
    CHECK(t->path.empty());  // embedded: the bytes travel, decoded by the renderer
    CHECK(t->encoded.size() == 8);  // the PNG signature
    CHECK(contains(t->label, "image 0 'tiny'"));
  }
  CHECK(m.base_color_texture.texcoord == 0);
  CHECK(m.metallic_roughness_texture.texcoord == 1);
  CHECK(m.base_color_texture.sampler == sc::TextureSampler{});  // no sampler: repeat, linear
  const sc::TextureSampler clamped{sc::TextureWrap::ClampToEdge, sc::TextureWrap::MirroredRepeat, sc::TextureFilter::Nearest,
                                   sc::TextureFilter::Nearest};
  CHECK(m.metallic_roughness_texture.sampler == clamped);
  CHECK(m.occlusion_texture.sampler == clamped);
  CHECK(m.normal_scale == doctest::Approx(0.5f));
  CHECK(m.occlusion_strength == doctest::Approx(0.25f));
  CHECK(near3(m.emissive, {2.0f, 0, 0}));  // 0.5 times KHR_materials_emissive_strength 4
  REQUIRE(s->meshes[0].uvs1.size() == s->meshes[0].uvs.size());
  CHECK(s->meshes[0].uvs1 == s->meshes[0].uvs);
}

TEST_CASE("glTF: bad samplers, texture coordinate sets and TEXCOORD_1 are named") {
  TempDir dir;
  const auto refused = [&](const std::string& text, std::string_view why) {
    write_file(dir / "bad.gltf", text);
    auto s = sc::load_gltf(dir / "bad.gltf");
    REQUIRE_FALSE(s.has_value());
    CHECK(s.error().kind == ErrorKind::Parse);
    CHECK_MESSAGE(contains(s.error().message, why), s.error().message);
    CHECK(contains(s.error().message, "bad.gltf"));
  };
  SUBCASE("a sampler index past the samplers") {
    refused(full_material_gltf([](nlohmann::json& d) { d["textures"][1]["sampler"] = 7; }),
            "material 'red' metallicRoughnessTexture: texture 1 uses sampler 7, but there are 1 samplers");
  }
  SUBCASE("an unknown wrap mode") {
    refused(full_material_gltf([](nlohmann::json& d) { d["samplers"][0]["wrapT"] = 1234; }), "sampler 0 has an unknown wrapT 1234");
  }
  SUBCASE("an unknown filter") {
    refused(full_material_gltf([](nlohmann::json& d) { d["samplers"][0]["magFilter"] = 5; }), "sampler 0 has an unknown magFilter 5");
  }
  SUBCASE("a negative texCoord") {
    refused(full_material_gltf([](nlohmann::json& d) { d["materials"][0]["emissiveTexture"]["texCoord"] = -1; }),
            "material 'red' emissiveTexture: texCoord -1 is negative");
  }
  SUBCASE("TEXCOORD_1 of the wrong length") {
    refused(full_material_gltf([](nlohmann::json& d) {
              d["accessors"].push_back({{"bufferView", 0}, {"byteOffset", 96}, {"componentType", 5126}, {"count", 3}, {"type", "VEC2"}});
              d["meshes"][0]["primitives"][0]["attributes"]["TEXCOORD_1"] = 4;
            }),
            "TEXCOORD_1: accessor 4 has 3 elements, POSITION has 4");
  }
  SUBCASE("a texCoord beyond set 1 is a warning and reads set 0") {
    write_file(dir / "set2.gltf", full_material_gltf([](nlohmann::json& d) { d["materials"][0]["normalTexture"]["texCoord"] = 2; }));
    auto s = sc::load_gltf(dir / "set2.gltf");
    REQUIRE_MESSAGE(s.has_value(), s.error().what());
    CHECK(s->materials[0].standard.normal_texture.texcoord == 0);
    CHECK(std::any_of(s->warnings.begin(), s->warnings.end(),
                      [](const std::string& w) { return contains(w, "normalTexture: texCoord 2"); }));
  }
}

TEST_CASE("glTF: the shipped sample examples/gltf/spot.glb loads with its material, UV sets, camera and lights") {
  const auto root = source_dir();
  if (!root) {
    MESSAGE("WEFT_SOURCE_DIR not set: skipped");
    return;
  }
  auto s = sc::load_gltf(*root / "examples/gltf/spot.glb");
  REQUIRE_MESSAGE(s.has_value(), s.error().what());
  CHECK(s->warnings.empty());
  REQUIRE(s->materials.size() == 1);
  const sc::StandardMaterial& m = s->materials[0].standard;
  for (const sc::Texture* t : {&m.base_color_texture, &m.metallic_roughness_texture, &m.normal_texture, &m.occlusion_texture}) {
    CHECK_FALSE(t->empty());
    CHECK(t->mime_type == "image/png");
  }
  CHECK(m.emissive_texture.empty());
  CHECK(m.occlusion_texture.texcoord == 1);
  REQUIRE(s->meshes.size() == 1);
  CHECK(s->meshes[0].uvs1.size() == s->meshes[0].uvs.size());
  CHECK(s->cameras.size() == 1);
  REQUIRE(s->lights.size() == 2);
  CHECK(std::holds_alternative<sc::PointLight>(s->lights[0]));
  REQUIRE(std::holds_alternative<sc::SpotLight>(s->lights[1]));
  CHECK(std::get<sc::SpotLight>(s->lights[1]).outer_cone_degrees == doctest::Approx(30.0f).epsilon(0.001));
}

TEST_CASE("glTF: the third-party sample examples/gltf/water_bottle (CC0) loads with its three embedded maps") {
  const auto root = source_dir();
  REQUIRE_MESSAGE(root, "WEFT_SOURCE_DIR must name the source tree (ctest sets it)");
  auto s = sc::load_gltf(*root / "examples/gltf/water_bottle/WaterBottle.glb");
  REQUIRE_MESSAGE(s.has_value(), s.error().what());
  CHECK(s->warnings.empty());
  REQUIRE(s->materials.size() == 1);
  REQUIRE(s->meshes.size() == 1);
  CHECK(s->meshes[0].positions.size() == 4857);
  CHECK(s->meshes[0].uvs.size() == 4857);
  const sc::StandardMaterial& m = s->materials[0].standard;
  // Occlusion and metallic-roughness share one packed image; each map decodes at 2048^2
  // (the packed one is a palette PNG, which the decoder expands).
  for (const sc::Texture* t : {&m.base_color_texture, &m.metallic_roughness_texture, &m.normal_texture, &m.occlusion_texture}) {
    REQUIRE_FALSE(t->empty());
    CHECK(t->mime_type == "image/png");
    auto img = weft::image::decode_ldr(t->encoded, t->label);
    REQUIRE_MESSAGE(img, (img ? "" : img.error().what()));
    CHECK(img->width == 2048);
    CHECK(img->height == 2048);
  }
  CHECK(m.metallic_roughness_texture.encoded == m.occlusion_texture.encoded);
}

TEST_CASE("glTF: errors name the file and what is wrong") {
  TempDir dir;
  SUBCASE("truncated JSON") {
    const std::string text = gltf_json();
    write_file(dir / "truncated.gltf", text.substr(0, text.size() / 2));
    auto s = sc::load_gltf(dir / "truncated.gltf");
    REQUIRE_FALSE(s.has_value());
    CHECK(s.error().kind == ErrorKind::Parse);
    CHECK(contains(s.error().message, "truncated.gltf"));
  }
  SUBCASE("truncated GLB") {
    auto bytes = glb_bytes();
    bytes.resize(bytes.size() - 20);
    write_file(dir / "truncated.glb", bytes);
    auto s = sc::load_gltf(dir / "truncated.glb");
    REQUIRE_FALSE(s.has_value());
    CHECK(s.error().kind == ErrorKind::Parse);
    CHECK(contains(s.error().message, "truncated.glb"));
  }
  SUBCASE("a bufferView beyond its buffer") {
    GltfOptions o;
    o.view0_length = 400;
    write_file(dir / "view.gltf", gltf_json(o));
    auto s = sc::load_gltf(dir / "view.gltf");
    REQUIRE_FALSE(s.has_value());
    CHECK(s.error().kind == ErrorKind::Parse);
    CHECK(contains(s.error().message, "view.gltf"));
    CHECK(contains(s.error().message, "bufferView 0"));
  }
  SUBCASE("an accessor beyond its bufferView") {
    GltfOptions o;
    o.view0_length = 100;  // inside the buffer, but the UVs (96..127) no longer fit
    write_file(dir / "accessor.gltf", gltf_json(o));
    auto s = sc::load_gltf(dir / "accessor.gltf");
    REQUIRE_FALSE(s.has_value());
    CHECK(contains(s.error().message, "accessor 2"));
    CHECK(contains(s.error().message, "TEXCOORD_0"));
  }
  SUBCASE("a NaN position names the vertex") {
    GltfOptions o;
    o.nan_at_vertex = 2;
    write_file(dir / "nan.gltf", gltf_json(o));
    auto s = sc::load_gltf(dir / "nan.gltf");
    REQUIRE_FALSE(s.has_value());
    CHECK(contains(s.error().message, "nan.gltf"));
    CHECK(contains(s.error().message, "vertex 2"));
  }
  SUBCASE("a node hierarchy with a cycle") {
    std::string text = gltf_json();
    const std::string child = R"("name": "child", "translation": [0, 1, 0], "mesh": 0)";
    text.replace(text.find(child), child.size(), child + R"(, "children": [0])");
    write_file(dir / "cycle.gltf", text);
    auto s = sc::load_gltf(dir / "cycle.gltf");
    REQUIRE_FALSE(s.has_value());
    CHECK(contains(s.error().message, "cycle"));
  }
  SUBCASE("a required extension weft does not read") {
    std::string text = gltf_json();
    text.replace(text.find(R"("extensionsUsed")"), 0, R"("extensionsRequired": ["KHR_draco_mesh_compression"], )");
    write_file(dir / "draco.gltf", text);
    auto s = sc::load_gltf(dir / "draco.gltf");
    REQUIRE_FALSE(s.has_value());
    CHECK(s.error().kind == ErrorKind::Unsupported);
    CHECK(contains(s.error().message, "KHR_draco_mesh_compression"));
  }
  SUBCASE("not a file") {
    auto s = sc::load_gltf(dir / "absent.gltf");
    REQUIRE_FALSE(s.has_value());
    CHECK(s.error().kind == ErrorKind::NotFound);
  }
}

TEST_CASE("issue 33: a glTF whose buffer is a FIFO, or a mesh file that is one, is an error saying so, never a wait") {
  TempDir dir;
  ::alarm(30);  // a reader waiting on a FIFO ends the test run (SIGALRM) instead of hanging it
  REQUIRE(::mkfifo((dir / "buffer.bin").c_str(), 0600) == 0);
  nlohmann::json doc = nlohmann::json::parse(gltf_json());
  doc["buffers"][0]["uri"] = "buffer.bin";
  write_file(dir / "fifo_buffer.gltf", doc.dump());
  auto s = sc::load_gltf(dir / "fifo_buffer.gltf");
  REQUIRE_FALSE(s.has_value());
  CHECK_MESSAGE(contains(s.error().message, "buffer.bin' is a FIFO, not a regular file"), s.error().message);
  for (const char* name : {"m.obj", "m.ply", "m.off", "m.stl", "m.glb"}) {
    REQUIRE(::mkfifo((dir / name).c_str(), 0600) == 0);
    auto mesh = sc::load_mesh(dir / name);
    REQUIRE_FALSE(mesh.has_value());
    CHECK(mesh.error().kind == ErrorKind::Io);
    CHECK_MESSAGE(mesh.error().message == "mesh file '" + (dir / name).string() + "' is a FIFO, not a regular file",
                  mesh.error().message);
  }
  ::alarm(0);
}
