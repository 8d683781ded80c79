// Which objects the key light's shadow map needs. A flat object (every vertex on one plane)
// shadows only what lies behind it, on the side away from the light. When nothing visible
// lies there, leaving it out of the shadow map changes no pixel, and a floor under the scene
// is exactly that object: it covers most of the map, so it took most of the shadow pass's
// rasterisation (docs/benchmarks.md, "The showcase").
//
// The rule compares a flat object with every other object's box. Asked object by object
// (shadows_nothing_visible, the reference) that is n - 1 boxes per flat object, and the scene's
// bounds, which every call needs, are n more: 30,000 lit objects took 48 s to pick their
// casters (issue 33). select_shadow_casters answers for every object at once: the scene's
// bounds and every box's world corners once, and the boxes in a bounding-volume hierarchy, so
// a flat object skips, a node at a time, the boxes that are provably on its lit side. The
// boxes it does look at get exactly the test shadows_nothing_visible gives them (one function,
// Caster::allows), so the answers are the same (tests/renderer/test_shadow_casters.cpp
// compares them on random scenes).
module;
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
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


using Corners = std::array<vec3, 8>;

// The eight corners of `box` moved by `m`, in the order the tests below walk them.
Corners box_corners(const scene::Bounds& box, const mat4& m) {
  Corners corners;
  for (int c = 0; c < 8; ++c)
    corners[c] = world(m, vec3(c & 1 ? box.max.x : box.min.x, c & 2 ? box.max.y : box.min.y, c & 4 ? box.max.z : box.min.z));
  return corners;
}

// One flat object's question, set up once: does another object's box let it shadow nothing?
struct Caster {
  const scene::Mesh* mesh = nullptr;
  mat4 transform{1.0f};
  Plane plane{};        // facing the light
  bool opaque = false;  // hides what is behind it from the eye (a standard material)
  vec3 eye{0.0f};
  bool eye_in_front = false;
  float tolerance = 0.0f, touching = 0.0f;
  std::optional<Rectangle> rectangle;  // made when first needed
  bool rectangle_tried = false;

  // Every corner on the lit side of the plane (or resting on it).
  [[nodiscard]] bool on_lit_side(const Corners& corners) const {
    return std::all_of(corners.begin(), corners.end(), [&](vec3 c) { return plane.above(c) >= -touching; });
  }

  // Whether the other object with these box corners leaves this object shadowing nothing visible.
  bool allows(const Corners& corners) {
    if (on_lit_side(corners)) return true;
    if (!opaque || !eye_in_front) return false;
    if (!rectangle_tried) {
      rectangle = filled_rectangle(*mesh, transform, plane);
      rectangle_tried = true;
    }
    if (!rectangle) return false;
    // The part of the box behind the plane is convex, and so is its image on the plane seen
    // from the eye: it is hidden when the lines from the eye to its vertices (the corners
    // behind the plane and the crossings of the box's edges) meet the plane inside the filled
    // rectangle.
    std::vector<vec3> behind;
    for (int c = 0; c < 8; ++c) {
      if (plane.above(corners[c]) < -tolerance) behind.push_back(corners[c]);
      for (int axis = 1; axis < 8; axis <<= 1) {
        const int d = c | axis;
        if (d == c) continue;
        const float s0 = plane.above(corners[c]), s1 = plane.above(corners[d]);
        if ((s0 < 0.0f) != (s1 < 0.0f)) behind.push_back(glm::mix(corners[c], corners[d], s0 / (s0 - s1)));
      }
    }
    for (const vec3& p : behind) {
      const float h_eye = plane.above(eye), h_p = plane.above(p);
      const vec3 crossing = glm::mix(eye, p, h_eye / (h_eye - h_p));
      if (!rectangle->contains(crossing)) return false;
    }
    return true;
  }
};

