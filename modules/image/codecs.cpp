// The one translation unit that compiles the third-party codecs for weft.image: stb_image
// and stb_image_write (as static functions, so another library's copy cannot clash) and
// tinyexr's header-only implementation over zlib. See codecs.h for the interface.
//
// tinyexr is compiled from its header rather than linked from Debian's libtinyexr.so: that
// library is older than the header Debian ships with it (it lacks EXRNumLevels and
// EXRSetNameAttr, and EXRImage gained fields), so linking it would mismatch the ABI.
#include "codecs.h"

#include <algorithm>
#include <cfloat>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#pragma clang diagnostic push
#pragma clang diagnostic ignored "-Weverything"
#define STB_IMAGE_STATIC
#define STB_IMAGE_IMPLEMENTATION
#define STBI_NO_STDIO
#define STBI_NO_JPEG  // JPEG goes to libjpeg-turbo (jpeg.cpp)
#include <stb_image.h>
#define STB_IMAGE_WRITE_STATIC
#define STB_IMAGE_WRITE_IMPLEMENTATION
// No STBI_WRITE_NO_STDIO: it also compiles out stbi_write_hdr_to_func (an stb bug).
#include <stb_image_write.h>
#include <zlib.h>
#define TINYEXR_USE_MINIZ 0
#define TINYEXR_USE_THREAD 0
#define TINYEXR_IMPLEMENTATION
#include <tinyexr.h>
#pragma clang diagnostic pop

