// weft.image: full-reference image metrics — RMSE, PSNR, max |a-b| and SSIM. Every sum
// runs in double so that float extremes (1e30, FLT_MAX) give finite, correct results.
module;
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <expected>
#include <limits>
#include <vector>
module weft.image;
import weft.core;

namespace weft::image {
namespace {

Result<void> check_finite(const Image& image, const char* name) {
  for (std::size_t i = 0; i < image.pixels.size(); ++i) {
    if (!std::isfinite(image.pixels[i])) {
      const std::size_t pixel = i / image.channels;
      return fail(ErrorKind::InvalidArgument, "image {} has a non-finite value ({}) at pixel ({}, {}) channel {}", name,
                  image.pixels[i], pixel % image.width, pixel / image.width, i % image.channels);
    }
  }
  return {};
}

// Both valid, same shape, all finite.
Result<void> check_pair(const Image& a, const Image& b) {
  if (auto ok = validate(a); !ok) return with_context("image a", ok.error());
  if (auto ok = validate(b); !ok) return with_context("image b", ok.error());
  if (a.width != b.width || a.height != b.height || a.channels != b.channels) {
    return fail(ErrorKind::InvalidArgument, "images differ in size: {}x{}x{} (a) vs {}x{}x{} (b)", a.width, a.height,
                a.channels, b.width, b.height, b.channels);
  }
  if (auto ok = check_finite(a, "a"); !ok) return ok;
  return check_finite(b, "b");
}

double mean_squared_error(const Image& a, const Image& b) {
  double sum = 0.0;
  for (std::size_t i = 0; i < a.pixels.size(); ++i) {
    const double d = static_cast<double>(a.pixels[i]) - static_cast<double>(b.pixels[i]);
    sum += d * d;
  }
  return sum / static_cast<double>(a.pixels.size());
}

// Luminance of one row in double (Rec.709 for RGB(A), the gray channel otherwise).
void luminance_row(const Image& image, std::uint32_t y, double shift, std::vector<double>& out) {
  const std::uint32_t ch = image.channels;
  const float* row = &image.pixels[std::size_t{y} * image.width * ch];
  for (std::uint32_t x = 0; x < image.width; ++x) {
    const float* px = row + std::size_t{x} * ch;
    const double l = ch >= 3 ? 0.2126 * px[0] + 0.7152 * px[1] + 0.0722 * px[2] : static_cast<double>(px[0]);
    out[x] = l - shift;
  }
}

// The value each image's luminance is shifted by before taking moments: its mean, clamped
// into [min, max] so that a constant image shifts to exactly 0.
double moment_shift(const Image& image, std::vector<double>& row) {
  double sum = 0.0, lo = std::numeric_limits<double>::infinity(), hi = -lo;
  for (std::uint32_t y = 0; y < image.height; ++y) {
    luminance_row(image, y, 0.0, row);
    for (const double v : row) {
      sum += v;
      lo = std::min(lo, v);
      hi = std::max(hi, v);
    }
  }
  return std::clamp(sum / (static_cast<double>(image.width) * image.height), lo, hi);
}

// A normalised Gaussian of `size` taps (sigma 1.5) centred on the middle of the taps.
std::vector<double> gaussian(std::uint32_t size) {
  constexpr double sigma = 1.5;
  std::vector<double> g(size);
  const double centre = (static_cast<double>(size) - 1.0) / 2.0;
  double sum = 0.0;
  for (std::uint32_t i = 0; i < size; ++i) {
    const double d = static_cast<double>(i) - centre;
    g[i] = std::exp(-(d * d) / (2.0 * sigma * sigma));
    sum += g[i];
  }
  for (double& v : g) v /= sum;
  return g;
}

}  // namespace

Result<double> rmse(const Image& a, const Image& b) {
  if (auto ok = check_pair(a, b); !ok) return std::unexpected(ok.error());
  return std::sqrt(mean_squared_error(a, b));
}

Result<double> psnr(const Image& a, const Image& b, double peak) {
  if (!(peak > 0.0) || !std::isfinite(peak)) {
    return fail(ErrorKind::InvalidArgument, "PSNR peak must be positive and finite, got {}", peak);
  }
  if (auto ok = check_pair(a, b); !ok) return std::unexpected(ok.error());
  const double mse = mean_squared_error(a, b);
  if (mse == 0.0) return std::numeric_limits<double>::infinity();
  // 20 log10(peak) - 10 log10(mse): no peak^2 that could overflow.
  return 20.0 * std::log10(peak) - 10.0 * std::log10(mse);
}

Result<double> max_abs_diff(const Image& a, const Image& b) {
  if (auto ok = check_pair(a, b); !ok) return std::unexpected(ok.error());
  double largest = 0.0;
  for (std::size_t i = 0; i < a.pixels.size(); ++i) {
    largest = std::max(largest, std::abs(static_cast<double>(a.pixels[i]) - static_cast<double>(b.pixels[i])));
  }
  return largest;
}

// Wang, Bovik, Sheikh, Simoncelli 2004, as in their reference ssim_index.m: Gaussian
// window, "valid" filtering, mean of the SSIM map. Each image's moments are taken about
// its own mean luminance (see moment_shift) to avoid cancellation in E[x^2] - E[x]^2 when
// the images have a large mean; rounding is kept from making variances negative or
// covariances larger than Cauchy-Schwarz allows.
Result<double> ssim(const Image& a, const Image& b, double dynamic_range) {
  if (!(dynamic_range > 0.0) || !std::isfinite(dynamic_range)) {
    return fail(ErrorKind::InvalidArgument, "SSIM dynamic range must be positive and finite, got {}", dynamic_range);
  }
  if (auto ok = check_pair(a, b); !ok) return std::unexpected(ok.error());

  const std::uint32_t w = a.width, h = a.height;
  const double c1 = (0.01 * dynamic_range) * (0.01 * dynamic_range);
  const double c2 = (0.03 * dynamic_range) * (0.03 * dynamic_range);
  // Smaller images shrink the window to fit, keeping sigma 1.5.
  const std::uint32_t wx = std::min<std::uint32_t>(11, w), wy = std::min<std::uint32_t>(11, h);
  const std::vector<double> gx = gaussian(wx), gy = gaussian(wy);
  const std::uint32_t out_w = w - wx + 1, out_h = h - wy + 1;

  std::vector<double> la(w), lb(w);
  const double shift_a = moment_shift(a, la), shift_b = moment_shift(b, lb);

  // Ring of the last wy rows filtered horizontally: 5 moments (a, b, aa, bb, ab) per column.
  std::vector<double> ring(std::size_t{wy} * out_w * 5);
  double total = 0.0;
  for (std::uint32_t y = 0; y < h; ++y) {
    luminance_row(a, y, shift_a, la);
    luminance_row(b, y, shift_b, lb);
    double* row = &ring[std::size_t{y % wy} * out_w * 5];
    for (std::uint32_t x = 0; x < out_w; ++x) {
      double m[5] = {0, 0, 0, 0, 0};
      for (std::uint32_t k = 0; k < wx; ++k) {
        const double g = gx[k], va = la[x + k], vb = lb[x + k];
        m[0] += g * va;
        m[1] += g * vb;
        m[2] += g * (va * va);
        m[3] += g * (vb * vb);
        m[4] += g * (va * vb);  // bracketed: exactly symmetric in a, b
      }
      std::copy(m, m + 5, row + std::size_t{x} * 5);
    }
    if (y + 1 < wy) continue;
    const std::uint32_t top = y + 1 - wy;  // the output row whose window ends at row y
    for (std::uint32_t x = 0; x < out_w; ++x) {
      double m[5] = {0, 0, 0, 0, 0};
      for (std::uint32_t k = 0; k < wy; ++k) {
        const double* src = &ring[(std::size_t{(top + k) % wy} * out_w + x) * 5];
        for (int j = 0; j < 5; ++j) m[j] += gy[k] * src[j];
      }
      const double sa = std::max(0.0, m[2] - m[0] * m[0]);
      const double sb = std::max(0.0, m[3] - m[1] * m[1]);
      // Cauchy-Schwarz bounds the covariance; rounding must not break it.
      const double bound = std::sqrt(sa * sb);
      const double sab = std::clamp(m[4] - m[0] * m[1], -bound, bound);
      const double mu_a = m[0] + shift_a, mu_b = m[1] + shift_b;
      total += ((2.0 * (mu_a * mu_b) + c1) * (2.0 * sab + c2)) / ((mu_a * mu_a + mu_b * mu_b + c1) * (sa + sb + c2));
    }
  }
  return total / (static_cast<double>(out_w) * out_h);
}

}  // namespace weft::image