// Object `index`'s question, or nothing when the answer is "it casts" whatever the other
// objects are: not flat, or the light grazing its plane. `all`: the scene's bounds (not empty);
// `light`: unit, towards the light.
std::optional<Caster> caster(const scene::Scene& scene, std::uint32_t index, vec3 light, const scene::Bounds& all) {
  const scene::Object& object = scene.objects.at(index);
  const scene::Mesh& mesh = scene.meshes.at(object.mesh);
  const float tolerance = 1e-5f * std::max(glm::length(all.max - all.min), 1e-6f);
  std::optional<Plane> plane = flat_plane(mesh, object.transform, tolerance);
  if (!plane) return std::nullopt;
  const float facing = glm::dot(plane->normal, light);
  if (std::abs(facing) < 1e-3f) return std::nullopt;  // the light grazes the plane
  if (facing < 0.0f) plane = Plane{-plane->normal, -plane->offset};
  Caster c;
  c.mesh = &mesh;
  c.transform = object.transform;
  c.plane = *plane;
  // Points behind the plane may still be hidden from the camera by the object itself when it
  // is opaque (a standard material: an object sunk a little into the floor).
  c.opaque = scene.materials.at(object.material).type == scene::standard_material;
  c.eye = scene.camera.position;
  c.eye_in_front = plane->above(c.eye) > tolerance;
  c.tolerance = tolerance;
  // Objects resting on the floor often dip into it by a rounding error or a few millimetres
  // (the showcase's cushion: 5 mm of a 7 m scene). Seen from the floor's lit side those
  // slivers are hidden by it except past its rim, so up to 0.1 % of the scene's size counts
  // as on the plane; the rest must pass the hiding test.
  c.touching = c.eye_in_front ? 1e-3f * glm::length(all.max - all.min) : tolerance;
  return c;
}

bool finite(const Corners& corners) {
  return std::all_of(corners.begin(), corners.end(),
                     [](vec3 p) { return std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z); });
}

// The other objects' boxes in a bounding-volume hierarchy (median splits along the longest
// axis, up to 4 boxes a leaf). Boxes with a corner that is not finite stay out of it, in
// `loose`, and are tested one by one.
class BoxTree {
 public:
  BoxTree(const std::vector<Corners>& corners, const std::vector<std::uint32_t>& objects) : corners_(corners) {
    for (std::uint32_t j : objects) (finite(corners[j]) ? items_ : loose_).push_back(j);
    if (!items_.empty()) build(0, std::uint32_t(items_.size()));
  }

  // Whether every box but object `self`'s allows `caster`; `tested` counts the boxes given
  // the exact test.
  bool all_allow(Caster& caster, std::uint32_t self, std::uint64_t& tested) const {
    for (std::uint32_t j : loose_) {
      if (j == self) continue;
      ++tested;
      if (!caster.allows(corners_[j])) return false;
    }
    if (nodes_.empty()) return true;
    std::vector<std::uint32_t> stack{0};
    while (!stack.empty()) {
      const Node& node = nodes_[stack.back()];
      stack.pop_back();
      if (on_lit_side(caster, node)) continue;
      if (node.count > 0) {
        for (std::uint32_t k = node.first; k < node.first + node.count; ++k) {
          if (items_[k] == self) continue;
          ++tested;
          if (!caster.allows(corners_[items_[k]])) return false;
        }
      } else {
        stack.push_back(node.right);
        stack.push_back(node.left);
      }
    }
    return true;
  }

 private:
  struct Node {
    vec3 lo, hi;                  // around every corner of the node's boxes
    std::uint32_t first = 0, count = 0;  // a leaf: items_[first, first + count)
    std::uint32_t left = 0, right = 0;   // an inner node: its children
  };

