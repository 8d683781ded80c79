// RayScene (one Embree scene of every triangle) and the visibility bake: rtcOccluded1 per
// probe and direction, probes split over std::threads (Embree's own threads only build the BVH).
module;
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <expected>
#include <limits>
#include <memory>
#include <optional>
#include <span>
#include <vector>
#include <embree3/rtcore.h>
#include <glm/glm.hpp>
#include <weft/try.h>
module weft.ssdf;

namespace weft::ssdf {
namespace {
Result<void> check_mesh(const BakeMesh& mesh) {
  if (mesh.indices.size() % 3 != 0)
    return fail(ErrorKind::InvalidArgument, "SSDF bake: {} indices is not a multiple of 3", mesh.indices.size());
  for (std::size_t i = 0; i < mesh.indices.size(); ++i)
    if (mesh.indices[i] >= mesh.positions.size())
      return fail(ErrorKind::InvalidArgument, "SSDF bake: index {} (triangle {}) is {}, but there are {} vertices",
                  i, i / 3, mesh.indices[i], mesh.positions.size());
  for (std::size_t v = 0; v < mesh.positions.size(); ++v)
    if (!std::isfinite(mesh.positions[v].x) || !std::isfinite(mesh.positions[v].y) || !std::isfinite(mesh.positions[v].z))
      return fail(ErrorKind::InvalidArgument, "SSDF bake: vertex {} has a non-finite position", v);
  return {};
}

RTCRay make_ray(const vec3& origin, const vec3& direction) {
  RTCRay ray{};
  ray.org_x = origin.x, ray.org_y = origin.y, ray.org_z = origin.z;
  ray.dir_x = direction.x, ray.dir_y = direction.y, ray.dir_z = direction.z;
  ray.tnear = 0.0f;
  ray.tfar = std::numeric_limits<float>::infinity();
  ray.mask = 0xffffffffu;
  return ray;
}
}  // namespace

// Owns an Embree device and scene; releases both.
struct RayScene::State {
  RTCDevice device = nullptr;
  RTCScene scene = nullptr;
  float diagonal = 1.0f;
  State() = default;
  State(const State&) = delete;
  State& operator=(const State&) = delete;
  ~State() {
    if (scene) rtcReleaseScene(scene);
    if (device) rtcReleaseDevice(device);
  }
};

RayScene::RayScene(RayScene&&) noexcept = default;
RayScene& RayScene::operator=(RayScene&&) noexcept = default;
RayScene::~RayScene() = default;

Result<RayScene> RayScene::build(const BakeMesh& mesh) {
  WEFT_TRY_VOID(check_mesh(mesh));
  RayScene result;
  result.state_ = std::make_unique<State>();
  State& embree = *result.state_;
  embree.device = rtcNewDevice(nullptr);
  if (!embree.device) return fail(ErrorKind::Device, "Embree: rtcNewDevice failed (error {})", int(rtcGetDeviceError(nullptr)));
  embree.scene = rtcNewScene(embree.device);
  if (mesh.triangle_count() > 0) {
    RTCGeometry geometry = rtcNewGeometry(embree.device, RTC_GEOMETRY_TYPE_TRIANGLE);
    auto* vertices = static_cast<float*>(rtcSetNewGeometryBuffer(geometry, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3,
                                                                 3 * sizeof(float), mesh.positions.size()));
    auto* indices = static_cast<unsigned*>(rtcSetNewGeometryBuffer(geometry, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3,
                                                                   3 * sizeof(unsigned), mesh.triangle_count()));
    if (!vertices || !indices) {
      rtcReleaseGeometry(geometry);
      return fail(ErrorKind::Device, "Embree: could not allocate buffers for {} vertices, {} triangles",
                  mesh.positions.size(), mesh.triangle_count());
    }
    for (std::size_t v = 0; v < mesh.positions.size(); ++v)
      for (int c = 0; c < 3; ++c) vertices[3 * v + std::size_t(c)] = mesh.positions[v][c];
    std::ranges::copy(mesh.indices, indices);
    rtcCommitGeometry(geometry);
    rtcAttachGeometry(embree.scene, geometry);
    rtcReleaseGeometry(geometry);
  }
  rtcCommitScene(embree.scene);
  if (const RTCError error = rtcGetDeviceError(embree.device); error != RTC_ERROR_NONE)
    return fail(ErrorKind::Device, "Embree: building the scene failed (error {})", int(error));
  const scene::Bounds bounds = scene::compute_bounds(mesh.positions);
  embree.diagonal = bounds.empty() ? 1.0f : std::max(glm::length(bounds.size()), 1e-6f);
  return result;
}

bool RayScene::occluded(const vec3& origin, const vec3& direction) const {
  RTCIntersectContext context;
  rtcInitIntersectContext(&context);
  RTCRay ray = make_ray(origin, direction);
  rtcOccluded1(state_->scene, &context, &ray);
  return ray.tfar < 0.0f;  // Embree sets tfar = -inf on a hit
}

std::optional<RayScene::Hit> RayScene::intersect(const vec3& origin, const vec3& direction) const {
  RTCIntersectContext context;
  rtcInitIntersectContext(&context);
  RTCRayHit hit{};
  hit.ray = make_ray(origin, direction);
  hit.hit.geomID = RTC_INVALID_GEOMETRY_ID;
  hit.hit.primID = RTC_INVALID_GEOMETRY_ID;
  rtcIntersect1(state_->scene, &context, &hit);
  if (hit.hit.geomID == RTC_INVALID_GEOMETRY_ID) return std::nullopt;
  return Hit{hit.hit.primID, hit.ray.tfar, hit.hit.u, hit.hit.v};
}

float RayScene::diagonal() const { return state_->diagonal; }

std::vector<Probe> vertex_probes(const BakeMesh& mesh) {
  std::vector<Probe> probes(mesh.positions.size());
  for (std::size_t v = 0; v < probes.size(); ++v)
    probes[v] = {mesh.positions[v], v < mesh.normals.size() ? mesh.normals[v] : vec3(0.0f)};
  return probes;
}

Result<Visibility> bake_visibility(const BakeMesh& occluders, std::span<const Probe> probes, const DirectionGrid& grid,
                                   const VisibilityOptions& options) {
  for (std::size_t p = 0; p < probes.size(); ++p) {
    const vec3 a = probes[p].position, n = probes[p].normal;
    if (!std::isfinite(a.x + a.y + a.z + n.x + n.y + n.z))
      return fail(ErrorKind::InvalidArgument, "SSDF bake: probe {} has a non-finite position or normal", p);
  }
  WEFT_TRY(auto rays, RayScene::build(occluders));
  const float offset = options.offset * rays.diagonal();

  Visibility result;
  result.probe_count = probes.size();
  result.directions = grid.size();
  result.visible.assign(probes.size() * grid.size(), 1);
  std::atomic<std::size_t> done{0};
  const auto start = std::chrono::steady_clock::now();
  const std::size_t report_every = std::max<std::size_t>(1, probes.size() / 10);
  cluster::parallel_for(probes.size(), options.threads, [&](std::size_t begin, std::size_t end) {
    for (std::size_t p = begin; p < end; ++p) {
      const vec3 n = glm::length(probes[p].normal) > 0.0f ? glm::normalize(probes[p].normal) : vec3(0.0f);
      const vec3 origin = probes[p].position + offset * n;
      std::uint8_t* row = result.visible.data() + p * grid.size();
      for (std::size_t d = 0; d < grid.size(); ++d) {
        const vec3 dir = grid.direction(d);
        row[d] = (options.below_horizon_visible && glm::dot(dir, n) < 0.0f) || !rays.occluded(origin, dir) ? 1 : 0;
      }
      const std::size_t finished = ++done;
      if (options.progress && probes.size() >= 1000 && finished % report_every == 0)
        log::info(weft::format("SSDF visibility: {}/{} vertices, {:.1f} s", finished, probes.size(),
                               std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count()));
    }
  });
  return result;
}

}  // namespace weft::ssdf
