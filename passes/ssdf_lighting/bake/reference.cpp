// The ground truth for SSDF lighting: Monte-Carlo environment lighting of Lambert surfaces,
// every shadow ray traced with Embree (no SSDF, no spherical Gaussians), per point or as a
// camera image. Deterministic: each point or pixel has its own seeded generator.
module;
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <expected>
#include <optional>
#include <random>
#include <span>
#include <vector>
#include <glm/glm.hpp>
#include <weft/try.h>
module weft.ssdf;

namespace weft::ssdf {
namespace {

// Duff et al. 2017: an orthonormal basis around a unit normal, without a branch cut.
void basis(const vec3& n, vec3& t, vec3& b) {
  const float sign = std::copysign(1.0f, n.z);
  const float a = -1.0f / (sign + n.z);
  const float c = n.x * n.y * a;
  t = vec3(1.0f + sign * n.x * n.x * a, sign * c, -sign * n.x);
  b = vec3(c, sign + n.y * n.y * a, -n.y);
}

std::uint64_t mix_seed(std::uint64_t seed, std::uint64_t index) {
  std::uint64_t z = seed + 0x9e3779b97f4a7c15ull * (index + 1);
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
  return z ^ (z >> 31);
}

// (1/π) ∫ L V max(n·ω, 0) dω by stratified cosine-weighted sampling: the mean of L V.
vec3 estimate(const RayScene& rays, const vec3& position, const vec3& normal, const RadianceFunction& radiance,
              std::uint32_t side, float offset, std::uint64_t seed) {
  if (!(glm::length(normal) > 0.0f)) return vec3(0.0f);
  const vec3 n = glm::normalize(normal);
  vec3 t, b;
  basis(n, t, b);
  const vec3 origin = position + offset * n;
  std::mt19937_64 rng(seed);
  auto uniform = [&] { return float(double(rng() >> 11) * 0x1.0p-53); };
  glm::dvec3 sum(0.0);
  for (std::uint32_t i = 0; i < side; ++i) {
    for (std::uint32_t j = 0; j < side; ++j) {
      const float u1 = (float(i) + uniform()) / float(side), u2 = (float(j) + uniform()) / float(side);
      const float r = std::sqrt(u1), phi = 2.0f * pi * u2;
      const vec3 d = glm::normalize(t * (r * std::cos(phi)) + b * (r * std::sin(phi)) + n * std::sqrt(std::max(0.0f, 1.0f - u1)));
      if (!rays.occluded(origin, d)) sum += glm::dvec3(radiance(d));
    }
  }
  return vec3(sum / double(side * side));
}

std::uint32_t strata(std::uint32_t samples) {
  return std::max(1u, std::uint32_t(std::lround(std::sqrt(double(std::max(1u, samples))))));
}

}  // namespace

Result<std::vector<vec3>> reference_diffuse(const RayScene& rays, std::span<const Probe> points,
                                            const RadianceFunction& radiance, const ReferenceOptions& options) {
  if (!radiance) return fail(ErrorKind::InvalidArgument, "SSDF reference: no radiance function");
  std::vector<vec3> out(points.size());
  const std::uint32_t side = strata(options.samples);
  const float offset = options.offset * rays.diagonal();
  std::atomic<std::size_t> done{0};
  const std::size_t report_every = std::max<std::size_t>(1, points.size() / 10);
  const auto start = std::chrono::steady_clock::now();
  cluster::parallel_for(points.size(), options.threads, [&](std::size_t begin, std::size_t end) {
    for (std::size_t p = begin; p < end; ++p) {
      out[p] = estimate(rays, points[p].position, points[p].normal, radiance, side, offset, mix_seed(options.seed, p));
      const std::size_t finished = ++done;
      if (options.progress && points.size() >= 1000 && finished % report_every == 0)
        log::info(weft::format("SSDF reference: {}/{} points ({} rays each), {:.1f} s", finished, points.size(),
                               side * side,
                               std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count()));
    }
  });
  return out;
}

Result<ReferenceImage> reference_image(const scene::Scene& scene, const ReferenceCamera& camera,
                                       std::span<const vec3> albedo, const RadianceFunction& radiance,
                                       const std::optional<ReferenceLight>& light, const ReferenceOptions& options) {
  if (!radiance) return fail(ErrorKind::InvalidArgument, "SSDF reference: no radiance function");
  if (camera.width == 0 || camera.height == 0 || camera.width > 16384 || camera.height > 16384)
    return fail(ErrorKind::InvalidArgument, "SSDF reference: image size {} x {} must be within 1 .. 16384", camera.width,
                camera.height);
  WEFT_TRY(auto merged, merge_scene(scene));
  std::vector<std::uint32_t> triangle_object;
  for (std::uint32_t o = 0; o < scene.objects.size(); ++o)
    triangle_object.insert(triangle_object.end(), scene.meshes[scene.objects[o].mesh].indices.size() / 3, o);
  WEFT_TRY(auto rays, RayScene::build(merged));
  const float offset = options.offset * rays.diagonal();
  const std::uint32_t side = strata(options.samples);

  ReferenceImage image;
  image.width = camera.width;
  image.height = camera.height;
  const std::size_t count = std::size_t(camera.width) * camera.height;
  image.radiance.assign(count, vec3(0.0f));
  image.mask.assign(count, 0);
  image.object.assign(count, ~0u);
  std::atomic<std::size_t> rows_done{0};
  const auto start = std::chrono::steady_clock::now();
  cluster::parallel_for(camera.height, options.threads, [&](std::size_t begin, std::size_t end) {
    for (std::size_t y = begin; y < end; ++y) {
      for (std::uint32_t x = 0; x < camera.width; ++x) {
        const std::size_t pixel = y * camera.width + x;
        const vec2 ndc((float(x) + 0.5f) / float(camera.width) * 2.0f - 1.0f,
                       (float(y) + 0.5f) / float(camera.height) * 2.0f - 1.0f);
        const vec4 near = camera.inverse_view_projection * vec4(ndc, 0.0f, 1.0f);
        const vec4 far = camera.inverse_view_projection * vec4(ndc, 1.0f, 1.0f);
        const vec3 origin = vec3(near) / near.w;
        const vec3 direction = glm::normalize(vec3(far) / far.w - origin);
        const auto hit = rays.intersect(origin, direction);
        if (!hit) {
          image.radiance[pixel] = radiance(direction);
          continue;
        }
        const std::uint32_t* tri = &merged.indices[std::size_t(hit->triangle) * 3];
        const vec3 p = origin + hit->t * direction;
        vec3 n = merged.normals[tri[0]] * (1.0f - hit->u - hit->v) + merged.normals[tri[1]] * hit->u +
                 merged.normals[tri[2]] * hit->v;
        if (!(glm::length(n) > 0.0f))
          n = glm::cross(merged.positions[tri[1]] - merged.positions[tri[0]],
                         merged.positions[tri[2]] - merged.positions[tri[0]]);
        n = glm::normalize(n);
        const std::uint32_t object = triangle_object[hit->triangle];
        const vec3 a = object < albedo.size() ? albedo[object] : vec3(0.0f);
        vec3 result = a * estimate(rays, p, n, radiance, side, offset, mix_seed(options.seed, pixel));
        if (light) {
          const float cosine = glm::dot(n, light->towards);
          if (cosine > 0.0f && !rays.occluded(p + offset * n, light->towards))
            result += a / pi * light->irradiance * cosine;
        }
        image.radiance[pixel] = result;
        image.mask[pixel] = 1;
        image.object[pixel] = object;
      }
      const std::size_t finished = ++rows_done;
      if (options.progress && finished % std::max<std::size_t>(1, camera.height / 10) == 0)
        log::info(weft::format("SSDF reference image: {}% ({} x {}, {} rays a pixel), {:.1f} s",
                               finished * 100 / camera.height, camera.width, camera.height, side * side,
                               std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count()));
    }
  });
  return image;
}

}  // namespace weft::ssdf