  std::uint32_t build(std::uint32_t first, std::uint32_t end) {
    const std::uint32_t index = std::uint32_t(nodes_.size());
    nodes_.push_back({});
    vec3 lo(std::numeric_limits<float>::infinity()), hi(-std::numeric_limits<float>::infinity());
    for (std::uint32_t k = first; k < end; ++k)
      for (const vec3& p : corners_[items_[k]]) lo = glm::min(lo, p), hi = glm::max(hi, p);
    nodes_[index].lo = lo, nodes_[index].hi = hi;
    if (end - first <= 4) {
      nodes_[index].first = first, nodes_[index].count = end - first;
      return index;
    }
    const vec3 extent = hi - lo;
    const int axis = extent.x >= extent.y && extent.x >= extent.z ? 0 : extent.y >= extent.z ? 1 : 2;
    const std::uint32_t middle = first + (end - first) / 2;
    const auto centre = [&](std::uint32_t j) { return corners_[j][0][axis] + corners_[j][7][axis]; };
    std::nth_element(items_.begin() + first, items_.begin() + middle, items_.begin() + end,
                     [&](std::uint32_t a, std::uint32_t b) { return centre(a) < centre(b); });
    const std::uint32_t left = build(first, middle);
    const std::uint32_t right = build(middle, end);
    nodes_[index].left = left, nodes_[index].right = right;
    return index;
  }

  // True only when every point of the node's box is on the caster's lit side as
  // Plane::above computes it in float: the box's lowest corner along the normal, in double,
  // with a margin far above the rounding of one above() (the margin only lets fewer nodes be
  // skipped; the boxes of a node not skipped get the exact test).
  static bool on_lit_side(const Caster& caster, const Node& node) {
    const vec3 n = caster.plane.normal;
    double lowest = -double(caster.plane.offset), scale = std::abs(double(caster.plane.offset));
    for (int a = 0; a < 3; ++a) {
      lowest += double(n[a]) * double(n[a] >= 0.0f ? node.lo[a] : node.hi[a]);
      scale += std::abs(double(n[a])) * std::max(std::abs(double(node.lo[a])), std::abs(double(node.hi[a])));
    }
    return lowest - 1e-5 * scale >= -double(caster.touching);
  }

  const std::vector<Corners>& corners_;
  std::vector<std::uint32_t> items_, loose_;
  std::vector<Node> nodes_;
};

}  // namespace

bool shadows_nothing_visible(const scene::Scene& scene, std::uint32_t index, vec3 towards_light) {
  const scene::Bounds all = scene.bounds();
  if (all.empty()) return false;
  (void)scene.objects.at(index);
  std::optional<Caster> c = caster(scene, index, glm::normalize(towards_light), all);
  if (!c) return false;
  for (std::uint32_t j = 0; j < scene.objects.size(); ++j) {
    if (j == index) continue;
    const scene::Object& other = scene.objects[j];
    const scene::Bounds box = scene.meshes.at(other.mesh).bounds;
    if (box.empty()) continue;
    if (!c->allows(box_corners(box, other.transform))) return false;
  }
  return true;
}

std::vector<bool> select_shadow_casters(const scene::Scene& scene, vec3 towards_light, ShadowCasterStats* stats) {
  const std::uint32_t n = std::uint32_t(scene.objects.size());
  std::vector<bool> casts(n, true);
  ShadowCasterStats counted;
  const scene::Bounds all = scene.bounds();
  if (!all.empty()) {
    const vec3 light = glm::normalize(towards_light);
    std::vector<Corners> corners(n);
    std::vector<std::uint32_t> boxed;  // the objects with a box (an empty one is no obstacle)
    boxed.reserve(n);
    for (std::uint32_t j = 0; j < n; ++j) {
      const scene::Object& object = scene.objects[j];
      const scene::Bounds box = scene.meshes.at(object.mesh).bounds;
      if (box.empty()) continue;
      corners[j] = box_corners(box, object.transform);
      boxed.push_back(j);
    }
    std::optional<BoxTree> tree;  // built when the first flat object needs it
    for (std::uint32_t i = 0; i < n; ++i) {
      std::optional<Caster> c = caster(scene, i, light, all);
      if (!c) continue;
      ++counted.flat_objects;
      if (!tree) tree.emplace(corners, boxed);
      casts[i] = !tree->all_allow(*c, i, counted.boxes_tested);
    }
  }
  if (stats) *stats = counted;
  return casts;
}

}  // namespace weft::renderer
