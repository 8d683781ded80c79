// The UBO2003 / UTIA direction sampling and direction names for error messages.
module;
#include <array>
#include <string>
#include <cmath>
#include <numbers>
#include <vector>
module weft.btf;

namespace weft::btf {

vec3 to_vector(Direction d) {
  const float s = std::sin(d.theta);
  return {s * std::cos(d.phi), s * std::sin(d.phi), std::cos(d.theta)};
}

std::vector<Direction> ubo2003_directions() {
  constexpr std::array<int, 6> azimuths = {1, 6, 12, 18, 20, 24};
  std::vector<Direction> out;
  out.reserve(81);
  for (std::size_t ring = 0; ring < azimuths.size(); ++ring) {
    const float theta = float(ring) * 15.0f * std::numbers::pi_v<float> / 180.0f;
    for (int k = 0; k < azimuths[ring]; ++k) {
      out.push_back({theta, 2.0f * std::numbers::pi_v<float> * float(k) / float(azimuths[ring])});
    }
  }
  return out;
}

std::string describe(Direction d) {
  return weft::format("θ {:.1f}°, φ {:.1f}°", d.theta * 180.0f / std::numbers::pi_v<float>,
                      d.phi * 180.0f / std::numbers::pi_v<float>);
}

}  // namespace weft::btf
