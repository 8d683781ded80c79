// Helpers for the weft.scene suites: temporary folders, files, base64, a small glTF builder
// and the optional shared data folder. Plain C++ (no imports), included before `import`.
#pragma once

#include <atomic>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <optional>
#include <random>
#include <string>
#include <string_view>
#include <vector>

namespace scene_test {

namespace fs = std::filesystem;

// A fresh folder under the system temp dir, removed with everything in it.
struct TempDir {
  fs::path path;
  TempDir() {
    static std::atomic<int> counter{0};
    std::random_device rd;
    path = fs::temp_directory_path() / ("weft-test-scene-" + std::to_string(rd()) + "-" + std::to_string(counter++));
    fs::create_directories(path);
  }
  ~TempDir() {
    std::error_code ec;
    fs::remove_all(path, ec);
  }
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;
  fs::path operator/(const std::string& name) const { return path / name; }
};

inline void write_file(const fs::path& p, std::string_view text) {
  std::ofstream out(p, std::ios::binary | std::ios::trunc);
  out.write(text.data(), static_cast<std::streamsize>(text.size()));
}

inline void write_file(const fs::path& p, const std::vector<std::uint8_t>& bytes) {
  std::ofstream out(p, std::ios::binary | std::ios::trunc);
  out.write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
}

inline std::string read_text(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

inline bool contains(std::string_view text, std::string_view part) { return text.find(part) != std::string_view::npos; }

inline std::string base64(const std::vector<std::uint8_t>& data) {
  static constexpr char table[] = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  std::size_t i = 0;
  for (; i + 2 < data.size(); i += 3) {
    const std::uint32_t v = (std::uint32_t(data[i]) << 16) | (std::uint32_t(data[i + 1]) << 8) | data[i + 2];
    out += table[(v >> 18) & 63];
    out += table[(v >> 12) & 63];
    out += table[(v >> 6) & 63];
    out += table[v & 63];
  }
  if (i + 1 == data.size()) {
    const std::uint32_t v = std::uint32_t(data[i]) << 16;
    out += table[(v >> 18) & 63];
    out += table[(v >> 12) & 63];
    out += "==";
  } else if (i + 2 == data.size()) {
    const std::uint32_t v = (std::uint32_t(data[i]) << 16) | (std::uint32_t(data[i + 1]) << 8);
    out += table[(v >> 18) & 63];
    out += table[(v >> 12) & 63];
    out += table[(v >> 6) & 63];
    out += '=';
  }
  return out;
}

template <class T>
void append(std::vector<std::uint8_t>& bytes, const T& value) {
  const auto* p = reinterpret_cast<const std::uint8_t*>(&value);
  bytes.insert(bytes.end(), p, p + sizeof(T));
}

// The buffer of the test glTF: a unit quad in the XY plane (positions, normals +Z, UVs,
// u16 indices). Positions 0..47, normals 48..95, UVs 96..127, indices 128..139.
inline std::vector<std::uint8_t> quad_buffer(float nan_at_vertex = -1) {
  std::vector<std::uint8_t> b;
  const float positions[4][3] = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}};
  for (int v = 0; v < 4; ++v) {
    for (int c = 0; c < 3; ++c) {
      append(b, (v == int(nan_at_vertex) && c == 1) ? std::numeric_limits<float>::quiet_NaN() : positions[v][c]);
    }
  }
  for (int v = 0; v < 4; ++v) {
    append(b, 0.0f);
    append(b, 0.0f);
    append(b, 1.0f);
  }
  const float uvs[4][2] = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
  for (const auto& uv : uvs) {
    append(b, uv[0]);
    append(b, uv[1]);
  }
  for (std::uint16_t i : {0, 1, 2, 0, 2, 3}) append(b, i);
  return b;
}

struct GltfOptions {
  std::size_t view0_length = 128;   // bufferView 0's byteLength (128 is right)
  std::string texture_uri;          // a baseColorTexture image uri for material "red"
  int nan_at_vertex = -1;           // a NaN y coordinate at this vertex
  bool embed_buffer = true;         // false: no uri (for GLB)
};

