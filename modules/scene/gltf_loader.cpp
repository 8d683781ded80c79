// The one translation unit that compiles tinygltf's implementation for weft.scene; see
// gltf_loader.h.
#define TINYGLTF_IMPLEMENTATION
#include "gltf_loader.h"

#include <cstring>
#include <exception>
#include <new>

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

bool is_glb(const std::vector<unsigned char>& bytes) {
  return bytes.size() >= 4 && std::memcmp(bytes.data(), "glTF", 4) == 0;
}

}  // namespace

bool parse_model(const std::vector<unsigned char>& bytes, const std::string& base_dir, tinygltf::Model& model,
                 std::string& error, std::string& warning) {
  try {
    if (bytes.size() > 0xffffffffu) {
      error = "file is larger than 4 GiB";
      return false;
    }
    tinygltf::TinyGLTF loader;
    loader.SetImageLoader(&keep_encoded, nullptr);
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
