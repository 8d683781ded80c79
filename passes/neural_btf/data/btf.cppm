// weft.btf — a bidirectional texture function as data: per texel, the RGB reflectance for
// every measured (light, view) direction pair (the texel's "ABRDF"). Directions are in the
// surface's tangent frame (z = normal). No GPU: loaders, the synthetic generator,
// preprocessing and clustering run in bakes, tests and benchmarks.
module;
#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>
export module weft.btf;
import weft.core;

export namespace weft::btf {

// A direction in the tangent frame: θ from the normal (0 … π/2), φ around it (radians).
struct Direction {
  float theta = 0.0f;
  float phi = 0.0f;
};
[[nodiscard]] vec3 to_vector(Direction d);  // unit, z = cos θ

// The UBO2003 / UTIA sampling: θ = 0°, 15°, …, 75° with 1, 6, 12, 18, 20, 24 azimuths
// (81 directions), φ evenly spaced from 0. Used for both lights and views.
[[nodiscard]] std::vector<Direction> ubo2003_directions();

// Linear RGB samples, texel-major: rgb[((texel * lights + l) * views + v) * 3 + c], with
// texel = y * width + x. One texel's block of lights * views * 3 floats is its ABRDF.
struct Btf {
  std::uint32_t width = 0, height = 0;
  std::vector<Direction> lights, views;
  std::vector<float> rgb;

  [[nodiscard]] std::size_t texels() const { return std::size_t(width) * height; }
  [[nodiscard]] std::size_t samples_per_texel() const { return lights.size() * views.size(); }
  [[nodiscard]] std::size_t abrdf_floats() const { return samples_per_texel() * 3; }
  [[nodiscard]] std::span<const float> abrdf(std::size_t texel) const {
    return std::span<const float>(rgb).subspan(texel * abrdf_floats(), abrdf_floats());
  }
  [[nodiscard]] std::span<float> abrdf(std::size_t texel) {
    return std::span<float>(rgb).subspan(texel * abrdf_floats(), abrdf_floats());
  }
};

}  // namespace weft::btf
