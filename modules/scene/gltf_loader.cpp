// The one translation unit that compiles tinygltf's implementation for weft.scene; see
// gltf_loader.h.
#define TINYGLTF_IMPLEMENTATION
#include "gltf_loader.h"

#include <cstring>
#include <exception>
#include <new>
#include <system_error>
import weft.core;

namespace weft::scene::gltf_detail {
namespace {

// Keeps an embedded image's encoded bytes (PNG/JPEG) instead of decoding them.
bool keep_encoded(tinygltf::Image* image, const int, std::string*, std::string*, int, int,
                  const unsigned char* bytes, int size, void*) {
  if (bytes == nullptr || size <= 0) return false;
  image->image.assign(bytes, bytes + size);
  image->as_is = true;
  return true;
}

// tinygltf's file access, confined to the asset's folder: a buffer URI such as
// "../../etc/passwd" is refused with a reason instead of read. tinygltf also looks for a
// buffer in the current directory; that search finds nothing here.
struct Confined {
  std::string base_dir;  // absolute, as parse_model's caller passes it
};

bool from_base(const std::string& candidate, const Confined& c) { return candidate.starts_with(c.base_dir); }

// The candidate resolved lexically (as URIs are: "sub/../a.bin" is "a.bin"), or nothing when
// it is tinygltf's search of the current directory or leaves the folder.
std::optional<std::filesystem::path> resolve(const std::string& candidate, const Confined& c) {
  if (!from_base(candidate, c)) return std::nullopt;
  return resolve_inside(c.base_dir, candidate.substr(c.base_dir.size()));
}

bool file_exists(const std::string& candidate, void* user) {
  const auto& c = *static_cast<const Confined*>(user);
  if (!from_base(candidate, c)) return false;
  const auto inside = resolve(candidate, c);
  if (!inside) return true;  // read_whole_file says why it is not read
  std::error_code ec;  // a FIFO or a folder "exists": read_whole_file says what it is
  return std::filesystem::exists(*inside, ec);
}

std::string expand_file_path(const std::string& path, void*) { return path; }

bool read_whole_file(std::vector<unsigned char>* out, std::string* err, const std::string& candidate, void* user) {
  const auto& c = *static_cast<const Confined*>(user);
  const auto inside = resolve(candidate, c);
  if (!inside) {
    if (err) *err += "the URI leads outside the glTF file's folder (weft reads buffers only from that folder)";
    return false;
  }
  auto bytes = weft::read_input_file(*inside, "glTF resource");
  if (!bytes) {
    if (err) *err += bytes.error().message;
    return false;
  }
  *out = std::move(*bytes);
  return true;
}

bool write_whole_file(std::string* err, const std::string&, const std::vector<unsigned char>&, void*) {
  if (err) *err += "weft does not write glTF files";
  return false;
}

bool is_glb(const std::vector<unsigned char>& bytes) {
  return bytes.size() >= 4 && std::memcmp(bytes.data(), "glTF", 4) == 0;
}

}  // namespace

std::optional<std::filesystem::path> resolve_inside(const std::filesystem::path& base_dir, const std::string& relative) {
  const std::filesystem::path rel(relative);
  if (relative.empty() || rel.has_root_path()) return std::nullopt;
  const std::filesystem::path resolved = (base_dir / rel).lexically_normal();
  const std::filesystem::path inside = resolved.lexically_relative(base_dir.lexically_normal());
  if (inside.empty() || *inside.begin() == "..") return std::nullopt;
  return resolved;
}

bool parse_model(const std::vector<unsigned char>& bytes, const std::string& base_dir, tinygltf::Model& model,
                 std::string& error, std::string& warning) {
  try {
    if (bytes.size() > 0xffffffffu) {
      error = "file is larger than 4 GiB";
      return false;
    }
    tinygltf::TinyGLTF loader;
    loader.SetImageLoader(&keep_encoded, nullptr);
    Confined confined{base_dir.ends_with('/') ? base_dir : base_dir + "/"};
    loader.SetFsCallbacks({&file_exists, &expand_file_path, &read_whole_file, &write_whole_file, &confined});
    const auto length = static_cast<unsigned int>(bytes.size());
    if (is_glb(bytes)) {
      return loader.LoadBinaryFromMemory(&model, &error, &warning, bytes.data(), length, base_dir);
    }
    // tinygltf reads the JSON text with an explicit length; it needs no terminating zero.
    return loader.LoadASCIIFromString(&model, &error, &warning, reinterpret_cast<const char*>(bytes.data()), length,
                                      base_dir);
  } catch (const std::bad_alloc&) {
    error = "out of memory while parsing";
  } catch (const std::exception& e) {
    error = e.what();
  } catch (...) {
    error = "unknown exception while parsing";
  }
  return false;
}

}  // namespace weft::scene::gltf_detail
