// Internal to weft.image: the third-party codecs (stb_image, stb_image_write, tinyexr;
// libjpeg-turbo in jpeg.cpp) behind a few plain functions on memory buffers, compiled once in
// codecs.cpp so that no module unit includes their implementations. Files, paths and weft::Error live in io.cpp.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace weft::image::codec {

template <class T>
struct Decoded {
  int width = 0;
  int height = 0;
  int channels = 0;
  std::vector<T> pixels;   // interleaved, top row first
  std::string error;       // empty on success: the decoder's reason otherwise
  bool unsupported = false;  // the file is valid but uses something we do not read
};

struct Encoded {
  std::vector<std::uint8_t> bytes;
  std::string error;  // empty on success
};

bool is_png(const std::uint8_t* data, std::size_t size);
bool is_radiance(const std::uint8_t* data, std::size_t size);

// PNG, JPEG or BMP to 8 bits, with the file's own channel count (JPEG: grey 1, else RGB).
Decoded<std::uint8_t> decode_ldr(const std::uint8_t* data, std::size_t size);
// JPEG through libjpeg-turbo (jpeg.cpp); refuses a header of more than
// most_pixels_per_byte * size + pixel_slack pixels before decoding.
Decoded<std::uint8_t> decode_jpeg(const std::uint8_t* data, std::size_t size, std::uint64_t most_pixels_per_byte,
                                  std::uint64_t pixel_slack);
// Radiance RGBE; the caller checks is_radiance first.
Decoded<float> decode_radiance(const std::uint8_t* data, std::size_t size);
// OpenEXR: RGB(A), Y(A) or a single channel; scanline or tiled (first level).
Decoded<float> decode_exr(const std::uint8_t* data, std::size_t size);

// Sizes are checked by the caller (positive, channels 1..4, fit in int).
Encoded encode_png(int width, int height, int channels, const std::uint8_t* pixels);
// Baseline JPEG; alpha is dropped. quality 1..100.
Encoded encode_jpeg(int width, int height, int channels, const std::uint8_t* pixels, int quality);
Encoded encode_radiance(int width, int height, int channels, const float* pixels);
Encoded encode_exr(int width, int height, int channels, const float* pixels, bool half);

}  // namespace weft::image::codec
