module;
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <expected>
#include <span>
#include <string>
#include <vector>
#include <glm/gtc/matrix_transform.hpp>
#include "weft_frame_shaders.h"
module weft.frame;
import weft.core;
import weft.gpu;

namespace weft::frame {

mat4 fit_light_view_projection(vec3 towards_light, vec3 lo, vec3 hi) {
  const vec3 center = 0.5f * (lo + hi);
  const float radius = std::max(0.5f * glm::length(hi - lo), 1e-4f);
  const vec3 dir = glm::normalize(towards_light);
  const vec3 up = std::abs(dir.y) > 0.99f ? vec3(1, 0, 0) : vec3(0, 1, 0);
  const mat4 view = glm::lookAtRH(center + dir * radius * 2.0f, center, up);
  // A bounding sphere keeps the map stable as the light turns; Vulkan depth 0..1.
  mat4 projection = glm::orthoRH_ZO(-radius, radius, -radius, radius, radius * 0.5f, radius * 3.5f);
  projection[1][1] *= -1.0f;
  return projection * view;
}


gpu::VertexBufferLayout vertex_layout() {
  return {.stride = sizeof(Vertex),
          .attributes = {{gpu::VertexFormat::Float32x3, offsetof(Vertex, position), 0},
                         {gpu::VertexFormat::Float32, offsetof(Vertex, curvature), 1},
                         {gpu::VertexFormat::Float32x3, offsetof(Vertex, normal), 2},
                         {gpu::VertexFormat::Float32x4, offsetof(Vertex, tangent), 3},
                         {gpu::VertexFormat::Float32x2, offsetof(Vertex, uv), 4}}};
}

Result<GpuMesh> upload_mesh(gpu::Device& device, const MeshData& mesh) {
  if (mesh.vertices.empty() || mesh.indices.empty())
    return fail(ErrorKind::InvalidArgument, "mesh '{}': no vertices or no triangles", mesh.name);
  if (mesh.indices.size() % 3 != 0)
    return fail(ErrorKind::InvalidArgument, "mesh '{}': {} indices is not a multiple of 3", mesh.name, mesh.indices.size());
  const auto max_index = *std::max_element(mesh.indices.begin(), mesh.indices.end());
  if (max_index >= mesh.vertices.size())
    return fail(ErrorKind::InvalidArgument, "mesh '{}': index {} >= vertex count {}", mesh.name, max_index,
                mesh.vertices.size());
  auto vb = device.create_buffer_with_data({.label = mesh.name + ".vertices", .usage = gpu::BufferUsage::Vertex},
                                           std::as_bytes(std::span(mesh.vertices)));
  if (!vb) return std::unexpected(vb.error());
  auto ib = device.create_buffer_with_data({.label = mesh.name + ".indices", .usage = gpu::BufferUsage::Index},
                                           std::as_bytes(std::span(mesh.indices)));
  if (!ib) return std::unexpected(ib.error());
  GpuMesh out{mesh.name, std::move(*vb), std::move(*ib), std::uint32_t(mesh.indices.size()),
              std::uint32_t(mesh.vertices.size())};
  out.bounds_min = out.bounds_max = mesh.vertices[0].position;
  for (const auto& v : mesh.vertices) {
    out.bounds_min = glm::min(out.bounds_min, v.position);
    out.bounds_max = glm::max(out.bounds_max, v.position);
  }
  return out;
}

namespace {
std::array<float, 9> sh_basis(vec3 d) {
  return {0.282095f,
          0.488603f * d.y,
          0.488603f * d.z,
          0.488603f * d.x,
          1.092548f * d.x * d.y,
          1.092548f * d.y * d.z,
          0.315392f * (3.0f * d.z * d.z - 1.0f),
          1.092548f * d.x * d.z,
          0.546274f * (d.x * d.x - d.y * d.y)};
}
}  // namespace

std::array<vec4, 9> irradiance_sh(std::span<const float> rgb, std::uint32_t width, std::uint32_t height,
                                  float rotation_radians) {
  std::array<glm::dvec3, 9> radiance{};
  const double dphi = 2.0 * pi / width, dtheta = pi / double(height);
  for (std::uint32_t y = 0; y < height; ++y) {
    const double theta = (y + 0.5) * dtheta;
    // The row's exact solid angle (not sin θ dθ), so even a 2-row map integrates to 4π.
    const double solid_angle = dphi * (std::cos(y * dtheta) - std::cos((y + 1) * dtheta));
    for (std::uint32_t x = 0; x < width; ++x) {
      // Equirect convention shared with shaders/frame.glsl: u = atan(z, x) / 2π + 0.5, v = θ / π.
      const double phi = ((x + 0.5) / width - 0.5) * 2.0 * pi + rotation_radians;
      const vec3 d{float(std::sin(theta) * std::cos(phi)), float(std::cos(theta)), float(std::sin(theta) * std::sin(phi))};
      const std::size_t i = (std::size_t(y) * width + x) * 3;
      glm::dvec3 L{rgb[i], rgb[i + 1], rgb[i + 2]};
      if (!std::isfinite(L.x) || !std::isfinite(L.y) || !std::isfinite(L.z)) continue;
      const auto basis = sh_basis(d);
      for (int k = 0; k < 9; ++k) radiance[k] += L * double(basis[k]) * solid_angle;
    }
  }
  // Cosine-lobe convolution weights per band: π, 2π/3, π/4.
  const double band[9] = {pi, 2 * pi / 3, 2 * pi / 3, 2 * pi / 3, pi / 4, pi / 4, pi / 4, pi / 4, pi / 4};
  std::array<vec4, 9> out{};
  for (int k = 0; k < 9; ++k) out[k] = vec4(vec3(radiance[k] * band[k]), 0.0f);
  return out;
}

std::array<vec4, 9> constant_irradiance_sh(vec3 radiance) {
  std::array<vec4, 9> out{};
  out[0] = vec4(radiance * (pi / 0.282095f), 0.0f);
  return out;
}

vec3 evaluate_sh(const std::array<vec4, 9>& sh, vec3 n) {
  const auto basis = sh_basis(n);
  vec3 e{0.0f};
  for (int k = 0; k < 9; ++k) e += vec3(sh[k]) * basis[k];
  return e;
}

std::span<const std::uint32_t> fullscreen_vertex_spirv() { return shaders::fullscreen_vert(); }

mat4 perspective_vk(float fov, float aspect, float near_plane, float far_plane) {
  mat4 p = glm::perspectiveRH_ZO(fov, aspect, near_plane, far_plane);
  p[1][1] *= -1.0f;
  return p;
}

namespace {
// The radical inverse of i in `base`: the i-th point of the van der Corput sequence in [0, 1).
float radical_inverse(std::uint32_t i, std::uint32_t base) {
  double inverse_base = 1.0 / base, scale = inverse_base, value = 0.0;
  while (i > 0) {
    value += double(i % base) * scale;
    i /= base;
    scale *= inverse_base;
  }
  return float(value);
}
}  // namespace

vec2 sample_jitter(std::uint32_t index) {
  if (index == 0) return vec2(0.0f);
  return vec2(radical_inverse(index, 2), radical_inverse(index, 3)) - 0.5f;
}

mat4 jitter_projection(const mat4& projection, vec2 jitter, std::uint32_t width, std::uint32_t height) {
  if (width == 0 || height == 0) return projection;
  // NDC x' = x + dx: clip x' = clip x + dx * clip w, i.e. row 0 of the matrix gains dx * row 3.
  const float dx = 2.0f * jitter.x / float(width), dy = 2.0f * jitter.y / float(height);
  mat4 p = projection;
  for (int column = 0; column < 4; ++column) {
    p[column][0] += dx * p[column][3];
    p[column][1] += dy * p[column][3];
  }
  return p;
}

}  // namespace weft::frame
