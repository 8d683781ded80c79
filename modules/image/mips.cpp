// Mip chains of 8-bit textures, made on the CPU when a texture is loaded: exact (a box over
// the texels above, in linear light for sRGB colour, renormalised for normal maps) and the
// same on every adapter, which a GPU blit chain is not (it filters sRGB as the driver does
// and cannot renormalise).
module;
#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>
module weft.image;

namespace weft::image {

namespace {

// A source range [begin, end) per destination texel along one axis: 2x and 2x + 1, and the
// last destination texel of an odd side also takes the texel that would be left over.
struct Span {
  std::uint32_t begin, end;
};
std::vector<Span> spans(std::uint32_t source, std::uint32_t destination) {
  std::vector<Span> out(destination);
  for (std::uint32_t x = 0; x < destination; ++x) {
    const std::uint32_t b = std::min(2 * x, source - 1);
    const std::uint32_t e = x + 1 == destination ? source : std::min(2 * x + 2, source);
    out[x] = {b, std::max(e, b + 1)};
  }
  return out;
}

std::uint8_t to_byte(float v) { return std::uint8_t(std::clamp(std::lround(v * 255.0f), 0L, 255L)); }

// One level from the one above, as floats in the space they are averaged in.
std::vector<float> downsample(const std::vector<float>& above, std::uint32_t w, std::uint32_t h, std::uint32_t nw,
                              std::uint32_t nh) {
  const auto xs = spans(w, nw), ys = spans(h, nh);
  std::vector<float> out(std::size_t(nw) * nh * 4);
  for (std::uint32_t y = 0; y < nh; ++y)
    for (std::uint32_t x = 0; x < nw; ++x) {
      std::array<double, 4> sum{};
      for (std::uint32_t sy = ys[y].begin; sy < ys[y].end; ++sy)
        for (std::uint32_t sx = xs[x].begin; sx < xs[x].end; ++sx)
          for (int c = 0; c < 4; ++c) sum[c] += above[(std::size_t(sy) * w + sx) * 4 + c];
      const double n = double(ys[y].end - ys[y].begin) * double(xs[x].end - xs[x].begin);
      for (int c = 0; c < 4; ++c) out[(std::size_t(y) * nw + x) * 4 + c] = float(sum[c] / n);
    }
  return out;
}

}  // namespace

std::uint32_t full_mip_count(std::uint32_t width, std::uint32_t height) {
  std::uint32_t levels = 1;
  for (std::uint32_t side = std::max(width, height); side > 1; side /= 2) ++levels;
  return levels;
}

std::vector<std::vector<std::uint8_t>> rgba8_mip_chain(std::span<const std::uint8_t> rgba, std::uint32_t width,
                                                       std::uint32_t height, MipContent content) {
  if (width == 0 || height == 0 || rgba.size() != std::size_t(width) * height * 4) return {};
  std::array<float, 256> decode{};
  for (int i = 0; i < 256; ++i) decode[i] = content == MipContent::Srgb ? srgb_to_linear(float(i) / 255.0f) : float(i) / 255.0f;
  // Level 0 as floats in the averaging space (linear light, or as stored); alpha is linear.
  std::vector<float> level(rgba.size());
  for (std::size_t i = 0; i < rgba.size(); ++i) level[i] = i % 4 == 3 ? float(rgba[i]) / 255.0f : decode[rgba[i]];
  std::vector<std::vector<std::uint8_t>> chain;
  chain.emplace_back(rgba.begin(), rgba.end());
  std::uint32_t w = width, h = height;
  while (w > 1 || h > 1) {
    const std::uint32_t nw = std::max(1u, w / 2), nh = std::max(1u, h / 2);
    level = downsample(level, w, h, nw, nh);
    std::vector<std::uint8_t> bytes(level.size());
    for (std::size_t t = 0; t < std::size_t(nw) * nh; ++t) {
      float* v = &level[t * 4];
      if (content == MipContent::NormalMap) {
        // The average of unit normals is shorter than one where they disagree; renormalise
        // (a flat (0, 0, 1) where they cancel), so lighting sees a normal, not a shrunk one.
        float n[3] = {v[0] * 2.0f - 1.0f, v[1] * 2.0f - 1.0f, v[2] * 2.0f - 1.0f};
        const float length = std::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
        if (length > 1e-6f)
          for (float& c : n) c /= length;
        else
          n[0] = n[1] = 0.0f, n[2] = 1.0f;
        // The renormalised value also feeds the next level: each level is the average of
        // unit normals from the one above.
        for (int c = 0; c < 3; ++c) v[c] = n[c] * 0.5f + 0.5f;
      }
      for (int c = 0; c < 4; ++c)
        bytes[t * 4 + c] = to_byte(content == MipContent::Srgb && c < 3 ? linear_to_srgb(v[c]) : v[c]);
    }
    chain.push_back(std::move(bytes));
    w = nw;
    h = nh;
  }
  return chain;
}

std::vector<std::vector<float>> rgba32f_mip_chain(std::span<const float> rgba, std::uint32_t width,
                                                 std::uint32_t height) {
  if (width == 0 || height == 0 || rgba.size() != std::size_t(width) * height * 4) return {};
  std::vector<std::vector<float>> chain;
  chain.emplace_back(rgba.begin(), rgba.end());
  std::uint32_t w = width, h = height;
  while (w > 1 || h > 1) {
    const std::uint32_t nw = std::max(1u, w / 2), nh = std::max(1u, h / 2);
    chain.push_back(downsample(chain.back(), w, h, nw, nh));
    w = nw;
    h = nh;
  }
  return chain;
}

}  // namespace weft::image
