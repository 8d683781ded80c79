// Scene data to GPU data: meshes into weft's vertex layout, the environment into a float
// texture plus its irradiance SH. Keyed by content so a second frame uploads nothing.
module;
#include <algorithm>
#include <cstdint>
#include <cstring>
#include <expected>
#include <span>
#include <string>
#include <vector>
module weft.renderer;
import weft.core;
import weft.gpu;
import weft.frame;
import weft.image;
import weft.scene;

namespace weft::renderer::detail {

std::uint64_t content_hash(const scene::Environment& env) {
  Hasher h;
  h.value(env.constant_color).value(env.rotation_degrees);
  if (env.map) {
    h.value(env.map->width).value(env.map->height).value(env.map->channels);
    h.bytes(env.map->pixels.data(), env.map->pixels.size() * sizeof(float));
  }
  return h.digest();
}

// RGBA32F texels of the environment (a 4x2 constant when it has no map) and their RGB.
EnvironmentTexels environment_texels(const scene::Environment& env) {
  EnvironmentTexels t;
  if (env.map && env.map->width > 0 && env.map->height > 0) {
    const auto& m = *env.map;
    t.width = m.width;
    t.height = m.height;
    t.rgba.resize(std::size_t(m.width) * m.height);
    t.rgb.resize(t.rgba.size() * 3);
    for (std::size_t i = 0; i < t.rgba.size(); ++i) {
      vec3 c{0.0f};
      for (std::uint32_t k = 0; k < std::min(3u, m.channels); ++k) c[k] = m.pixels[i * m.channels + k];
      if (m.channels == 1) c = vec3(c.x);
      t.rgba[i] = vec4(c, 1.0f);
      std::memcpy(&t.rgb[i * 3], &c, sizeof(c));
    }
  } else {
    t.rgba.assign(8, vec4(env.constant_color, 1.0f));
    t.rgb.resize(24);
    for (std::size_t i = 0; i < 8; ++i) std::memcpy(&t.rgb[i * 3], &env.constant_color, sizeof(vec3));
  }
  return t;
}

}  // namespace weft::renderer::detail
