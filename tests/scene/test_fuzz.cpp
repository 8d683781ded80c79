// Fuzz-style robustness: hundreds of corrupted and truncated versions of a valid scene
// file, OBJ, PLY (ASCII and binary), OFF, STL, glTF and GLB (byte flips, truncation,
// fixed seeds). Each must end cleanly: a value, or an Error with a message; never a crash,
// never an exception.
#include <doctest/doctest.h>

#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <filesystem>
#include <functional>
#include <random>
#include <string>
#include <vector>

#include "support.h"

import weft.core;
import weft.scene;

using namespace scene_test;
namespace sc = weft::scene;

namespace {

using Bytes = std::vector<std::uint8_t>;

Bytes bytes_of(std::string_view text) { return Bytes(text.begin(), text.end()); }

// Variant i of `valid`: byte flips, a truncation, or both, all from `rng`.
Bytes mutate(const Bytes& valid, int i, std::mt19937& rng) {
  Bytes out = valid;
  const auto pick = [&](std::size_t n) { return std::uniform_int_distribution<std::size_t>(0, n - 1)(rng); };
  const int kind = i % 4;
  if (kind == 0 || kind == 2) {
    const int flips = 1 + int(pick(4));
    for (int f = 0; f < flips && !out.empty(); ++f) out[pick(out.size())] = static_cast<std::uint8_t>(pick(256));
  }
  if (kind == 1 || kind == 2) out.resize(pick(out.size() + 1));
  if (kind == 3 && !out.empty()) {  // a digit or punctuation swapped for another one: subtler damage
    static constexpr char alphabet[] = "0123456789-.,:[]{}\" e/\n";
    for (int f = 0; f < 2; ++f) out[pick(out.size())] = static_cast<std::uint8_t>(alphabet[pick(sizeof alphabet - 1)]);
  }
  return out;
}

// WEFT_FUZZ_SCALE=N runs N times as many variants (for a long local or nightly run).
int scaled(int count) {
  const char* scale = std::getenv("WEFT_FUZZ_SCALE");
  const int n = scale != nullptr ? std::atoi(scale) : 1;
  return count * (n > 0 ? n : 1);
}

struct Outcome {
  int ok = 0;
  int errors = 0;
};

// Runs `load` on `count` variants; every call must return, and every error must say something.
template <class Load>
Outcome fuzz(const Bytes& valid, int count, std::uint32_t seed, Load load) {
  count = scaled(count);
  std::mt19937 rng(seed);
  Outcome outcome;
  for (int i = 0; i < count; ++i) {
    const Bytes variant = mutate(valid, i, rng);
    bool returned = false;
    try {
      const auto result = load(variant);
      returned = true;
      if (result.has_value()) {
        ++outcome.ok;
      } else {
        ++outcome.errors;
        CHECK_FALSE(result.error().message.empty());
      }
    } catch (const std::exception& e) {
      FAIL_CHECK("variant " << i << " threw: " << e.what());
    } catch (...) {
      FAIL_CHECK("variant " << i << " threw something");
    }
    CHECK(returned);
  }
  CHECK(outcome.errors > 0);  // the corruption was noticed at least sometimes
  return outcome;
}

template <class Load>
Outcome fuzz_file(TempDir& dir, const std::string& name, const Bytes& valid, int count, std::uint32_t seed, Load load) {
  // The valid file loads: the variants start from something good.
  write_file(dir / name, valid);
  auto good = load(dir / name);
  REQUIRE_MESSAGE(good.has_value(), good.error().what());
  return fuzz(valid, count, seed, [&](const Bytes& variant) {
    write_file(dir / name, variant);
    return load(dir / name);
  });
}

const char* obj_text =
    "# a cube with UVs and normals, quads\n"
    "v -1 -1 -1\nv 1 -1 -1\nv 1 1 -1\nv -1 1 -1\nv -1 -1 1\nv 1 -1 1\nv 1 1 1\nv -1 1 1\n"
    "vt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\n"
    "vn 0 0 -1\nvn 0 0 1\nvn 0 -1 0\nvn 0 1 0\nvn -1 0 0\nvn 1 0 0\n"
    "f 1/1/1 4/4/1 3/3/1 2/2/1\nf 5/1/2 6/2/2 7/3/2 8/4/2\nf 1/1/3 2/2/3 6/3/3 5/4/3\n"
    "f 4/1/4 8/2/4 7/3/4 3/4/4\nf 1/1/5 5/2/5 8/3/5 4/4/5\nf 2/1/6 3/2/6 7/3/6 6/4/6\n";

const char* ply_text =
    "ply\nformat ascii 1.0\ncomment a tetrahedron\nelement vertex 4\nproperty float x\nproperty float y\n"
    "property float z\nproperty float nx\nproperty float ny\nproperty float nz\nproperty float u\nproperty float v\n"
    "element face 4\nproperty list uchar int vertex_indices\nend_header\n"
    "0 0 0 -1 -1 -1 0 0\n1 0 0 1 0 0 1 0\n0 1 0 0 1 0 0 1\n0 0 1 0 0 1 1 1\n"
    "3 0 2 1\n3 0 1 3\n3 0 3 2\n3 1 2 3\n";

const char* off_text = "OFF\n8 6 12\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n0 0 1\n1 0 1\n1 1 1\n0 1 1\n"
                       "4 0 3 2 1\n4 4 5 6 7\n4 0 1 5 4\n4 2 3 7 6\n4 1 2 6 5\n4 0 4 7 3\n";

Bytes binary_ply() {
  const std::string header = "ply\nformat binary_little_endian 1.0\nelement vertex 4\nproperty float x\n"
                             "property float y\nproperty float z\nelement face 4\n"
                             "property list uchar int vertex_indices\nend_header\n";
  Bytes b = bytes_of(header);
  const float p[4][3] = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
  for (const auto& v : p) {
    for (float f : v) append(b, f);
  }
  const std::int32_t faces[4][3] = {{0, 2, 1}, {0, 1, 3}, {0, 3, 2}, {1, 2, 3}};
  for (const auto& f : faces) {
    append(b, std::uint8_t{3});
    for (std::int32_t i : f) append(b, i);
  }
  return b;
}

Bytes binary_stl() {
  Bytes b(80, 0);
  append(b, std::uint32_t{4});
  const float p[4][3] = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
  const int faces[4][3] = {{0, 2, 1}, {0, 1, 3}, {0, 3, 2}, {1, 2, 3}};
  for (const auto& f : faces) {
    for (int k = 0; k < 3; ++k) append(b, 0.0f);  // facet normal
    for (int i : f) {
      for (float c : p[i]) append(b, c);
    }
    append(b, std::uint16_t{0});
  }
  return b;
}

const char* scene_text = R"({
  "version": 1,
  "output": {"width": 320, "height": 240},
  "camera": {"position": [0, 1, 4], "target": [0, 0, 0], "fov": 45, "near": 0.1, "far": 20},
  "environment": {"color": [0.2, 0.2, 0.2], "intensity": 1},
  "lights": [{"type": "directional", "direction": [0, -1, -1], "intensity": 2},
             {"type": "spot", "position": [0, 3, 0], "inner_cone": 5, "outer_cone": 20}],
  "meshes": {"ball": {"primitive": "sphere", "radius": 0.5, "segments": 16},
             "cow": {"path": "cow.obj", "recompute_normals": true}},
  "materials": {"red": {"base_color": [0.9, 0.1, 0.1], "roughness": 0.3},
                "fur": {"type": "fur", "layers": 20}},
  "objects": [{"name": "a", "mesh": "ball", "material": "red", "transform": {"translation": [0, 0.5, 0], "scale": 2}},
              {"name": "b", "mesh": "cow", "material": "fur", "transform": {"rotation_degrees": [0, 45, 0]}}]
})";

}  // namespace