namespace weft::image::codec {
namespace {

std::string stb_reason(const char* fallback) {
  const char* reason = stbi_failure_reason();
  return reason != nullptr && *reason != '\0' ? std::string(reason) : std::string(fallback);
}

void append_bytes(void* context, void* data, int size) {
  auto* out = static_cast<std::vector<std::uint8_t>*>(context);
  const auto* p = static_cast<const std::uint8_t*>(data);
  out->insert(out->end(), p, p + size);
}

std::string exr_code_text(int code) {
  switch (code) {
    case TINYEXR_ERROR_INVALID_MAGIC_NUMBER: return "not an OpenEXR file (bad magic number)";
    case TINYEXR_ERROR_INVALID_EXR_VERSION: return "unsupported OpenEXR version";
    case TINYEXR_ERROR_INVALID_DATA: return "invalid data";
    case TINYEXR_ERROR_INVALID_FILE: return "invalid file";
    case TINYEXR_ERROR_INVALID_HEADER: return "invalid header";
    case TINYEXR_ERROR_UNSUPPORTED_FORMAT: return "unsupported format";
    case TINYEXR_ERROR_UNSUPPORTED_FEATURE: return "unsupported feature";
    default: return "error code " + std::to_string(code);
  }
}

// tinyexr's message if it gave one (freed here), else the code's meaning.
std::string exr_reason(int code, const char* err) {
  std::string text = err != nullptr ? std::string(err) : exr_code_text(code);
  if (err != nullptr) FreeEXRErrorMessage(err);
  while (!text.empty() && (text.back() == '\n' || text.back() == ' ')) text.pop_back();
  return text.empty() ? exr_code_text(code) : text;
}

bool exr_unsupported(int code) {
  return code == TINYEXR_ERROR_UNSUPPORTED_FORMAT || code == TINYEXR_ERROR_UNSUPPORTED_FEATURE;
}

// Frees tinyexr's header and image on every path out of decode_exr. The header always:
// ParseEXRHeaderFromMemory fills it even when it fails. The image only after a successful
// load: a failed load has freed it already (leaving its pointers dangling).
struct ExrGuard {
  EXRHeader header;
  EXRImage image;
  bool image_ok = false;
  ExrGuard() {
    InitEXRHeader(&header);
    InitEXRImage(&image);
  }
  ~ExrGuard() {
    if (image_ok) FreeEXRImage(&image);
    FreeEXRHeader(&header);
  }
  ExrGuard(const ExrGuard&) = delete;
  ExrGuard& operator=(const ExrGuard&) = delete;
};

float exr_sample(const unsigned char* plane, int pixel_type, std::size_t index) {
  if (pixel_type == TINYEXR_PIXELTYPE_UINT) {
    unsigned int v;
    std::memcpy(&v, plane + index * sizeof v, sizeof v);
    return static_cast<float>(v);
  }
  float v;  // HALF channels were requested as FLOAT
  std::memcpy(&v, plane + index * sizeof v, sizeof v);
  return v;
}

// stb_image (2022) loops forever on an RLE scanline cut short (it reads 0 past the end,
// a zero-length run) and zero-fills truncated flat data without a word. So walk the pixel
// stream first, the way stb will; return why it cannot be decoded, or "" to let stb decide
// (stb reports header errors itself).
std::string radiance_stream_error(const std::uint8_t* data, std::size_t size) {
  std::size_t pos = 0;
  std::string line;
  auto next_line = [&] {
    if (pos >= size) return false;
    const std::size_t start = pos;
    while (pos < size && data[pos] != '\n') ++pos;
    line.assign(reinterpret_cast<const char*>(data) + start, pos - start);
    if (pos < size) ++pos;
    return true;
  };
  if (!next_line()) return {};
  do {
    if (!next_line()) return {};
  } while (!line.empty() && line[0] != '\0');  // stb reads lines as C strings: "\0..." ends the header too
  if (!next_line()) return {};
  int h = 0, w = 0;
  if (std::sscanf(line.c_str(), "-Y %d +X %d", &h, &w) != 2 || h <= 0 || w <= 0) return {};

  const auto width = static_cast<std::uint64_t>(w), pixels = width * static_cast<std::uint64_t>(h);
  const std::string truncated = "truncated pixel data";
  auto flat_from = [&](std::uint64_t done) { return size - pos >= (pixels - done) * 4 ? std::string{} : truncated; };
  if (w < 8 || w >= 32768) return flat_from(0);
  for (int y = 0; y < h; ++y) {
    if (size - pos < 4) return truncated;
    const std::uint8_t c1 = data[pos], c2 = data[pos + 1], hi = data[pos + 2], lo = data[pos + 3];
    pos += 4;
    if (c1 != 2 || c2 != 2 || (hi & 0x80) != 0) return flat_from(1);  // stb reads flat from here on
    if (((hi << 8) | lo) != w) return {};
    for (int k = 0; k < 4; ++k) {
      for (int x = 0; x < w;) {
        if (pos >= size) return truncated;
        int count = data[pos++];
        if (count == 0) return "zero-length run in RLE data";
        const bool run = count > 128;
        if (run) count -= 128;
        if (count > w - x) return {};
        const std::size_t need = run ? 1 : static_cast<std::size_t>(count);
        if (size - pos < need) return truncated;
        pos += need;
        x += count;
      }
    }
  }
  return {};
}

}  // namespace

bool is_png(const std::uint8_t* data, std::size_t size) {
  static constexpr std::uint8_t signature[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
  return size >= sizeof signature && std::memcmp(data, signature, sizeof signature) == 0;
}

bool is_radiance(const std::uint8_t* data, std::size_t size) {
  if (size > static_cast<std::size_t>(INT32_MAX)) return false;
  return stbi_is_hdr_from_memory(data, static_cast<int>(size)) != 0;
}

// Takes ownership of what stb decoded: checks the size it reports, copies, frees.
template <class T>
Decoded<T> take_stb_pixels(T* pixels, int w, int h, int c) {
  Decoded<T> out;
  if (pixels == nullptr) {
    out.error = stb_reason("unknown decoder error");
    return out;
  }
  if (w <= 0 || h <= 0 || c < 1 || c > 4) {  // stb accepts e.g. a Radiance "+X 0"
    stbi_image_free(pixels);
    out.error = "bad image size " + std::to_string(w) + "x" + std::to_string(h) + "x" + std::to_string(c);
    return out;
  }
  out.width = w;
  out.height = h;
  out.channels = c;
  out.pixels.assign(pixels, pixels + static_cast<std::size_t>(w) * h * c);
  stbi_image_free(pixels);
  return out;
}

// A JPEG Huffman table whose 16 code counts sum past 256 made Debian 12's stb_image write past
// its tables (fuzz_jpg; JPEG now goes to libjpeg-turbo, which refuses such a table as
// "bogus"). The check stays because it says where: it walks the marker segments, entropy-coded
// data included, and names the table's byte.
std::string jpeg_stream_error(const std::uint8_t* data, std::size_t size) {
  // stb finds SOI as it finds every marker: 0xFF, any number of 0xFF fill bytes, then the code.
  if (size < 2 || data[0] != 0xFF) return {};
  std::size_t at = 0;
  while (at < size && data[at] == 0xFF) ++at;
  if (at >= size || data[at] != 0xD8) return {};  // not a JPEG: stb decides
  ++at;
  while (at + 4 <= size) {
    if (data[at] != 0xFF) {  // entropy-coded data: skip to the next marker (0xFF, then not 00 / RSTn / FF)
      ++at;
      continue;
    }
    const std::uint8_t marker = data[at + 1];
    if (marker == 0x00 || marker == 0xFF || (marker >= 0xD0 && marker <= 0xD8) || marker == 0x01) {  // no length
      ++at;
      continue;
    }
    if (marker == 0xD9) break;  // end of image
    const std::size_t length = std::size_t(data[at + 2]) << 8 | data[at + 3];
    if (length < 2) return "JPEG segment at byte " + std::to_string(at) + " has a length below 2";
    const std::size_t end = std::min(size, at + 2 + length);
    if (marker == 0xC4) {  // DHT: tables of (class/id, 16 counts, symbols), read as stb reads them:
      // table after table while the declared length lasts, even past the segment's end, and
      // zeros past the end of the file.
      const auto byte = [&](std::size_t i) -> std::size_t { return i < size ? data[i] : 0; };
      std::ptrdiff_t left = std::ptrdiff_t(length) - 2;
      std::size_t t = at + 4;
      while (left > 0) {
        if ((byte(t) >> 4) > 1 || (byte(t) & 15) > 3) break;  // stb refuses the table
        std::size_t codes = 0;
        for (std::size_t i = 1; i <= 16; ++i) codes += byte(t + i);
        if (codes > 256)
          return "JPEG Huffman table at byte " + std::to_string(t) + " declares " + std::to_string(codes) +
                 " codes (at most 256)";
        t += 17 + codes;
        left -= std::ptrdiff_t(17 + codes);
      }
    }
    at = end;
  }
  return {};
}

// The same stb_image passes a null pointer to memcpy for a zero-length IDAT chunk (UB that
// UBSan reports; harmless in practice, but a fuzzed reader must be clean). A zero-length IDAT
// adds no data, so such chunks are dropped from a copy before decoding.
std::vector<std::uint8_t> png_without_empty_idat(const std::uint8_t* data, std::size_t size) {
  std::vector<std::uint8_t> out;
  if (!is_png(data, size)) return out;
  // Chunks: length (4, big-endian), type (4), data, CRC (4); the last one may be cut short.
  const auto length_at = [&](std::size_t at) {
    return std::size_t(data[at]) << 24 | std::size_t(data[at + 1]) << 16 | std::size_t(data[at + 2]) << 8 | data[at + 3];
  };
  const auto empty_idat_at = [&](std::size_t at) { return length_at(at) == 0 && std::memcmp(data + at + 4, "IDAT", 4) == 0; };
  const auto chunk_bytes = [&](std::size_t at) { return std::min(size - at, 12 + length_at(at)); };
  bool any = false;
  for (std::size_t at = 8; at + 8 <= size; at += chunk_bytes(at)) any = any || empty_idat_at(at);
  if (!any) return out;
  out.assign(data, data + 8);
  std::size_t at = 8;
  for (; at + 8 <= size; at += chunk_bytes(at))
    if (!empty_idat_at(at)) out.insert(out.end(), data + at, data + at + chunk_bytes(at));
  out.insert(out.end(), data + at, data + size);
  return out;
}

// tinyexr trusts an attribute's stated size for the fixed-size types (it reads a "tiles"
// tiledesc as 9 bytes whatever its size says: a heap over-read found by fuzz_skin_lut_cache).
// This walks a single-part header's attributes (name, type, size, value; an empty name ends
// it) and refuses one that runs past the file or whose size does not match its type.
std::string exr_header_error(const std::uint8_t* data, std::size_t size) {
  static constexpr std::pair<std::string_view, std::size_t> fixed_sizes[] = {
      {"box2i", 16}, {"box2f", 16}, {"v2i", 8},   {"v2f", 8},         {"v3i", 12},      {"v3f", 12},
      {"int", 4},    {"float", 4},  {"double", 8}, {"compression", 1}, {"lineOrder", 1}, {"tiledesc", 9},
      {"m33f", 36},  {"m44f", 64},  {"rational", 8}, {"timecode", 8}, {"keycode", 28},  {"envmap", 1},
      {"chromaticities", 32}};
  std::size_t at = 8;  // magic and version
  const auto cstring = [&](std::string_view what, std::string& out) -> std::string {
    const std::size_t limit = std::min(size, at + 256);
    std::size_t end = at;
    while (end < limit && data[end] != 0) ++end;
    if (end >= limit) return "the header's attribute " + std::string(what) + " at byte " + std::to_string(at) +
                             " is not a string of at most 255 bytes";
    out.assign(reinterpret_cast<const char*>(data) + at, end - at);
    at = end + 1;
    return {};
  };
  while (at < size) {
    std::string name, type;
    if (std::string why = cstring("name", name); !why.empty()) return why;
    if (name.empty()) return {};  // end of the header
    if (std::string why = cstring("type", type); !why.empty()) return why;
    if (size - at < 4) return "attribute '" + name + "' is cut off before its size";
    std::int32_t length = 0;
    std::memcpy(&length, data + at, 4);
    at += 4;
    if (length < 0 || std::size_t(length) > size - at)
      return "attribute '" + name + "' says it has " + std::to_string(length) + " bytes, the file has " +
             std::to_string(size - at) + " left";
    for (const auto& [fixed_type, bytes] : fixed_sizes)
      if (type == fixed_type && std::size_t(length) != bytes)
        return "attribute '" + name + "' of type " + type + " has " + std::to_string(length) + " bytes (a " + type +
               " has " + std::to_string(bytes) + ")";
    // tinyexr reads these two by name, whatever their type says (found by fuzz_exr).
    for (const auto& [by_name, bytes] : {std::pair<std::string_view, std::size_t>{"tiles", 9}, {"compression", 1}})
      if (name == by_name && std::size_t(length) != bytes)
        return "attribute '" + name + "' has " + std::to_string(length) + " bytes (it is " + std::to_string(bytes) +
               ")";
    at += std::size_t(length);
  }
  return "the header has no end (no empty attribute name)";
}

Decoded<std::uint8_t> decode_ldr(const std::uint8_t* data, std::size_t size) {
  Decoded<std::uint8_t> out;
  if (size > static_cast<std::size_t>(INT32_MAX)) {
    out.error = "file is larger than 2 GiB";
    out.unsupported = true;
    return out;
  }
  // Only formats with a signature: stb_image also tries TGA, which has none, so any bytes can
  // pass for one (a fuzzed ".png" decoded as a TGA of huge size copied for minutes: fuzz_btf_folder).
  const bool jpeg = size >= 2 && data[0] == 0xFF && (data[1] == 0xD8 || data[1] == 0xFF);
  const bool bmp = size >= 2 && data[0] == 'B' && data[1] == 'M';
  if (!is_png(data, size) && !jpeg && !bmp) {
    out.error = "not a PNG, JPEG or BMP file (no signature; weft reads only those 8-bit formats)";
    return out;
  }
  if (std::string why = jpeg_stream_error(data, size); !why.empty()) {
    out.error = std::move(why);
    return out;
  }
  // The densest real JPEG coding spends a bit per 8x8 block and component: 512 pixels a byte.
  if (jpeg) return decode_jpeg(data, size, 1024, 1 << 18);
  // A BMP header declaring far more pixels than the file holds (stb reads no RLE, so at most
  // 8 pixels a byte): stb_image would allocate the whole image and fill it from nothing.
  if (int w = 0, h = 0, c = 0; bmp && stbi_info_from_memory(data, static_cast<int>(size), &w, &h, &c)) {
    const std::uint64_t pixels = std::uint64_t(w) * std::uint64_t(h);
    if (pixels > 8 * std::uint64_t(size) + 4096) {
      out.error = "BMP header declares " + std::to_string(w) + " x " + std::to_string(h) + " pixels, more than its " +
                  std::to_string(size) + " bytes can code (a BMP at most 8 pixels a byte)";
      return out;
    }
  }
  const std::vector<std::uint8_t> cleaned = png_without_empty_idat(data, size);
  if (!cleaned.empty()) {
    data = cleaned.data();
    size = cleaned.size();
  }
  int w = 0, h = 0, c = 0;
  stbi_uc* pixels = stbi_load_from_memory(data, static_cast<int>(size), &w, &h, &c, 0);
  return take_stb_pixels(pixels, w, h, c);
}

Decoded<float> decode_radiance(const std::uint8_t* data, std::size_t size) {
  Decoded<float> out;
  if (size > static_cast<std::size_t>(INT32_MAX)) {
    out.error = "file is larger than 2 GiB";
    out.unsupported = true;
    return out;
  }
  if (std::string why = radiance_stream_error(data, size); !why.empty()) {
    out.error = std::move(why);
    return out;
  }
  int w = 0, h = 0, c = 0;
  float* pixels = stbi_loadf_from_memory(data, static_cast<int>(size), &w, &h, &c, 0);
  return take_stb_pixels(pixels, w, h, c);
}

Decoded<float> decode_exr(const std::uint8_t* data, std::size_t size) {
  Decoded<float> out;
  EXRVersion version;
  int ret = ParseEXRVersionFromMemory(&version, data, size);
  if (ret != TINYEXR_SUCCESS) {
    out.error = exr_code_text(ret);
    return out;
  }
  if (version.multipart || version.non_image) {
    out.error = version.multipart ? "multi-part OpenEXR files are not supported"
                                  : "deep OpenEXR images are not supported";
    out.unsupported = true;
    return out;
  }
  if (std::string why = exr_header_error(data, size); !why.empty()) {
    out.error = std::move(why);
    return out;
  }
  ExrGuard exr;
  const char* err = nullptr;
  ret = ParseEXRHeaderFromMemory(&exr.header, &version, data, size, &err);
  if (ret != TINYEXR_SUCCESS) {
    out.error = exr_reason(ret, err);
    out.unsupported = exr_unsupported(ret);
    return out;
  }
  for (int i = 0; i < exr.header.num_channels; ++i) {
    if (exr.header.pixel_types[i] == TINYEXR_PIXELTYPE_HALF) {
      exr.header.requested_pixel_types[i] = TINYEXR_PIXELTYPE_FLOAT;
    }
    if (exr.header.channels[i].x_sampling != 1 || exr.header.channels[i].y_sampling != 1) {
      out.error = std::string("sub-sampled channel '") + exr.header.channels[i].name + "' is not supported";
      out.unsupported = true;
      return out;
    }
  }
  // tinyexr computes a window's width as max - min + 1 in int: a window near INT_MIN overflows
  // (UB, found by fuzz_exr). weft reads images up to 2^24 pixels a side.
  for (const EXRBox2i* box : {&exr.header.data_window, &exr.header.display_window}) {
    const std::int64_t w = std::int64_t(box->max_x) - box->min_x + 1, h = std::int64_t(box->max_y) - box->min_y + 1;
    if (w < 1 || h < 1 || w > (1 << 24) || h > (1 << 24)) {
      out.error = std::string(box == &exr.header.data_window ? "data" : "display") + " window (" +
                  std::to_string(box->min_x) + ", " + std::to_string(box->min_y) + ") - (" + std::to_string(box->max_x) +
                  ", " + std::to_string(box->max_y) + ") is not 1 to 16,777,216 pixels a side";
      return out;
    }
  }
  // A window the file's bytes cannot fill, even at the best ratio OpenEXR's compressions reach
  // (zlib's 1032:1; PIZ's run codes and B44 less), is a corrupt header: tinyexr would allocate
  // and fill it all the same (fuzz_exr: 116 MB and minutes from a 404-byte file).
  {
    std::uint64_t bytes_per_pixel = 0;
    for (int i = 0; i < exr.header.num_channels; ++i)
      bytes_per_pixel += exr.header.pixel_types[i] == TINYEXR_PIXELTYPE_HALF ? 2 : 4;
    const EXRBox2i& box = exr.header.data_window;
    const std::uint64_t pixels = std::uint64_t(std::int64_t(box.max_x) - box.min_x + 1) *
                                 std::uint64_t(std::int64_t(box.max_y) - box.min_y + 1);
    constexpr std::uint64_t best_ratio = 2048, slack = 1 << 20;
    if (pixels * bytes_per_pixel > best_ratio * size + slack) {
      out.error = "data window of " + std::to_string(pixels) + " pixels (" + std::to_string(pixels * bytes_per_pixel) +
                  " bytes decoded) is more than a " + std::to_string(size) +
                  "-byte file can hold (OpenEXR compresses at most about 1000:1)";
      return out;
    }
  }
  // tinyexr frees a half-decoded image with FreeEXRImage, which walks image.num_channels,
  // but sets that only on success: set it first so a corrupt file's planes are not leaked.
  exr.image.num_channels = exr.header.num_channels;
  ret = LoadEXRImageFromMemory(&exr.image, &exr.header, data, size, &err);
  if (ret != TINYEXR_SUCCESS) {
    out.error = exr_reason(ret, err);
    out.unsupported = exr_unsupported(ret);
    return out;
  }
  exr.image_ok = true;

  // Which stored channel feeds each of ours: RGB(A), Y(A), or one channel of any name.
  const int n = exr.header.num_channels;
  auto find = [&](const char* name) {
    for (int i = 0; i < n; ++i) {
      if (std::strcmp(exr.header.channels[i].name, name) == 0) return i;
    }
    return -1;
  };
  const int r = find("R"), g = find("G"), b = find("B"), a = find("A"), y = find("Y");
  std::vector<int> source;
  if (r >= 0 && g >= 0 && b >= 0) {
    source = {r, g, b};
    if (a >= 0) source.push_back(a);
  } else if (y >= 0) {
    source = {y};
    if (a >= 0) source.push_back(a);
  } else if (n == 1) {
    source = {0};
  } else {
    std::string names;
    for (int i = 0; i < n; ++i) names += std::string(i ? ", " : "") + exr.header.channels[i].name;
    out.error = "channels [" + names + "] are neither RGB(A) nor Y(A)";
    out.unsupported = true;
    return out;
  }

  const int w = exr.image.width, h = exr.image.height;
  if (w <= 0 || h <= 0) {
    out.error = "empty data window";
    return out;
  }
  const int c = static_cast<int>(source.size());
  out.width = w;
  out.height = h;
  out.channels = c;
  out.pixels.assign(static_cast<std::size_t>(w) * h * c, 0.0f);
  auto put = [&](int px, int py, unsigned char** planes, std::size_t index) {
    for (int k = 0; k < c; ++k) {
      const int s = source[static_cast<std::size_t>(k)];
      out.pixels[(static_cast<std::size_t>(py) * w + px) * c + k] =
          exr_sample(planes[s], exr.header.pixel_types[s], index);
    }
  };
  if (exr.header.tiled) {
    if (exr.image.tiles == nullptr) {
      out.error = "tiled image without tiles";
      return out;
    }
    const int tw = exr.header.tile_size_x, th = exr.header.tile_size_y;
    for (int t = 0; t < exr.image.num_tiles; ++t) {
      const EXRTile& tile = exr.image.tiles[t];
      for (int j = 0; j < tile.height; ++j) {
        for (int i = 0; i < tile.width; ++i) {
          const int px = tile.offset_x * tw + i, py = tile.offset_y * th + j;
          if (px < 0 || py < 0 || px >= w || py >= h) continue;
          put(px, py, tile.images, static_cast<std::size_t>(j) * tw + i);
        }
      }
    }
  } else {
    for (int py = 0; py < h; ++py) {
      for (int px = 0; px < w; ++px) put(px, py, exr.image.images, static_cast<std::size_t>(py) * w + px);
    }
  }
  return out;
}

Encoded encode_png(int width, int height, int channels, const std::uint8_t* pixels) {
  Encoded out;
  if (stbi_write_png_to_func(append_bytes, &out.bytes, width, height, channels, pixels, width * channels) == 0) {
    out.bytes.clear();
    out.error = "stb_image_write could not encode the PNG";
  }
  return out;
}

Encoded encode_jpeg(int width, int height, int channels, const std::uint8_t* pixels, int quality) {
  Encoded out;
  if (stbi_write_jpg_to_func(append_bytes, &out.bytes, width, height, channels, pixels, quality) == 0) {
    out.bytes.clear();
    out.error = "stb_image_write could not encode the JPEG";
  }
  return out;
}

Encoded encode_radiance(int width, int height, int channels, const float* pixels) {
  // RGBE holds non-negative finite values up to 255/256 * 2^127 (8-bit exponent).
  const float largest = std::ldexp(255.0f / 256.0f, 127);
  std::vector<float> clean(pixels, pixels + static_cast<std::size_t>(width) * height * channels);
  for (float& v : clean) v = std::isnan(v) ? 0.0f : std::clamp(v, 0.0f, largest);
  Encoded out;
  if (stbi_write_hdr_to_func(append_bytes, &out.bytes, width, height, channels, clean.data()) == 0) {
    out.bytes.clear();
    out.error = "stb_image_write could not encode the Radiance HDR";
  }
  return out;
}

Encoded encode_exr(int width, int height, int channels, const float* pixels, bool half) {
  // Channels are stored in alphabetical order, as OpenEXR readers expect.
  static const char* const names[4][4] = {{"Y"}, {"A", "Y"}, {"B", "G", "R"}, {"A", "B", "G", "R"}};
  static const int from[4][4] = {{0}, {1, 0}, {2, 1, 0}, {3, 2, 1, 0}};  // our channel for each
  const auto n = static_cast<std::size_t>(width) * height;
  std::vector<std::vector<float>> planes(static_cast<std::size_t>(channels), std::vector<float>(n));
  std::vector<unsigned char*> plane_ptrs(static_cast<std::size_t>(channels));
  std::vector<EXRChannelInfo> infos(static_cast<std::size_t>(channels));
  std::vector<int> pixel_types(static_cast<std::size_t>(channels), TINYEXR_PIXELTYPE_FLOAT);
  std::vector<int> stored_types(static_cast<std::size_t>(channels),
                                half ? TINYEXR_PIXELTYPE_HALF : TINYEXR_PIXELTYPE_FLOAT);
  for (int k = 0; k < channels; ++k) {
    const auto kk = static_cast<std::size_t>(k);
    const int src = from[channels - 1][k];
    for (std::size_t i = 0; i < n; ++i) planes[kk][i] = pixels[i * channels + src];
    plane_ptrs[kk] = reinterpret_cast<unsigned char*>(planes[kk].data());
    std::memset(&infos[kk], 0, sizeof infos[kk]);
    std::strncpy(infos[kk].name, names[channels - 1][k], sizeof infos[kk].name - 1);
    infos[kk].x_sampling = 1;
    infos[kk].y_sampling = 1;
  }

  EXRHeader header;
  InitEXRHeader(&header);
  header.num_channels = channels;
  header.channels = infos.data();
  header.pixel_types = pixel_types.data();
  header.requested_pixel_types = stored_types.data();
  header.compression_type = TINYEXR_COMPRESSIONTYPE_ZIP;

  EXRImage image;
  InitEXRImage(&image);
  image.num_channels = channels;
  image.width = width;
  image.height = height;
  image.images = plane_ptrs.data();

  Encoded out;
  unsigned char* memory = nullptr;
  const char* err = nullptr;
  const std::size_t size = SaveEXRImageToMemory(&image, &header, &memory, &err);
  if (size == 0 || memory == nullptr) {
    out.error = exr_reason(TINYEXR_ERROR_SERIALZATION_FAILED, err);
    std::free(memory);
    return out;
  }
  out.bytes.assign(memory, memory + size);
  std::free(memory);
  return out;
}

}  // namespace weft::image::codec
