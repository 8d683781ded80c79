// Procedural meshes for analytic tests and scenes: sphere, plane, torus, cube. Seam vertices
// (u = 0 and u = 1, the sphere's poles) get bit-identical positions, so welding joins them
// and curvature sees a closed surface. Normals are analytic; tangents and curvature come
// from prepare_mesh.
module;
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <expected>
#include <string>
#include <string_view>
#include <vector>
#include <glm/glm.hpp>
module weft.scene;
import weft.core;

namespace weft::scene {
namespace {

constexpr double two_pi = 6.283185307179586476925;

bool positive(float v) { return std::isfinite(v) && v > 0.0f; }

// Adds the quad a-b-c-d (in either winding) as two triangles facing along the normals.
void add_quad(Mesh& mesh, std::uint32_t a, std::uint32_t b, std::uint32_t c, std::uint32_t d) {
  const auto add = [&](std::uint32_t x, std::uint32_t y, std::uint32_t z) {
    const vec3& px = mesh.positions[x];
    const vec3& py = mesh.positions[y];
    const vec3& pz = mesh.positions[z];
    if (px == py || py == pz || px == pz) return;  // collapsed at a pole
    const vec3 face = glm::cross(py - px, pz - px);
    const vec3 normal = mesh.normals[x] + mesh.normals[y] + mesh.normals[z];
    if (glm::dot(face, normal) >= 0.0f) mesh.indices.insert(mesh.indices.end(), {x, y, z});
    else mesh.indices.insert(mesh.indices.end(), {x, z, y});
  };
  add(a, b, c);
  add(a, c, d);
}

// A (rows+1) x (columns+1) grid of vertices from `vertex(i, j)`, quads between them.
template <class Fn>
Mesh grid(std::string name, std::uint32_t columns, std::uint32_t rows, Fn vertex) {
  Mesh mesh;
  mesh.name = std::move(name);
  const std::size_t count = std::size_t(columns + 1) * (rows + 1);
  mesh.positions.reserve(count);
  mesh.normals.reserve(count);
  mesh.uvs.reserve(count);
  for (std::uint32_t j = 0; j <= rows; ++j) {
    for (std::uint32_t i = 0; i <= columns; ++i) {
      vec3 p, n;
      vertex(i, j, p, n);
      mesh.positions.push_back(p);
      mesh.normals.push_back(n);
      mesh.uvs.emplace_back(float(i) / float(columns), float(j) / float(rows));
    }
  }
  const auto at = [&](std::uint32_t i, std::uint32_t j) { return j * (columns + 1) + i; };
  for (std::uint32_t j = 0; j < rows; ++j) {
    for (std::uint32_t i = 0; i < columns; ++i) add_quad(mesh, at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j + 1));
  }
  return mesh;
}

Result<Mesh> finish(Mesh mesh) {
  const std::string label = weft::format("{} primitive", mesh.name);
  if (auto ok = detail::prepare_mesh(mesh, LoadOptions{}, label); !ok) return std::unexpected(ok.error());
  return mesh;
}

std::uint32_t clamp_count(std::uint32_t n, std::uint32_t lo) { return std::clamp<std::uint32_t>(n, lo, max_primitive_count); }

}  // namespace

Result<Mesh> make_sphere(float radius, std::uint32_t segments) {
  if (!positive(radius)) return fail(ErrorKind::InvalidArgument, "sphere radius must be positive and finite, got {}", radius);
  const std::uint32_t segs = clamp_count(segments, 3);
  const std::uint32_t rings = std::max<std::uint32_t>(2, segs / 2);
  return finish(grid("sphere", segs, rings, [&](std::uint32_t i, std::uint32_t j, vec3& p, vec3& n) {
    const double theta = std::acos(-1.0) * j / rings;
    const double phi = two_pi * (i % segs) / segs;  // the seam column repeats column 0 exactly
    const double sin_theta = (j == 0 || j == rings) ? 0.0 : std::sin(theta);
    const double cos_theta = j == 0 ? 1.0 : j == rings ? -1.0 : std::cos(theta);
    n = vec3(float(sin_theta * std::cos(phi)), float(cos_theta), float(sin_theta * std::sin(phi)));
    p = n * radius;
  }));
}

Result<Mesh> make_plane(float size, std::uint32_t subdivisions) {
  if (!positive(size)) return fail(ErrorKind::InvalidArgument, "plane size must be positive and finite, got {}", size);
  const std::uint32_t n = clamp_count(subdivisions, 1);
  return finish(grid("plane", n, n, [&](std::uint32_t i, std::uint32_t j, vec3& p, vec3& nrm) {
    p = vec3(size * (float(i) / float(n) - 0.5f), 0.0f, size * (float(j) / float(n) - 0.5f));
    nrm = vec3(0.0f, 1.0f, 0.0f);
  }));
}

Result<Mesh> make_torus(float major_radius, float minor_radius, std::uint32_t segments, std::uint32_t sides) {
  if (!positive(major_radius) || !positive(minor_radius) || !(minor_radius < major_radius)) {
    return fail(ErrorKind::InvalidArgument, "torus radii must be finite with 0 < minor < major, got major {} minor {}",
                major_radius, minor_radius);
  }
  const std::uint32_t segs = clamp_count(segments, 3);
  const std::uint32_t around = clamp_count(sides, 3);
  return finish(grid("torus", segs, around, [&](std::uint32_t i, std::uint32_t j, vec3& p, vec3& n) {
    const double phi = two_pi * (i % segs) / segs;
    const double theta = two_pi * (j % around) / around;
    const double ring = major_radius + minor_radius * std::cos(theta);
    n = vec3(float(std::cos(theta) * std::cos(phi)), float(std::sin(theta)), float(std::cos(theta) * std::sin(phi)));
    p = vec3(float(ring * std::cos(phi)), float(minor_radius * std::sin(theta)), float(ring * std::sin(phi)));
  }));
}

Result<Mesh> make_cube(float size) {
  if (!positive(size)) return fail(ErrorKind::InvalidArgument, "cube size must be positive and finite, got {}", size);
  Mesh mesh;
  mesh.name = "cube";
  const float h = size * 0.5f;
  // Each face: its normal and two in-face axes (u, v) with cross(u, v) = normal.
  const vec3 faces[6][3] = {
      {{1, 0, 0}, {0, 0, -1}, {0, 1, 0}}, {{-1, 0, 0}, {0, 0, 1}, {0, 1, 0}}, {{0, 1, 0}, {1, 0, 0}, {0, 0, -1}},
      {{0, -1, 0}, {1, 0, 0}, {0, 0, 1}}, {{0, 0, 1}, {1, 0, 0}, {0, 1, 0}},  {{0, 0, -1}, {-1, 0, 0}, {0, 1, 0}},
  };
  for (const auto& f : faces) {
    const auto base = static_cast<std::uint32_t>(mesh.positions.size());
    const vec2 corners[4] = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
    for (const vec2& c : corners) {
      mesh.positions.push_back((f[0] + f[1] * (2.0f * c.x - 1.0f) + f[2] * (2.0f * c.y - 1.0f)) * h);
      mesh.normals.push_back(f[0]);
      mesh.uvs.emplace_back(c.x, 1.0f - c.y);  // v down the face, like an image
    }
    add_quad(mesh, base, base + 1, base + 2, base + 3);
  }
  return finish(std::move(mesh));
}

}  // namespace weft::scene
