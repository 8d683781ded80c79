// The CPU side of shell fur: the photo's luminance histogram and robust thresholds, the band
// table of equation 4, the hair orientation from the photo's streaks, the naive method's
// per-layer textures, and a procedural fur photo.
module;
#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <expected>
#include <limits>
#include <numeric>
#include <random>
#include <span>
#include <string>
#include <string_view>
#include <vector>
#include <glm/glm.hpp>
module weft.pass.shell_fur;

namespace weft::fur {

namespace {

// The exact sRGB curves in double precision (IEC 61966-2-1).
double srgb_decode(double e) {
  e = std::clamp(e, 0.0, 1.0);
  return e <= 0.04045 ? e / 12.92 : std::pow((e + 0.055) / 1.055, 2.4);
}
double srgb_encode(double l) {
  l = std::clamp(l, 0.0, 1.0);
  return l <= 0.0031308 ? 12.92 * l : 1.055 * std::pow(l, 1.0 / 2.4) - 0.055;
}

const std::array<double, 256>& decode_table() {
  static const std::array<double, 256> table = [] {
    std::array<double, 256> t{};
    for (int i = 0; i < 256; ++i) t[i] = srgb_decode(i / 255.0);
    return t;
  }();
  return table;
}

std::uint8_t to_code(double unit) { return std::uint8_t(std::lround(std::clamp(unit, 0.0, 1.0) * 255.0)); }

// The code at a fraction of the histogram's mass (nearest rank over the sorted texels).
std::uint8_t percentile_code(const std::array<std::uint64_t, 256>& histogram, std::uint64_t total, double p) {
  const auto rank = std::uint64_t(std::floor(p * double(total - 1)));  // 0-based
  std::uint64_t cumulative = 0;
  for (int c = 0; c < 256; ++c) {
    cumulative += histogram[c];
    if (cumulative > rank) return std::uint8_t(c);
  }
  return 255;
}

// Otsu's best between-class variance over the total variance.
double otsu_separability(const std::array<std::uint64_t, 256>& histogram, std::uint64_t total) {
  double mean = 0.0, second = 0.0;
  for (int c = 0; c < 256; ++c) {
    mean += double(c) * double(histogram[c]);
    second += double(c) * double(c) * double(histogram[c]);
  }
  mean /= double(total);
  const double variance = second / double(total) - mean * mean;
  if (!(variance > 1e-12)) return 0.0;
  double best = 0.0, w0 = 0.0, sum0 = 0.0;
  for (int t = 0; t < 255; ++t) {
    w0 += double(histogram[t]) / double(total);
    sum0 += double(t) * double(histogram[t]) / double(total);
    const double w1 = 1.0 - w0;
    if (w0 <= 0.0 || w1 <= 0.0) continue;
    const double m0 = sum0 / w0, m1 = (mean - sum0) / w1;
    best = std::max(best, w0 * w1 * (m0 - m1) * (m0 - m1));
  }
  return std::clamp(best / variance, 0.0, 1.0);
}

// Separable Gaussian blur of a float image, clamped at the borders.
void blur(std::vector<float>& image, std::uint32_t w, std::uint32_t h, float sigma) {
  const int radius = std::max(1, int(std::ceil(3.0f * sigma)));
  std::vector<float> kernel(std::size_t(2 * radius + 1));
  float sum = 0.0f;
  for (int i = -radius; i <= radius; ++i) sum += kernel[std::size_t(i + radius)] = std::exp(-0.5f * float(i * i) / (sigma * sigma));
  for (auto& k : kernel) k /= sum;
  std::vector<float> tmp(image.size());
  for (std::uint32_t y = 0; y < h; ++y)
    for (std::uint32_t x = 0; x < w; ++x) {
      float acc = 0.0f;
      for (int i = -radius; i <= radius; ++i) {
        const int xx = std::clamp(int(x) + i, 0, int(w) - 1);
        acc += kernel[std::size_t(i + radius)] * image[std::size_t(y) * w + std::size_t(xx)];
      }
      tmp[std::size_t(y) * w + x] = acc;
    }
  for (std::uint32_t y = 0; y < h; ++y)
    for (std::uint32_t x = 0; x < w; ++x) {
      float acc = 0.0f;
      for (int i = -radius; i <= radius; ++i) {
        const int yy = std::clamp(int(y) + i, 0, int(h) - 1);
        acc += kernel[std::size_t(i + radius)] * tmp[std::size_t(yy) * w + x];
      }
      image[std::size_t(y) * w + x] = acc;
    }
}

// Structure tensor of the luminance codes: the hair runs along the direction of least
// change. Stored as the double angle of the hair direction times the coherence.
std::vector<std::uint8_t> hair_orientation(const std::vector<std::uint8_t>& rgba, std::uint32_t w, std::uint32_t h) {
  auto lum = [&](int x, int y) {
    x = std::clamp(x, 0, int(w) - 1);
    y = std::clamp(y, 0, int(h) - 1);
    return float(rgba[(std::size_t(y) * w + std::size_t(x)) * 4 + 3]);
  };
  const std::size_t n = std::size_t(w) * h;
  std::vector<float> jxx(n), jxy(n), jyy(n);
  for (std::uint32_t y = 0; y < h; ++y)
    for (std::uint32_t x = 0; x < w; ++x) {
      const int X = int(x), Y = int(y);
      const float gx = (lum(X + 1, Y - 1) + 2 * lum(X + 1, Y) + lum(X + 1, Y + 1)) -
                       (lum(X - 1, Y - 1) + 2 * lum(X - 1, Y) + lum(X - 1, Y + 1));
      const float gy = (lum(X - 1, Y + 1) + 2 * lum(X, Y + 1) + lum(X + 1, Y + 1)) -
                       (lum(X - 1, Y - 1) + 2 * lum(X, Y - 1) + lum(X + 1, Y - 1));
      const std::size_t i = std::size_t(y) * w + x;
      jxx[i] = gx * gx;
      jxy[i] = gx * gy;
      jyy[i] = gy * gy;
    }
  const float sigma = std::clamp(float(std::min(w, h)) / 128.0f, 1.0f, 3.0f);
  blur(jxx, w, h, sigma);
  blur(jxy, w, h, sigma);
  blur(jyy, w, h, sigma);
  std::vector<std::uint8_t> out(n * 2);
  for (std::size_t i = 0; i < n; ++i) {
    // Gradient double angle (jxx - jyy, 2 jxy); the hair is perpendicular: its double angle
    // is the opposite vector. |vector| / trace is the coherence in [0, 1].
    const float trace = jxx[i] + jyy[i];
    float vx = 0.0f, vy = 0.0f;
    if (trace > 1e-6f) {
      vx = -(jxx[i] - jyy[i]) / trace;
      vy = -(2.0f * jxy[i]) / trace;
    }
    out[2 * i] = to_code(vx * 0.5 + 0.5);
    out[2 * i + 1] = to_code(vy * 0.5 + 0.5);
  }
  return out;
}

}  // namespace

std::uint8_t fur_luminance_code(std::uint8_t r, std::uint8_t g, std::uint8_t b) {
  const auto& lin = decode_table();
  const double y = 0.2126 * lin[r] + 0.7152 * lin[g] + 0.0722 * lin[b];
  return to_code(srgb_encode(y));
}

double fur_code_to_luminance(double code) {
  if (code >= 0.0 && code <= 255.0 && code == std::floor(code)) return decode_table()[std::size_t(code)];
  return srgb_decode(code / 255.0);
}

double fur_luminance_floor() { return fur_code_to_luminance(0.5); }

Result<FurPhoto> analyze_fur_photo(const image::Image8& photo, const FurThresholds& thresholds) {
  if (auto ok = image::validate(photo); !ok) return with_context("fur photo", ok.error());
  const double lo = thresholds.low_percentile, hi = thresholds.high_percentile;
  if (!(lo >= 0.0 && hi <= 1.0 && lo < hi))
    return fail(ErrorKind::InvalidArgument, "fur photo: percentiles ({}, {}) must satisfy 0 <= low < high <= 1", lo, hi);
  FurPhoto out;
  out.width = photo.width;
  out.height = photo.height;
  const std::size_t n = out.texel_count();
  out.rgba.resize(n * 4);
  const std::uint32_t c = photo.channels;
  for (std::size_t i = 0; i < n; ++i) {
    const std::uint8_t* p = &photo.pixels[i * c];
    const std::uint8_t r = p[0], g = c >= 3 ? p[1] : p[0], b = c >= 3 ? p[2] : p[0];
    const std::uint8_t code = fur_luminance_code(r, g, b);
    out.rgba[i * 4 + 0] = r;
    out.rgba[i * 4 + 1] = g;
    out.rgba[i * 4 + 2] = b;
    out.rgba[i * 4 + 3] = code;
    ++out.histogram[code];
  }
  out.code_min = percentile_code(out.histogram, n, lo);
  out.code_max = percentile_code(out.histogram, n, hi);
  out.i_min = fur_code_to_luminance(out.code_min);
  out.i_max = fur_code_to_luminance(out.code_max);
  if (out.i_min < fur_luminance_floor()) {
    out.notes.push_back(weft::format("I_min is black at the {}% percentile; raised to half a code ({:.3g}) so the "
                                     "attenuation ln(I_max/I_min) stays finite",
                                     lo * 100.0, fur_luminance_floor()));
    out.i_min = fur_luminance_floor();
  }
  if (out.i_max < out.i_min) out.i_max = out.i_min;
  if (out.i_max == out.i_min)
    out.notes.push_back("I_max = I_min: the photo has no luminance contrast (a = 0), so every texel sits in the top layer");
  out.bimodality = otsu_separability(out.histogram, n);
  out.orientation = hair_orientation(out.rgba, out.width, out.height);
  return out;
}

std::string_view to_string(FurLayout layout) { return layout == FurLayout::Band ? "band" : "strand"; }

std::uint32_t FurBandTable::depth_layer(std::uint8_t code) const {
  for (std::uint32_t n = 0; n < layers; ++n)
    if (code >= first_code[n]) return n;
  return layers;
}

bool FurBandTable::keeps(std::uint32_t layer, std::uint8_t code) const {
  if (layer >= layers) return layer == layers;  // the skin is opaque
  const std::uint32_t own = depth_layer(code);
  return layout == FurLayout::Band ? own == layer : own <= layer;
}

Result<FurBandTable> make_band_table(double i_max, double i_min, std::uint32_t layers, FurLayout layout) {
  if (layers < 1 || layers > max_fur_layers)
    return fail(ErrorKind::InvalidArgument, "fur band table: {} layers is outside 1..{}", layers, max_fur_layers);
  if (!(std::isfinite(i_max) && std::isfinite(i_min) && i_min > 0.0 && i_min <= i_max))
    return fail(ErrorKind::InvalidArgument, "fur band table: need finite 0 < I_min <= I_max, got I_min = {}, I_max = {}",
                i_min, i_max);
  FurBandTable t;
  t.layers = layers;
  t.layout = layout;
  t.i_max = i_max;
  t.i_min = i_min;
  t.boundaries.resize(layers + 1);
  const double ratio = i_min / i_max;
  for (std::uint32_t n = 0; n <= layers; ++n) t.boundaries[n] = i_max * std::pow(ratio, double(n) / double(layers));
  t.boundaries[0] = i_max;
  t.boundaries[layers] = i_min;
  const auto& lum = decode_table();
  t.first_code.resize(layers + 1);
  for (std::uint32_t n = 0; n < layers; ++n) {
    std::uint16_t c = 0;
    while (c < 256 && lum[c] < t.boundaries[n]) ++c;
    t.first_code[n] = c;
  }
  t.first_code[layers] = 0;
  t.gpu.resize(layers + 1);
  for (std::uint32_t n = 0; n <= layers; ++n) {
    FurGpuLayer& g = t.gpu[n];
    const bool skin = n == layers;
    g.keep_min = skin ? -1.0f : (float(t.first_code[n]) - 0.5f) / 255.0f;
    g.keep_max = (skin || n == 0 || layout == FurLayout::Strand) ? 2.0f : (float(t.first_code[n - 1]) - 0.5f) / 255.0f;
    // The band's top I(n-1) itself, as a fractional alpha (its sRGB curve), so the shader's
    // code_to_luminance(top) gives I(n-1) back. Not the half-code keep threshold below
    // first_code[n-1]: darkening to that would take texels at the boundary half a code
    // (0.6-0.7 % in linear) below their own luminance, e.g. every strand layer under a
    // uniform photo, where I(n) = I_max for all n. The darkening factor is 1 at the top,
    // so a code on either side of it after float rounding is drawn the same.
    g.top = n == 0 ? 2.0f : float(srgb_encode(t.boundaries[n - 1]));
    g.height = float(layers - n) / float(layers);
  }
  return t;
}

std::vector<std::uint64_t> depth_layer_counts(const FurPhoto& photo, const FurBandTable& table) {
  std::vector<std::uint64_t> counts(table.layers + 1, 0);
  for (int c = 0; c < 256; ++c) counts[table.depth_layer(std::uint8_t(c))] += photo.histogram[std::size_t(c)];
  return counts;
}

double fur_attenuation(double i_max, double i_min, double thickness) {
  const double log_ratio = std::log(i_max / i_min);
  if (!(log_ratio > 0.0)) return 0.0;
  if (!(thickness > 0.0)) return std::numeric_limits<double>::infinity();
  return log_ratio / thickness;
}

std::vector<std::vector<std::uint8_t>> make_shell_textures(const FurPhoto& photo, const FurBandTable& table) {
  const auto& lin = decode_table();
  const std::size_t n = photo.texel_count();
  std::vector<std::vector<std::uint8_t>> layers(table.layers + 1, std::vector<std::uint8_t>(n * 4, 0));
  for (std::uint32_t layer = 0; layer <= table.layers; ++layer) {
    auto& out = layers[layer];
    const double top = double(table.gpu[layer].top) * 255.0;
    // Every texel gets its colour (as drawn in this layer) so bilinear filtering never blends
    // in black from texels the layer does not keep; alpha says which it keeps.
    for (std::size_t i = 0; i < n; ++i) {
      const std::uint8_t code = photo.code(i);
      const double factor = std::min(1.0, fur_code_to_luminance(top) / lin[code]);
      for (int k = 0; k < 3; ++k) {
        const std::uint8_t v = photo.rgba[i * 4 + std::size_t(k)];
        out[i * 4 + std::size_t(k)] = factor == 1.0 ? v : to_code(srgb_encode(lin[v] * factor));
      }
      out[i * 4 + 3] = table.keeps(layer, code) ? 255 : 0;
    }
  }
  return layers;
}

image::Image8 synthesize_fur_photo(const FurSynthesis& s) {
  const std::uint32_t w = std::max(1u, s.width), h = std::max(1u, s.height);
  std::mt19937 rng(s.seed);
  std::uniform_real_distribution<float> unit(0.0f, 1.0f);
  // Linear RGB accumulation; the undercoat is the deepest, darkest layer.
  std::vector<vec3> rgb(std::size_t(w) * h);
  for (auto& p : rgb) p = s.color * (0.03f + 0.02f * unit(rng));
  struct Hair {
    float height;
    vec2 root;
  };
  const double hair_area = std::max(1e-3, double(s.hair_length) * double(s.hair_width));
  const auto count = std::size_t(std::clamp(double(s.coverage) * double(w) * double(h) / hair_area, 0.0, 1e7));
  std::vector<Hair> hairs(count);
  for (auto& hair : hairs) hair = {unit(rng), vec2(unit(rng) * float(w), unit(rng) * float(h))};
  std::sort(hairs.begin(), hairs.end(), [](const Hair& a, const Hair& b) { return a.height < b.height; });
  const float flow = s.flow_degrees * pi / 180.0f;
  const float phase = unit(rng) * 2.0f * pi;
  const float contrast = std::log(25.0f);  // I_max / I_min of the synthetic medium
  for (const Hair& hair : hairs) {
    // Light reaching a hair falls off exponentially with its depth below the tips.
    const vec3 color = s.color * std::exp(-contrast * (1.0f - hair.height)) * (0.85f + 0.3f * unit(rng));
    const float length = s.hair_length * (0.6f + 0.8f * unit(rng));
    vec2 p = hair.root;
    // Whole periods across the image, so the flow tiles like the strokes do.
    float angle = flow + s.flow_waviness * std::sin(2.0f * pi * (p.x / float(w) + 2.0f * p.y / float(h)) + phase) +
                  0.25f * (unit(rng) - 0.5f);
    const float bend = 0.04f * (unit(rng) - 0.5f);
    const float step = 0.35f;
    for (float t = 0.0f; t < length; t += step) {
      const float radius = 0.5f * s.hair_width * (1.0f - 0.7f * t / length);
      const int r = int(std::ceil(radius + 1.0f));
      for (int dy = -r; dy <= r; ++dy)
        for (int dx = -r; dx <= r; ++dx) {
          const float fx = std::floor(p.x) + float(dx) + 0.5f, fy = std::floor(p.y) + float(dy) + 0.5f;
          const float coverage = std::clamp(radius + 0.5f - glm::length(vec2(fx, fy) - p), 0.0f, 1.0f);
          if (coverage <= 0.0f) continue;
          // Wrap around so the photo tiles under repeat.
          const int x = ((int(fx) % int(w)) + int(w)) % int(w), y = ((int(fy) % int(h)) + int(h)) % int(h);
          vec3& dst = rgb[std::size_t(y) * w + std::size_t(x)];
          dst = glm::mix(dst, color, coverage);
        }
      p += step * vec2(std::cos(angle), std::sin(angle));
      angle += bend;
    }
  }
  image::Image8 out = image::Image8::filled(w, h, 3);
  for (std::size_t i = 0; i < rgb.size(); ++i)
    for (int k = 0; k < 3; ++k) out.pixels[i * 3 + std::size_t(k)] = to_code(srgb_encode(rgb[i][k]));
  return out;
}

}  // namespace weft::fur
