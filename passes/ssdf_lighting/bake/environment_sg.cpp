// The environment as N spherical Gaussians: texel blocks carrying their exact energy are
// clustered on the sphere (weighted k-means, k-means++ seeding), one lobe per cluster with
// the cluster's exact energy and a von Mises–Fisher sharpness from its spread.
module;
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <expected>
#include <limits>
#include <numbers>
#include <random>
#include <span>
#include <vector>
#include <glm/glm.hpp>
module weft.ssdf;

namespace weft::ssdf {

double sg_integral(double sharpness) {
  if (!(sharpness > 1e-8)) return 4.0 * std::numbers::pi;
  return -2.0 * std::numbers::pi * std::expm1(-2.0 * sharpness) / sharpness;
}

vec3 evaluate(const SphericalGaussian& lobe, const vec3& direction) {
  return lobe.amplitude * std::exp(lobe.sharpness * (glm::dot(lobe.axis, glm::normalize(direction)) - 1.0f));
}

vec3 evaluate(std::span<const SphericalGaussian> lobes, const vec3& direction) {
  vec3 sum(0.0f);
  for (const auto& lobe : lobes) sum += evaluate(lobe, direction);
  return sum;
}

vec3 energy(const SphericalGaussian& lobe) { return lobe.amplitude * float(sg_integral(lobe.sharpness)); }

vec3 energy(std::span<const SphericalGaussian> lobes) {
  glm::dvec3 sum(0.0);
  for (const auto& lobe : lobes) sum += glm::dvec3(lobe.amplitude) * sg_integral(lobe.sharpness);
  return vec3(sum);
}

namespace {

// Solid angle of a texel in row y of an equirectangular map (rows are bands of θ).
double texel_solid_angle(std::uint32_t y, std::uint32_t width, std::uint32_t height) {
  const double t0 = std::numbers::pi * y / height, t1 = std::numbers::pi * (y + 1) / height;
  return 2.0 * std::numbers::pi / width * (std::cos(t0) - std::cos(t1));
}

double luminance(const glm::dvec3& c) { return 0.2126 * c.x + 0.7152 * c.y + 0.0722 * c.z; }

// The mean resultant length of a von Mises–Fisher distribution: A(κ) = coth κ − 1/κ.
double mean_resultant(double kappa) {
  if (kappa < 1e-3) return kappa / 3.0 - kappa * kappa * kappa / 45.0;
  if (kappa > 20.0) return 1.0 - 1.0 / kappa;  // coth κ = 1 to double precision
  return 1.0 / std::tanh(kappa) - 1.0 / kappa;
}

// κ with A(κ) = r, by bisection on log κ (A is increasing); clamped to [0, max].
double sharpness_for(double r, double max_sharpness) {
  if (!(r > 0.0)) return 0.0;
  if (r >= mean_resultant(max_sharpness)) return max_sharpness;
  double lo = std::log(1e-8), hi = std::log(max_sharpness);
  for (int i = 0; i < 100; ++i) {
    const double mid = 0.5 * (lo + hi);
    (mean_resultant(std::exp(mid)) < r ? lo : hi) = mid;
  }
  return std::exp(0.5 * (lo + hi));
}

// A block of texels: its energy and its weight (luminance energy) with their direction sum.
struct Block {
  glm::dvec3 energy{0.0};     // ∫ L dω over the block, per channel
  double weight = 0.0;        // luminance of `energy`
  glm::dvec3 resultant{0.0};  // Σ weight_t · direction_t over the block's texels
  vec3 direction{0.0f};       // unit: resultant (or the geometric centre when weight is 0)
};

std::vector<Block> blocks_of(const image::Image& map, std::uint32_t max_width, float rotation_degrees) {
  const std::uint32_t step = std::max(1u, (map.width + max_width - 1) / std::max(1u, max_width));
  std::vector<Block> blocks;
  for (std::uint32_t by = 0; by < map.height; by += step) {
    for (std::uint32_t bx = 0; bx < map.width; bx += step) {
      Block b;
      glm::dvec3 centre(0.0);
      for (std::uint32_t y = by; y < std::min(by + step, map.height); ++y) {
        const double omega = texel_solid_angle(y, map.width, map.height);
        for (std::uint32_t x = bx; x < std::min(bx + step, map.width); ++x) {
          glm::dvec3 c(0.0);
          for (std::uint32_t k = 0; k < 3; ++k) c[int(k)] = map.at(x, y, map.channels >= 3 ? k : 0);
          // weft.scene validates maps (finite, non-negative); a hand-made image may not be.
          for (int k = 0; k < 3; ++k)
            if (!std::isfinite(c[k]) || c[k] < 0.0) c[k] = 0.0;
          const vec3 d = scene::equirect_direction(
              vec2((float(x) + 0.5f) / float(map.width), (float(y) + 0.5f) / float(map.height)), rotation_degrees);
          const glm::dvec3 e = c * omega;
          b.energy += e;
          b.weight += luminance(e);
          b.resultant += luminance(e) * glm::dvec3(d);
          centre += omega * glm::dvec3(d);
        }
      }
      const double r = glm::length(b.resultant);
      b.direction = r > 0.0 ? vec3(b.resultant / r) : vec3(glm::normalize(centre));
      blocks.push_back(b);
    }
  }
  return blocks;
}

// A uniform draw in [0, 1) from the top 53 bits (independent of the standard library).
double uniform(std::mt19937_64& rng) { return double(rng() >> 11) * 0x1.0p-53; }

}  // namespace

vec3 map_energy(const image::Image& equirect) {
  glm::dvec3 sum(0.0);
  for (std::uint32_t y = 0; y < equirect.height; ++y) {
    const double omega = texel_solid_angle(y, equirect.width, equirect.height);
    for (std::uint32_t x = 0; x < equirect.width; ++x)
      for (std::uint32_t k = 0; k < 3; ++k) sum[int(k)] += equirect.at(x, y, equirect.channels >= 3 ? k : 0) * omega;
  }
  return vec3(sum);
}

Result<std::vector<SphericalGaussian>> fit_environment(const image::Image& map, const SgFitOptions& options,
                                                       float rotation_degrees, float intensity) {
  if (options.lobes < 1 || options.lobes > 256)
    return fail(ErrorKind::InvalidArgument, "SG fit: {} lobes asked for; 1 .. 256 are supported", options.lobes);
  if (map.width == 0 || map.height == 0 || map.channels == 0 || map.pixels.size() < map.sample_count())
    return fail(ErrorKind::InvalidArgument, "SG fit: the environment map is empty ({} x {} x {})", map.width, map.height,
                map.channels);
  if (!(options.max_sharpness > 0.0f) || !std::isfinite(options.max_sharpness))
    return fail(ErrorKind::InvalidArgument, "SG fit: max_sharpness {} must be finite and > 0", options.max_sharpness);
  if (!(intensity >= 0.0f) || !std::isfinite(intensity))
    return fail(ErrorKind::InvalidArgument, "SG fit: intensity {} must be finite and >= 0", intensity);
  const std::size_t k = options.lobes;
  std::vector<SphericalGaussian> lobes(k);
  const std::vector<Block> blocks = blocks_of(map, std::max(1u, options.max_width), rotation_degrees);
  std::vector<std::size_t> lit;  // blocks carrying energy
  for (std::size_t i = 0; i < blocks.size(); ++i)
    if (blocks[i].weight > 0.0) lit.push_back(i);
  if (lit.empty()) return lobes;  // an all-zero map: zero lobes, no NaN

  // Weighted k-means++ seeding on the sphere, distance 1 − cos.
  std::mt19937_64 rng(options.seed);
  std::vector<vec3> centres;
  std::vector<double> nearest(lit.size(), std::numeric_limits<double>::infinity());
  auto pick = [&](const std::vector<double>& weights) -> std::size_t {
    double total = 0.0;
    for (double w : weights) total += w;
    if (!(total > 0.0)) return lit.size();
    double target = uniform(rng) * total;
    for (std::size_t i = 0; i < weights.size(); ++i) {
      target -= weights[i];
      if (target < 0.0 && weights[i] > 0.0) return i;
    }
    for (std::size_t i = weights.size(); i-- > 0;)
      if (weights[i] > 0.0) return i;
    return lit.size();
  };
  std::vector<double> weights(lit.size());
  for (std::size_t i = 0; i < lit.size(); ++i) weights[i] = blocks[lit[i]].weight;
  while (centres.size() < std::min(k, lit.size())) {
    const std::size_t chosen = pick(weights);
    if (chosen == lit.size()) break;  // every remaining block coincides with a centre
    centres.push_back(blocks[lit[chosen]].direction);
    for (std::size_t i = 0; i < lit.size(); ++i) {
      nearest[i] = std::min(nearest[i], std::max(0.0, 1.0 - double(glm::dot(centres.back(), blocks[lit[i]].direction))));
      weights[i] = blocks[lit[i]].weight * nearest[i];
    }
  }

  // Lloyd iterations: nearest centre by angle, centre = normalised weighted resultant.
  std::vector<std::uint32_t> label(lit.size(), 0);
  for (std::uint32_t iteration = 0; iteration <= options.iterations; ++iteration) {
    bool changed = iteration == 0;
    for (std::size_t i = 0; i < lit.size(); ++i) {
      const vec3 d = blocks[lit[i]].direction;
      std::uint32_t best = 0;
      float best_dot = -2.0f;
      for (std::uint32_t c = 0; c < centres.size(); ++c) {
        const float dot = glm::dot(centres[c], d);
        if (dot > best_dot) best_dot = dot, best = c;
      }
      if (best != label[i]) changed = true;
      label[i] = best;
    }
    if (!changed || iteration == options.iterations) break;
    std::vector<glm::dvec3> sum(centres.size(), glm::dvec3(0.0));
    for (std::size_t i = 0; i < lit.size(); ++i) sum[label[i]] += blocks[lit[i]].resultant;
    for (std::size_t c = 0; c < centres.size(); ++c)
      if (glm::length(sum[c]) > 0.0) centres[c] = vec3(glm::normalize(sum[c]));
  }

  // Lloyd's clusters start a mixture of von Mises–Fisher lobes (an SG is a vMF density up to
  // its scale), refined by EM with soft assignments: hard clusters bias a broad lobe's centre
  // away from a sharp one inside it, EM recovers a map that is a sum of SGs.
  const std::size_t used = centres.size();
  std::vector<double> kappa(used, 0.0), mix(used, 0.0);
  std::vector<vec3> mu(centres);
  std::vector<double> resp(lit.size() * used, 0.0);
  auto m_step = [&] {
    for (std::size_t c = 0; c < used; ++c) {
      glm::dvec3 r(0.0);
      double w = 0.0;
      for (std::size_t i = 0; i < lit.size(); ++i) {
        const double ric = resp[i * used + c];
        r += ric * blocks[lit[i]].resultant;
        w += ric * blocks[lit[i]].weight;
      }
      mix[c] = w;
      const double len = glm::length(r);
      if (w > 0.0 && len > 0.0) {
        mu[c] = vec3(r / len);
        kappa[c] = sharpness_for(std::min(len / w, 1.0), options.max_sharpness);
      }
    }
  };
  for (std::size_t i = 0; i < lit.size(); ++i) resp[i * used + label[i]] = 1.0;
  m_step();
  std::vector<double> logp(used);
  for (std::uint32_t iteration = 0; iteration < options.em_iterations; ++iteration) {
    double total = 0.0;
    for (double m : mix) total += m;
    for (std::size_t i = 0; i < lit.size(); ++i) {
      const vec3 x = blocks[lit[i]].direction;
      double best = -std::numeric_limits<double>::infinity();
      for (std::size_t c = 0; c < used; ++c) {
        if (!(mix[c] > 0.0)) {
          logp[c] = -std::numeric_limits<double>::infinity();
          continue;
        }
        // log of the vMF density κ / (2π (1 − e^{−2κ})) e^{κ(μ·x − 1)}, 1/(4π) at κ = 0.
        const double kc = kappa[c];
        const double norm = kc < 1e-8 ? -std::log(4.0 * std::numbers::pi)
                                      : std::log(kc) - std::log(2.0 * std::numbers::pi) - std::log(-std::expm1(-2.0 * kc));
        logp[c] = std::log(mix[c] / total) + norm + kc * (double(glm::dot(mu[c], x)) - 1.0);
        best = std::max(best, logp[c]);
      }
      double sum = 0.0;
      for (std::size_t c = 0; c < used; ++c) sum += (logp[c] = std::exp(logp[c] - best));
      for (std::size_t c = 0; c < used; ++c) resp[i * used + c] = logp[c] / sum;
    }
    m_step();
  }

  // One lobe per component, holding exactly its share of the energy (responsibilities sum
  // to 1 per block, so the lobes' total is the map's).
  for (std::size_t c = 0; c < used; ++c) {
    glm::dvec3 e(0.0);
    for (std::size_t i = 0; i < lit.size(); ++i) e += resp[i * used + c] * blocks[lit[i]].energy;
    if (!(mix[c] > 0.0)) continue;
    SphericalGaussian& lobe = lobes[c];
    lobe.axis = mu[c];
    lobe.sharpness = float(kappa[c]);
    lobe.amplitude = vec3(e * double(intensity) / sg_integral(lobe.sharpness));
  }
  return lobes;
}

Result<std::vector<SphericalGaussian>> fit_environment(const scene::Environment& environment, const SgFitOptions& options) {
  if (environment.map) return fit_environment(*environment.map, options, environment.rotation_degrees, environment.intensity);
  image::Image constant = image::Image::filled(64, 32, 3);
  for (std::size_t i = 0; i < std::size_t(64) * 32; ++i)
    for (int c = 0; c < 3; ++c) constant.pixels[i * 3 + std::size_t(c)] = environment.constant_color[c];
  return fit_environment(constant, options, 0.0f, environment.intensity);
}

}  // namespace weft::ssdf
