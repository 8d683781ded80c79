// The environment light: loading an equirectangular map and looking it up on the CPU.
module;
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <expected>
#include <filesystem>
#include <optional>
#include <string>
#include <utility>
#include <vector>
#include <glm/glm.hpp>
module weft.scene;
import weft.core;
import weft.image;

namespace weft::scene {
namespace {

constexpr float two_pi = 6.28318530717958647692f;

}  // namespace

vec2 equirect_uv(const vec3& direction, float rotation_degrees) {
  const float len = glm::length(direction);
  const vec3 d = len > 0.0f ? direction / len : vec3(0.0f, 1.0f, 0.0f);
  const float rot = glm::radians(rotation_degrees);
  const float c = std::cos(rot), s = std::sin(rot);
  const vec3 r{c * d.x + s * d.z, d.y, -s * d.x + c * d.z};
  return {std::atan2(r.z, r.x) / two_pi + 0.5f, std::acos(std::clamp(r.y, -1.0f, 1.0f)) / pi};
}

vec3 equirect_direction(const vec2& uv, float rotation_degrees) {
  const float phi = (uv.x - 0.5f) * two_pi;
  const float theta = uv.y * pi;
  const vec3 r{std::sin(theta) * std::cos(phi), std::cos(theta), std::sin(theta) * std::sin(phi)};
  const float rot = glm::radians(rotation_degrees);
  const float c = std::cos(rot), s = std::sin(rot);
  return {c * r.x - s * r.z, r.y, s * r.x + c * r.z};
}

vec3 Environment::radiance(const vec3& direction) const {
  if (!map || map->width == 0 || map->height == 0 || map->channels < 3 || map->pixels.size() < map->sample_count()) {
    return constant_color * intensity;
  }
  const vec2 uv = equirect_uv(direction, rotation_degrees);
  const image::Image& img = *map;
  // Bilinear between texel centres: wraps around in u, clamps at the poles in v.
  const float x = uv.x * float(img.width) - 0.5f;
  const float y = std::clamp(uv.y * float(img.height) - 0.5f, 0.0f, float(img.height - 1));
  const float fx = std::floor(x), fy = std::floor(y);
  const float tx = x - fx, ty = y - fy;
  const auto w = static_cast<std::int64_t>(img.width);
  const auto wrap = [&](std::int64_t v) { return static_cast<std::uint32_t>(((v % w) + w) % w); };
  const std::uint32_t x0 = wrap(static_cast<std::int64_t>(fx)), x1 = wrap(static_cast<std::int64_t>(fx) + 1);
  const auto y0 = static_cast<std::uint32_t>(fy);
  const std::uint32_t y1 = std::min(y0 + 1, img.height - 1);
  const auto texel = [&](std::uint32_t px, std::uint32_t py) {
    return vec3(img.at(px, py, 0), img.at(px, py, 1), img.at(px, py, 2));
  };
  const vec3 top = glm::mix(texel(x0, y0), texel(x1, y0), tx);
  const vec3 bottom = glm::mix(texel(x0, y1), texel(x1, y1), tx);
  return glm::mix(top, bottom, ty) * intensity;
}

Result<Environment> load_environment(const std::filesystem::path& path) {
  auto loaded = image::load_float_image(path);
  if (!loaded) return with_context(weft::format("environment map '{}'", path.string()), loaded.error());
  image::Image& src = *loaded;
  if (auto ok = image::validate(src); !ok) return with_context(weft::format("environment map '{}'", path.string()), ok.error());
  image::Image rgb = image::Image::filled(src.width, src.height, 3);
  std::size_t repaired = 0;
  for (std::uint32_t y = 0; y < src.height; ++y) {
    for (std::uint32_t x = 0; x < src.width; ++x) {
      for (std::uint32_t c = 0; c < 3; ++c) {
        const std::uint32_t from = src.channels >= 3 ? c : 0;  // gray (and gray+alpha) to RGB
        float v = src.at(x, y, from);
        if (!std::isfinite(v) || v < 0.0f) {
          v = 0.0f;
          ++repaired;
        }
        rgb.at(x, y, c) = v;
      }
    }
  }
  if (repaired > 0) {
    log::warn(weft::format("environment map '{}': {} NaN, infinite or negative samples set to 0", path.string(), repaired));
  }
  Environment env;
  env.map = std::move(rgb);
  env.source = path;
  return env;
}

}  // namespace weft::scene
