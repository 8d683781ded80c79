// Internal to weft.scene: tinygltf's declarations with the options weft compiles it with,
// and the one call into its implementation (gltf_loader.cpp, an ordinary translation unit,
// so tinygltf and its JSON parser are compiled once and their exceptions stop there).
// Images are not decoded here: weft.image decodes textures later, so tinygltf gets no
// stb_image (weft.image compiles its own) and keeps embedded images as their encoded bytes.
#pragma once

#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#define TINYGLTF_NO_STB_IMAGE
#define TINYGLTF_NO_STB_IMAGE_WRITE
#define TINYGLTF_NO_EXTERNAL_IMAGE
#pragma clang diagnostic push
#pragma clang diagnostic ignored "-Weverything"
#include <tiny_gltf.h>
#pragma clang diagnostic pop

namespace weft::scene::gltf_detail {

// Parses a .gltf (JSON) or .glb (binary) held in `bytes`; external buffers are read
// relative to `base_dir` (absolute), and only from inside it. Never throws: any failure
// returns false with `error` set.
bool parse_model(const std::vector<unsigned char>& bytes, const std::string& base_dir, tinygltf::Model& model,
                 std::string& error, std::string& warning);

// `relative` (a decoded URI) joined to `base_dir`, or nothing when it is absolute, empty or
// climbs out of `base_dir` with "..": glTF files name their resources inside their folder.
std::optional<std::filesystem::path> resolve_inside(const std::filesystem::path& base_dir, const std::string& relative);

}  // namespace weft::scene::gltf_detail
