// The pass's shading on the CPU: the tabulated clamped-cosine response of a spherical
// Gaussian, the lobe visibility from the SSDF at its centre, and the diffuse sum. The
// shaders (pass/ssdf_common.glsl) implement the same formulas on the same table.
module;
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <numbers>
#include <span>
#include <vector>
#include <glm/glm.hpp>
module weft.ssdf;

namespace weft::ssdf {

double sg_cosine_response(double sharpness, double cosine, std::uint32_t steps) {
  const double t = std::clamp(cosine, -1.0, 1.0);
  if (std::isinf(sharpness)) return std::max(t, 0.0);
  const double s = std::sqrt(std::max(0.0, 1.0 - t * t));
  double sum = 0.0;
  const double dtheta = std::numbers::pi / steps;
  for (std::uint32_t i = 0; i < steps; ++i) {
    const double theta = (i + 0.5) * dtheta;
    const double a = t * std::cos(theta), b = s * std::sin(theta);
    // ∫_0^{2π} max(a + b cos φ, 0) dφ in closed form.
    double azimuthal;
    if (b <= std::abs(a)) {
      azimuthal = a > 0.0 ? 2.0 * std::numbers::pi * a : 0.0;
    } else {
      const double phi0 = std::acos(std::clamp(-a / b, -1.0, 1.0));
      azimuthal = 2.0 * (a * phi0 + b * std::sin(phi0));
    }
    sum += std::exp(sharpness * (std::cos(theta) - 1.0)) * std::sin(theta) * azimuthal * dtheta;
  }
  return sum / sg_integral(sharpness);
}

const IrradianceTable& irradiance_table() {
  static const IrradianceTable table = [] {
    IrradianceTable t;
    t.values.resize(std::size_t(IrradianceTable::rows) * IrradianceTable::columns);
    for (std::uint32_t r = 0; r < IrradianceTable::rows; ++r) {
      const double u = double(r) / (IrradianceTable::rows - 1);
      const double sharpness = r + 1 == IrradianceTable::rows ? std::numeric_limits<double>::infinity()
                                                               : IrradianceTable::sharpness_midpoint * u / (1.0 - u);
      for (std::uint32_t c = 0; c < IrradianceTable::columns; ++c) {
        const double cosine = -1.0 + 2.0 * double(c) / (IrradianceTable::columns - 1);
        t.values[std::size_t(r) * IrradianceTable::columns + c] = float(sg_cosine_response(sharpness, cosine));
      }
    }
    return t;
  }();
  return table;
}

float IrradianceTable::lookup(float sharpness, float cosine) const {
  const float u = std::isinf(sharpness) ? 1.0f : std::max(sharpness, 0.0f) / (std::max(sharpness, 0.0f) + sharpness_midpoint);
  const float x = std::clamp(u, 0.0f, 1.0f) * float(rows - 1);
  const float y = (std::clamp(cosine, -1.0f, 1.0f) * 0.5f + 0.5f) * float(columns - 1);
  const auto x0 = std::min(std::uint32_t(x), rows - 2), y0 = std::min(std::uint32_t(y), columns - 2);
  const float tx = x - float(x0), ty = y - float(y0);
  auto at = [&](std::uint32_t r, std::uint32_t c) { return values[std::size_t(r) * columns + c]; };
  return (at(x0, y0) * (1.0f - ty) + at(x0, y0 + 1) * ty) * (1.0f - tx) +
         (at(x0 + 1, y0) * (1.0f - ty) + at(x0 + 1, y0 + 1) * ty) * tx;
}

vec3 sg_irradiance(const SphericalGaussian& lobe, const vec3& normal) {
  return energy(lobe) * irradiance_table().lookup(lobe.sharpness, glm::dot(lobe.axis, normal));
}

float boundary_distance(float ssdf, float half_spacing) {
  const float a = std::abs(ssdf);
  return std::copysign(std::max(a - half_spacing, 0.5f * a), ssdf);
}

float lobe_visibility(float distance, float sharpness) {
  const float w = sharpness > 0.0f ? std::min(1.88f / std::sqrt(sharpness), 0.5f * pi) : 0.5f * pi;
  const float x = std::clamp((distance + w) / (2.0f * w), 0.0f, 1.0f);
  return x * x * (3.0f - 2.0f * x);
}

vec3 shade_diffuse(std::span<const SphericalGaussian> lobes, std::span<const float> ssdf, const vec3& normal,
                   float half_spacing) {
  vec3 sum(0.0f);
  for (std::size_t j = 0; j < lobes.size() && j < ssdf.size(); ++j)
    sum += sg_irradiance(lobes[j], normal) * lobe_visibility(boundary_distance(ssdf[j], half_spacing), lobes[j].sharpness);
  return sum / pi;
}

void ssdf_at_lobes(std::span<const float> row, const DirectionGrid& grid, std::span<const SphericalGaussian> lobes,
                   std::span<float> out) {
  for (std::size_t j = 0; j < lobes.size() && j < out.size(); ++j) {
    const auto taps = grid.bilinear(lobes[j].axis);
    float d = 0.0f;
    for (std::size_t t = 0; t < 4; ++t) d += taps.weights[t] * row[taps.cells[t]];
    out[j] = d;
  }
}

void ssdf_at_lobes(const cluster::Cpca& cpca, std::size_t row, const DirectionGrid& grid,
                   std::span<const SphericalGaussian> lobes, std::span<float> out) {
  std::vector<float> values(cpca.cols);
  cluster::reconstruct_row(cpca, row, values);
  ssdf_at_lobes(values, grid, lobes, out);
}

}  // namespace weft::ssdf
