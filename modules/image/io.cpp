// weft.image: reading and writing image files. Bytes move between disk and memory here
// (with the errors a user sees); the codecs in codecs.cpp only turn bytes into pixels and
// back. Saves go through weft::write_file_atomically, so failures leave no half file.
module;
#include <cerrno>
#include <climits>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <expected>
#include <filesystem>
#include <span>
#include <string>
#include <string_view>
#include <system_error>
#include <utility>
#include <vector>
#include "codecs.h"
module weft.image;
import weft.core;

namespace weft::image {
namespace fs = std::filesystem;

namespace {

std::string lower_extension(const fs::path& path) {
  std::string ext = path.extension().string();
  for (char& ch : ext) {
    if (ch >= 'A' && ch <= 'Z') ch = static_cast<char>(ch - 'A' + 'a');
  }
  return ext;
}

Result<std::vector<std::uint8_t>> read_bytes(const fs::path& path) {
  auto bytes = read_input_file(path, "image file");
  if (!bytes) return std::unexpected(bytes.error());
  if (bytes->empty()) return fail(ErrorKind::Parse, "cannot decode image '{}': the file is empty", path.string());
  return bytes;
}

Result<void> write_bytes(const fs::path& path, std::span<const std::uint8_t> bytes) {
  std::error_code ec;
  if (fs::is_directory(path, ec)) {
    return fail(ErrorKind::Io, "cannot write image '{}': it is a directory", path.string());
  }
  return write_file_atomically(path, {std::as_bytes(bytes)}, "image");
}

// stb and tinyexr take int sizes.
template <class Img>
Result<void> check_encodable(const fs::path& path, const Img& image, std::string_view format) {
  if (auto ok = validate(image); !ok) return with_context(weft::format("saving '{}'", path.string()), ok.error());
  if (image.sample_count() * sizeof(image.pixels[0]) > static_cast<std::size_t>(INT_MAX)) {
    return fail(ErrorKind::InvalidArgument, "cannot save '{}' as {}: {}x{}x{} is too large", path.string(), format,
                image.width, image.height, image.channels);
  }
  return {};
}

template <class T>
std::unexpected<Error> decode_error(const fs::path& path, const codec::Decoded<T>& decoded, std::string_view format) {
  return fail(decoded.unsupported ? ErrorKind::Unsupported : ErrorKind::Parse, "cannot decode {} '{}': {}", format,
              path.string(), decoded.error);
}

}  // namespace

Result<Image8> load_ldr(const fs::path& path) {
  auto bytes = read_bytes(path);
  if (!bytes) return std::unexpected(bytes.error());
  auto decoded = codec::decode_ldr(bytes->data(), bytes->size());
  if (!decoded.error.empty()) return decode_error(path, decoded, "image");
  return Image8{static_cast<std::uint32_t>(decoded.width), static_cast<std::uint32_t>(decoded.height),
                static_cast<std::uint32_t>(decoded.channels), std::move(decoded.pixels)};
}

Result<Image8> decode_ldr(std::span<const std::uint8_t> bytes, std::string_view label) {
  if (bytes.empty()) return fail(ErrorKind::Parse, "cannot decode image {}: no bytes", label);
  if (bytes.size() > static_cast<std::size_t>(INT_MAX)) {
    return fail(ErrorKind::InvalidArgument, "cannot decode image {}: {} bytes is too large", label, bytes.size());
  }
  auto decoded = codec::decode_ldr(bytes.data(), bytes.size());
  if (!decoded.error.empty()) {
    return fail(decoded.unsupported ? ErrorKind::Unsupported : ErrorKind::Parse, "cannot decode image {}: {}", label,
                decoded.error);
  }
  return Image8{static_cast<std::uint32_t>(decoded.width), static_cast<std::uint32_t>(decoded.height),
                static_cast<std::uint32_t>(decoded.channels), std::move(decoded.pixels)};
}

Result<Image8> load_png(const fs::path& path) {
  auto bytes = read_bytes(path);
  if (!bytes) return std::unexpected(bytes.error());
  if (!codec::is_png(bytes->data(), bytes->size())) {
    return fail(ErrorKind::Parse, "cannot decode PNG '{}': not a PNG file (bad signature)", path.string());
  }
  auto decoded = codec::decode_ldr(bytes->data(), bytes->size());
  if (!decoded.error.empty()) return decode_error(path, decoded, "PNG");
  return Image8{static_cast<std::uint32_t>(decoded.width), static_cast<std::uint32_t>(decoded.height),
                static_cast<std::uint32_t>(decoded.channels), std::move(decoded.pixels)};
}

Result<void> save_png(const fs::path& path, const Image8& image) {
  if (auto ok = check_encodable(path, image, "PNG"); !ok) return ok;
  auto encoded = codec::encode_png(static_cast<int>(image.width), static_cast<int>(image.height),
                                   static_cast<int>(image.channels), image.pixels.data());
  if (!encoded.error.empty()) return fail(ErrorKind::Internal, "saving '{}': {}", path.string(), encoded.error);
  return write_bytes(path, encoded.bytes);
}

Result<void> save_jpeg(const fs::path& path, const Image8& image) {
  if (auto ok = check_encodable(path, image, "JPEG"); !ok) return ok;
  constexpr int quality = 90;
  auto encoded = codec::encode_jpeg(static_cast<int>(image.width), static_cast<int>(image.height),
                                    static_cast<int>(image.channels), image.pixels.data(), quality);
  if (!encoded.error.empty()) return fail(ErrorKind::Internal, "saving '{}': {}", path.string(), encoded.error);
  return write_bytes(path, encoded.bytes);
}

Result<Image> load_hdr(const fs::path& path) {
  auto bytes = read_bytes(path);
  if (!bytes) return std::unexpected(bytes.error());
  if (!codec::is_radiance(bytes->data(), bytes->size())) {
    return fail(ErrorKind::Parse, "cannot decode Radiance HDR '{}': no '#?RADIANCE' or '#?RGBE' header",
                path.string());
  }
  auto decoded = codec::decode_radiance(bytes->data(), bytes->size());
  if (!decoded.error.empty()) return decode_error(path, decoded, "Radiance HDR");
  return Image{static_cast<std::uint32_t>(decoded.width), static_cast<std::uint32_t>(decoded.height),
               static_cast<std::uint32_t>(decoded.channels), std::move(decoded.pixels)};
}

Result<void> save_hdr(const fs::path& path, const Image& image) {
  if (auto ok = check_encodable(path, image, "Radiance HDR"); !ok) return ok;
  auto encoded = codec::encode_radiance(static_cast<int>(image.width), static_cast<int>(image.height),
                                        static_cast<int>(image.channels), image.pixels.data());
  if (!encoded.error.empty()) return fail(ErrorKind::Internal, "saving '{}': {}", path.string(), encoded.error);
  return write_bytes(path, encoded.bytes);
}

Result<Image> load_exr(const fs::path& path) {
  auto bytes = read_bytes(path);
  if (!bytes) return std::unexpected(bytes.error());
  auto decoded = codec::decode_exr(bytes->data(), bytes->size());
  if (!decoded.error.empty()) return decode_error(path, decoded, "OpenEXR");
  return Image{static_cast<std::uint32_t>(decoded.width), static_cast<std::uint32_t>(decoded.height),
               static_cast<std::uint32_t>(decoded.channels), std::move(decoded.pixels)};
}

Result<void> save_exr(const fs::path& path, const Image& image, ExrPixelType type) {
  if (auto ok = check_encodable(path, image, "OpenEXR"); !ok) return ok;
  auto encoded = codec::encode_exr(static_cast<int>(image.width), static_cast<int>(image.height),
                                   static_cast<int>(image.channels), image.pixels.data(), type == ExrPixelType::Half);
  if (!encoded.error.empty()) return fail(ErrorKind::Internal, "saving '{}': {}", path.string(), encoded.error);
  return write_bytes(path, encoded.bytes);
}

Result<Image> load_float_image(const fs::path& path) {
  const std::string ext = lower_extension(path);
  if (ext == ".exr") return load_exr(path);
  if (ext == ".hdr") return load_hdr(path);
  if (ext == ".png" || ext == ".jpg" || ext == ".jpeg") {
    auto ldr = load_ldr(path);
    if (!ldr) return std::unexpected(ldr.error());
    return from_srgb8(*ldr);
  }
  return fail(ErrorKind::Unsupported, "cannot load '{}': unknown image extension '{}' (use .exr, .hdr, .png or .jpg)",
              path.string(), ext);
}

Result<void> save_image(const fs::path& path, const Image& image, float exposure) {
  const std::string ext = lower_extension(path);
  if (ext == ".exr") return save_exr(path, image);
  if (ext == ".hdr") return save_hdr(path, image);
  if (ext == ".png") {
    if (auto ok = validate(image); !ok) return with_context(weft::format("saving '{}'", path.string()), ok.error());
    return save_png(path, to_srgb8(image, exposure));
  }
  return fail(ErrorKind::Unsupported, "cannot save '{}': unknown image extension '{}' (use .exr, .hdr or .png)",
              path.string(), ext);
}

Result<void> save_image(const fs::path& path, const Image8& image) {
  const std::string ext = lower_extension(path);
  if (ext == ".png") return save_png(path, image);
  if (ext == ".jpg" || ext == ".jpeg") return save_jpeg(path, image);
  if (ext == ".exr" || ext == ".hdr") {
    if (auto ok = validate(image); !ok) return with_context(weft::format("saving '{}'", path.string()), ok.error());
    return ext == ".exr" ? save_exr(path, from_srgb8(image)) : save_hdr(path, from_srgb8(image));
  }
  return fail(ErrorKind::Unsupported, "cannot save '{}': unknown image extension '{}' (use .png, .jpg, .exr or .hdr)",
              path.string(), ext);
}

}  // namespace weft::image