// A glTF with a node hierarchy (parent: T(1,0,0) S(2) -> child T(0,1,0) with the quad, and
// lamp T(0,0,1) with a spot light), a root "turned" node (the quad turned 90 degrees about
// +Y), and a camera node at (0,0,5).
inline std::string gltf_json(const GltfOptions& o = {}) {
  const std::vector<std::uint8_t> buffer = quad_buffer(float(o.nan_at_vertex));
  std::string images;
  std::string texture_ref;
  if (!o.texture_uri.empty()) {
    images = R"("images": [{"uri": ")" + o.texture_uri + R"("}], "textures": [{"source": 0}],)";
    texture_ref = R"(, "baseColorTexture": {"index": 0})";
  }
  const std::string uri = o.embed_buffer ? R"(, "uri": "data:application/octet-stream;base64,)" + base64(buffer) + "\"" : "";
  return R"({
  "asset": {"version": "2.0"},
  "scene": 0,
  "scenes": [{"nodes": [0, 3, 4]}],
  "nodes": [
    {"name": "parent", "translation": [1, 0, 0], "scale": [2, 2, 2], "children": [1, 2]},
    {"name": "child", "translation": [0, 1, 0], "mesh": 0},
    {"name": "lamp", "translation": [0, 0, 1], "extensions": {"KHR_lights_punctual": {"light": 0}}},
    {"name": "turned", "rotation": [0, 0.70710678, 0, 0.70710678], "mesh": 0},
    {"name": "cam", "translation": [0, 0, 5], "camera": 0}
  ],
  "meshes": [{"name": "quad", "primitives": [{"attributes": {"POSITION": 0, "NORMAL": 1, "TEXCOORD_0": 2}, "indices": 3, "material": 0}]}],
  "materials": [{"name": "red", "pbrMetallicRoughness": {"baseColorFactor": [1, 0, 0, 1], "metallicFactor": 0.25, "roughnessFactor": 0.75)" +
         texture_ref + R"(}, "emissiveFactor": [0.5, 0, 0]}],
  )" + images + R"(
  "cameras": [{"type": "perspective", "perspective": {"yfov": 0.78539816, "znear": 0.05, "zfar": 50}}],
  "extensionsUsed": ["KHR_lights_punctual"],
  "extensions": {"KHR_lights_punctual": {"lights": [
    {"type": "spot", "name": "spot", "color": [1, 0.5, 0.25], "intensity": 10, "range": 20, "spot": {"innerConeAngle": 0.2, "outerConeAngle": 0.5}}]}},
  "buffers": [{"byteLength": 140)" + uri + R"(}],
  "bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": )" + std::to_string(o.view0_length) + R"(},
                  {"buffer": 0, "byteOffset": 128, "byteLength": 12}],
  "accessors": [
    {"bufferView": 0, "byteOffset": 0, "componentType": 5126, "count": 4, "type": "VEC3", "min": [0, 0, 0], "max": [1, 1, 0]},
    {"bufferView": 0, "byteOffset": 48, "componentType": 5126, "count": 4, "type": "VEC3"},
    {"bufferView": 0, "byteOffset": 96, "componentType": 5126, "count": 4, "type": "VEC2"},
    {"bufferView": 1, "byteOffset": 0, "componentType": 5123, "count": 6, "type": "SCALAR"}
  ]
})";
}

// The same scene as a binary .glb: JSON chunk and BIN chunk.
inline std::vector<std::uint8_t> glb_bytes() {
  GltfOptions o;
  o.embed_buffer = false;
  std::string json = gltf_json(o);
  while (json.size() % 4 != 0) json.push_back(' ');
  std::vector<std::uint8_t> bin = quad_buffer();
  while (bin.size() % 4 != 0) bin.push_back(0);
  std::vector<std::uint8_t> out;
  append(out, std::uint32_t{0x46546C67});  // "glTF"
  append(out, std::uint32_t{2});
  append(out, std::uint32_t(12 + 8 + json.size() + 8 + bin.size()));
  append(out, std::uint32_t(json.size()));
  append(out, std::uint32_t{0x4E4F534A});  // "JSON"
  out.insert(out.end(), json.begin(), json.end());
  append(out, std::uint32_t(bin.size()));
  append(out, std::uint32_t{0x004E4942});  // "BIN\0"
  out.insert(out.end(), bin.begin(), bin.end());
  return out;
}

// ../shared/data when the tests run with WEFT_SHARED_DATA pointing at it.
inline std::optional<fs::path> shared_data() {
  const char* dir = std::getenv("WEFT_SHARED_DATA");
  if (dir == nullptr || !fs::is_directory(dir)) return std::nullopt;
  return fs::path(dir);
}

inline std::optional<fs::path> source_dir() {
  const char* dir = std::getenv("WEFT_SOURCE_DIR");
  if (dir == nullptr || !fs::is_directory(dir)) return std::nullopt;
  return fs::path(dir);
}

}  // namespace scene_test
