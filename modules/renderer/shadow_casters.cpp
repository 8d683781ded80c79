// Which objects the key light's shadow map needs. A flat object (every vertex on one plane)
// shadows only what lies behind it, on the side away from the light. When nothing visible
// lies there, leaving it out of the shadow map changes no pixel, and a floor under the scene
// is exactly that object: it covers most of the map, so it took most of the shadow pass's
// rasterisation (docs/benchmarks.md, "The showcase").
module;
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <optional>
#include <string>
#include <string_view>
#include <vector>
#include <glm/glm.hpp>
module weft.renderer;
import weft.core;
import weft.scene;

namespace weft::renderer {

namespace {

struct Plane {
  vec3 normal;  // unit, towards the light
  float offset;  // dot(normal, x) on the plane
  [[nodiscard]] float above(vec3 p) const { return glm::dot(normal, p) - offset; }
};

vec3 world(const mat4& m, vec3 p) { return vec3(m * vec4(p, 1.0f)); }

// The object's plane in world space when all its vertices lie on one (within `tolerance`).
std::optional<Plane> flat_plane(const scene::Mesh& mesh, const mat4& transform, float tolerance) {
  std::optional<Plane> plane;
  for (std::size_t t = 0; t + 2 < mesh.indices.size() && !plane; t += 3) {
    const vec3 a = world(transform, mesh.positions.at(mesh.indices[t]));
    const vec3 n = glm::cross(world(transform, mesh.positions.at(mesh.indices[t + 1])) - a,
                              world(transform, mesh.positions.at(mesh.indices[t + 2])) - a);
    const float length = glm::length(n);
    if (length > 1e-12f && std::isfinite(length)) plane = Plane{n / length, glm::dot(n / length, a)};
  }
  if (!plane) return std::nullopt;
  for (const vec3& p : mesh.positions)
    if (!(std::abs(plane->above(world(transform, p))) <= tolerance)) return std::nullopt;
  return plane;
}

// The flat object as a filled rectangle in its plane, when it is one (a floor: the plane
// primitive, a quad): its triangles' area equals the area of their bounding rectangle along
// one of the first triangle's edges. Then every point of the rectangle is covered.
struct Rectangle {
  vec3 origin, u, v;  // unit axes in the plane
  float u0, u1, v0, v1;
  [[nodiscard]] bool contains(vec3 p) const {
    const float a = glm::dot(p - origin, u), b = glm::dot(p - origin, v);
    return a >= u0 && a <= u1 && b >= v0 && b <= v1;
  }
};

std::optional<Rectangle> filled_rectangle(const scene::Mesh& mesh, const mat4& transform, const Plane& plane) {
  double area = 0.0;
  for (std::size_t t = 0; t + 2 < mesh.indices.size(); t += 3) {
    const vec3 a = world(transform, mesh.positions[mesh.indices[t]]);
    area += 0.5 * glm::length(glm::cross(world(transform, mesh.positions[mesh.indices[t + 1]]) - a,
                                         world(transform, mesh.positions[mesh.indices[t + 2]]) - a));
  }
  const vec3 a = world(transform, mesh.positions[mesh.indices[0]]);
  const vec3 edges[3] = {world(transform, mesh.positions[mesh.indices[1]]) - a,
                         world(transform, mesh.positions[mesh.indices[2]]) - a,
                         world(transform, mesh.positions[mesh.indices[2]]) - world(transform, mesh.positions[mesh.indices[1]])};
  for (const vec3& edge : edges) {
    if (!(glm::length(edge) > 0.0f)) continue;
    Rectangle r{a, glm::normalize(edge), glm::normalize(glm::cross(plane.normal, edge)), 0, 0, 0, 0};
    r.u0 = r.v0 = std::numeric_limits<float>::infinity();
    r.u1 = r.v1 = -std::numeric_limits<float>::infinity();
    for (const vec3& p : mesh.positions) {
      const vec3 w = world(transform, p);
      const float x = glm::dot(w - a, r.u), y = glm::dot(w - a, r.v);
      r.u0 = std::min(r.u0, x), r.u1 = std::max(r.u1, x), r.v0 = std::min(r.v0, y), r.v1 = std::max(r.v1, y);
    }
    const double box = double(r.u1 - r.u0) * double(r.v1 - r.v0);
    if (box > 0.0 && std::abs(area - box) <= 1e-3 * box) return r;
  }
  return std::nullopt;
}

}  // namespace

bool shadows_nothing_visible(const scene::Scene& scene, std::uint32_t index, vec3 towards_light) {
  const scene::Object& object = scene.objects.at(index);
  const scene::Mesh& mesh = scene.meshes.at(object.mesh);
  const scene::Bounds all = scene.bounds();
  if (all.empty()) return false;
  const float tolerance = 1e-5f * std::max(glm::length(all.max - all.min), 1e-6f);
  std::optional<Plane> plane = flat_plane(mesh, object.transform, tolerance);
  if (!plane) return false;
  const vec3 light = glm::normalize(towards_light);
  const float facing = glm::dot(plane->normal, light);
  if (std::abs(facing) < 1e-3f) return false;  // the light grazes the plane
  if (facing < 0.0f) plane = Plane{-plane->normal, -plane->offset};
  // Points behind the plane may still be hidden from the camera by the object itself when it
  // is opaque (a standard material: an object sunk a little into the floor).
  const scene::Material& material = scene.materials.at(object.material);
  const bool opaque = material.type == scene::standard_material;
  const vec3 eye = scene.camera.position;
  const bool eye_in_front = plane->above(eye) > tolerance;
  std::optional<Rectangle> rectangle;  // made when first needed
  bool rectangle_tried = false;
  // Objects resting on the floor often dip into it by a rounding error or a few millimetres
  // (the showcase's cushion: 5 mm of a 7 m scene). Seen from the floor's lit side those
  // slivers are hidden by it except past its rim, so up to 0.1 % of the scene's size counts
  // as on the plane; the rest must pass the hiding test below.
  const float touching = eye_in_front ? 1e-3f * glm::length(all.max - all.min) : tolerance;
  for (std::uint32_t j = 0; j < scene.objects.size(); ++j) {
    if (j == index) continue;
    const scene::Object& other = scene.objects[j];
    const scene::Bounds box = scene.meshes.at(other.mesh).bounds;
    if (box.empty()) continue;
    // The box's corners in world space, and where its edges cross the plane.
    std::array<vec3, 8> corners;
    for (int c = 0; c < 8; ++c)
      corners[c] = world(other.transform, vec3(c & 1 ? box.max.x : box.min.x, c & 2 ? box.max.y : box.min.y,
                                               c & 4 ? box.max.z : box.min.z));
    if (std::all_of(corners.begin(), corners.end(), [&](vec3 c) { return plane->above(c) >= -touching; })) continue;
    if (!opaque || !eye_in_front) return false;
    if (!rectangle_tried) {
      rectangle = filled_rectangle(mesh, object.transform, *plane);
      rectangle_tried = true;
    }
    if (!rectangle) return false;
    // The part of the box behind the plane is convex, and so is its image on the plane seen
    // from the eye: it is hidden when the lines from the eye to its vertices (the corners
    // behind the plane and the crossings of the box's edges) meet the plane inside the filled
    // rectangle.
    std::vector<vec3> behind;
    for (int c = 0; c < 8; ++c) {
      if (plane->above(corners[c]) < -tolerance) behind.push_back(corners[c]);
      for (int axis = 1; axis < 8; axis <<= 1) {
        const int d = c | axis;
        if (d == c) continue;
        const float s0 = plane->above(corners[c]), s1 = plane->above(corners[d]);
        if ((s0 < 0.0f) != (s1 < 0.0f)) behind.push_back(glm::mix(corners[c], corners[d], s0 / (s0 - s1)));
      }
    }
    for (const vec3& p : behind) {
      const float h_eye = plane->above(eye), h_p = plane->above(p);
      const vec3 crossing = glm::mix(eye, p, h_eye / (h_eye - h_p));
      if (!rectangle->contains(crossing)) return false;
    }
  }
  return true;
}

}  // namespace weft::renderer
