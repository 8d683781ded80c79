// Error against the reference over the pixels the feature covers. The renderer hands back
// 8-bit sRGB; with the plain clamp tone operator (no ACES) the decoded values are the linear
// radiance times the exposure wherever it is below 1, so RMSE is in linear units, with a
// floor of about 1e-3 from 8-bit rounding.
module;
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <expected>
#include <limits>
#include <span>
#include <string_view>
#include <vector>
module weft.tradeoff;
import weft.core;
import weft.image;

namespace weft::tradeoff {

namespace {
Result<void> same_size(const image::Image8& a, const image::Image8& b, std::string_view what) {
  if (auto ok = image::validate(a); !ok) return ok;
  if (a.width != b.width || a.height != b.height || a.channels != b.channels)
    return fail(ErrorKind::InvalidArgument, "{}: {}x{}x{} against {}x{}x{}", what, a.width, a.height, a.channels,
                b.width, b.height, b.channels);
  if (a.channels < 3) return fail(ErrorKind::InvalidArgument, "{}: RGB(A) images expected, got {} channels", what, a.channels);
  return {};
}

bool pixel_differs(const image::Image8& a, const image::Image8& b, std::size_t pixel) {
  for (std::uint32_t c = 0; c < 3; ++c)
    if (a.pixels[pixel * a.channels + c] != b.pixels[pixel * b.channels + c]) return true;
  return false;
}
}  // namespace

std::size_t Mask::count() const { return std::size_t(std::count(covered.begin(), covered.end(), std::uint8_t{1})); }

Mask full_mask(std::uint32_t width, std::uint32_t height) {
  return {width, height, std::vector<std::uint8_t>(std::size_t(width) * height, 1)};
}

Result<Mask> coverage_mask(const image::Image8& covered_a, const image::Image8& covered_b,
                           std::span<const image::Image8* const> renders, const image::Image8& reference) {
  if (auto ok = same_size(covered_a, reference, "coverage image against the reference"); !ok) return std::unexpected(ok.error());
  if (auto ok = same_size(covered_b, reference, "coverage image against the reference"); !ok) return std::unexpected(ok.error());
  for (const auto* r : renders)
    if (auto ok = same_size(*r, reference, "render against the reference"); !ok) return std::unexpected(ok.error());
  Mask mask{reference.width, reference.height, std::vector<std::uint8_t>(std::size_t(reference.width) * reference.height, 0)};
  for (std::size_t p = 0; p < mask.covered.size(); ++p) {
    bool covered = pixel_differs(covered_a, covered_b, p);
    for (std::size_t i = 0; !covered && i < renders.size(); ++i) covered = pixel_differs(*renders[i], reference, p);
    mask.covered[p] = covered ? 1 : 0;
  }
  return mask;
}

Result<ImageError> compare(const image::Image8& render, const image::Image8& reference, const Mask& mask) {
  if (auto ok = same_size(render, reference, "render against the reference"); !ok) return std::unexpected(ok.error());
  if (mask.width != reference.width || mask.height != reference.height || mask.covered.size() != std::size_t(mask.width) * mask.height)
    return fail(ErrorKind::InvalidArgument, "mask {}x{} against images {}x{}", mask.width, mask.height, reference.width,
                reference.height);
  ImageError e;
  e.pixels = mask.count();
  if (e.pixels == 0) return fail(ErrorKind::InvalidArgument, "the mask covers no pixel: the feature drew nothing");
  const auto a = image::from_srgb8(render), b = image::from_srgb8(reference);
  double sum = 0.0, largest = 0.0, reference_sum = 0.0;
  std::uint32_t x0 = mask.width, y0 = mask.height, x1 = 0, y1 = 0;
  for (std::uint32_t y = 0; y < mask.height; ++y)
    for (std::uint32_t x = 0; x < mask.width; ++x) {
      if (!mask.covered[std::size_t(y) * mask.width + x]) continue;
      x0 = std::min(x0, x), y0 = std::min(y0, y), x1 = std::max(x1, x), y1 = std::max(y1, y);
      for (std::uint32_t c = 0; c < 3; ++c) {
        const double d = double(a.at(x, y, c)) - double(b.at(x, y, c));
        sum += d * d;
        reference_sum += double(b.at(x, y, c)) * double(b.at(x, y, c));
        largest = std::max(largest, std::abs(d));
      }
    }
  e.rmse = std::sqrt(sum / double(e.pixels * 3));
  e.relative_rmse = reference_sum > 0.0 ? std::sqrt(sum / reference_sum) : 0.0;
  e.max_diff = largest;
  e.psnr_db = e.rmse > 0.0 ? 20.0 * std::log10(1.0 / e.rmse) : std::numeric_limits<double>::infinity();
  // SSIM needs whole windows: over the mask's bounding box, in RGB (weft.image takes luminance).
  auto crop = [&](const image::Image& img) {
    image::Image out = image::Image::filled(x1 - x0 + 1, y1 - y0 + 1, 3);
    for (std::uint32_t y = y0; y <= y1; ++y)
      for (std::uint32_t x = x0; x <= x1; ++x)
        for (std::uint32_t c = 0; c < 3; ++c) out.at(x - x0, y - y0, c) = img.at(x, y, c);
    return out;
  };
  auto s = image::ssim(crop(a), crop(b));
  if (!s) return std::unexpected(s.error());
  e.ssim = *s;
  return e;
}

}  // namespace weft::tradeoff
