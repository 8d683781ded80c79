// weft.image: checking an image's shape, the sRGB transfer functions, 8-bit <-> float
// conversion and luminance. Colour math runs in double; alpha stays linear.
module;
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <vector>
module weft.image;
import weft.core;

namespace weft::image {
namespace {

template <class Img>
Result<void> validate_shape(const Img& image, const char* what) {
  if (image.width == 0 || image.height == 0) {
    return fail(ErrorKind::InvalidArgument, "{} has zero size ({}x{})", what, image.width, image.height);
  }
  if (image.channels < 1 || image.channels > 4) {
    return fail(ErrorKind::InvalidArgument, "{} has {} channels; 1 to 4 are supported", what, image.channels);
  }
  if (image.pixels.size() != image.sample_count()) {
    return fail(ErrorKind::InvalidArgument, "{} of {}x{}x{} needs {} samples but has {}", what, image.width,
                image.height, image.channels, image.sample_count(), image.pixels.size());
  }
  return {};
}

// The last channel of gray+alpha and RGBA is alpha.
bool is_alpha(std::uint32_t channels, std::uint32_t c) { return (channels == 2 || channels == 4) && c == channels - 1; }

double clamp01(double v) { return std::isnan(v) ? 0.0 : std::clamp(v, 0.0, 1.0); }

double encode(double linear) {
  const double v = clamp01(linear);
  return v <= 0.0031308 ? 12.92 * v : 1.055 * std::pow(v, 1.0 / 2.4) - 0.055;
}

double decode(double encoded) {
  const double v = clamp01(encoded);
  return v <= 0.04045 ? v / 12.92 : std::pow((v + 0.055) / 1.055, 2.4);
}

std::uint8_t to_code(double unit) { return static_cast<std::uint8_t>(std::lround(clamp01(unit) * 255.0)); }

}  // namespace

Result<void> validate(const Image& image) { return validate_shape(image, "image"); }
Result<void> validate(const Image8& image) { return validate_shape(image, "8-bit image"); }

float linear_to_srgb(float linear) { return static_cast<float>(encode(linear)); }
float srgb_to_linear(float encoded) { return static_cast<float>(decode(encoded)); }

Image8 to_srgb8(const Image& image, float exposure) {
  if (!validate(image)) return {};
  Image8 out = Image8::filled(image.width, image.height, image.channels);
  const std::size_t n = image.sample_count();
  for (std::size_t i = 0; i < n; ++i) {
    const auto c = static_cast<std::uint32_t>(i % image.channels);
    const double v = image.pixels[i];
    out.pixels[i] = is_alpha(image.channels, c) ? to_code(v) : to_code(encode(v * static_cast<double>(exposure)));
  }
  return out;
}

Image from_srgb8(const Image8& image) {
  if (!validate(image)) return {};
  // One table for the 256 codes of colour channels.
  float table[256];
  for (int code = 0; code < 256; ++code) table[code] = static_cast<float>(decode(code / 255.0));
  Image out = Image::filled(image.width, image.height, image.channels);
  const std::size_t n = image.sample_count();
  for (std::size_t i = 0; i < n; ++i) {
    const auto c = static_cast<std::uint32_t>(i % image.channels);
    const std::uint8_t code = image.pixels[i];
    out.pixels[i] = is_alpha(image.channels, c) ? static_cast<float>(code / 255.0) : table[code];
  }
  return out;
}

Image luminance(const Image& image) {
  if (!validate(image)) return {};
  Image out = Image::filled(image.width, image.height, 1);
  const std::size_t count = std::size_t{image.width} * image.height;
  const std::uint32_t ch = image.channels;
  for (std::size_t p = 0; p < count; ++p) {
    const float* px = &image.pixels[p * ch];
    out.pixels[p] = ch >= 3 ? static_cast<float>(0.2126 * px[0] + 0.7152 * px[1] + 0.0722 * px[2]) : px[0];
  }
  return out;
}

}  // namespace weft::image