TEST_CASE("fuzz: corrupted scene files end in a SceneDesc or a Parse error") {
  TempDir dir;
  write_file(dir / "cow.obj", obj_text);
  const auto parse = [&](const Bytes& b) {
    return sc::parse_scene(std::string_view(reinterpret_cast<const char*>(b.data()), b.size()), dir.path, "fuzz.json");
  };
  REQUIRE(parse(bytes_of(scene_text)).has_value());
  const Outcome o = fuzz(bytes_of(scene_text), 400, 1234u, parse);
  CHECK(o.ok + o.errors == scaled(400));
}

TEST_CASE("fuzz: corrupted OBJ files") {
  TempDir dir;
  fuzz_file(dir, "fuzz.obj", bytes_of(obj_text), 300, 42u, [](const auto& p) { return sc::load_mesh(p); });
}

TEST_CASE("fuzz: corrupted PLY files, ASCII and binary") {
  TempDir dir;
  fuzz_file(dir, "ascii.ply", bytes_of(ply_text), 300, 7u, [](const auto& p) { return sc::load_mesh(p); });
  fuzz_file(dir, "binary.ply", binary_ply(), 200, 8u, [](const auto& p) { return sc::load_mesh(p); });
}

TEST_CASE("fuzz: corrupted OFF and binary STL files") {
  TempDir dir;
  fuzz_file(dir, "fuzz.off", bytes_of(off_text), 150, 9u, [](const auto& p) { return sc::load_mesh(p); });
  fuzz_file(dir, "fuzz.stl", binary_stl(), 150, 10u, [](const auto& p) { return sc::load_mesh(p); });
}

TEST_CASE("fuzz: corrupted glTF (JSON with an embedded buffer) and GLB files") {
  TempDir dir;
  fuzz_file(dir, "fuzz.gltf", bytes_of(gltf_json()), 300, 11u, [](const auto& p) { return sc::load_gltf(p); });
  fuzz_file(dir, "fuzz.glb", glb_bytes(), 200, 12u, [](const auto& p) { return sc::load_gltf(p); });
  fuzz_file(dir, "merged.gltf", bytes_of(gltf_json()), 100, 13u, [](const auto& p) { return sc::load_mesh(p); });
}
