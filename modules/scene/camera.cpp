// Camera matrices for Vulkan, framing, and transforms.
module;
#include <algorithm>
#include <cmath>
#include <expected>
#include <glm/glm.hpp>
#include <glm/gtc/matrix_transform.hpp>
#include <glm/gtc/quaternion.hpp>
module weft.scene;
import weft.core;

namespace weft::scene {
namespace {

bool finite(const vec3& v) { return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z); }

}  // namespace

vec3 Camera::forward() const {
  const vec3 d = target - position;
  const float len = glm::length(d);
  return len > 0.0f ? d / len : vec3(0.0f, 0.0f, -1.0f);
}

mat4 Camera::view() const {
  const vec3 f = forward();
  vec3 u = up;
  // An up along the view direction has no sideways part: fall back to another axis.
  if (!(glm::length(glm::cross(f, u)) > 1e-6f * glm::length(u))) {
    u = std::abs(f.y) < 0.99f ? vec3(0.0f, 1.0f, 0.0f) : vec3(0.0f, 0.0f, -1.0f);
  }
  return glm::lookAtRH(position, position + f, u);
}

mat4 Camera::projection(float aspect) const {
  mat4 p = glm::perspectiveRH_ZO(glm::radians(fov_y_degrees), aspect, near, far);
  p[1][1] = -p[1][1];  // Vulkan's NDC y points down
  return p;
}

Result<void> validate(const Camera& c) {
  if (!finite(c.position) || !finite(c.target) || !finite(c.up) || !std::isfinite(c.fov_y_degrees) ||
      !std::isfinite(c.near) || !std::isfinite(c.far)) {
    return fail(ErrorKind::InvalidArgument, "camera has a non-finite field");
  }
  if (!(c.fov_y_degrees >= float(min_fov_degrees) && c.fov_y_degrees <= float(max_fov_degrees))) {
    return fail(ErrorKind::InvalidArgument, "camera fov {} is outside [{}, {}] degrees", c.fov_y_degrees, min_fov_degrees,
                max_fov_degrees);
  }
  if (!(c.near > 0.0f)) return fail(ErrorKind::InvalidArgument, "camera near {} must be positive", c.near);
  if (!(c.far > c.near)) return fail(ErrorKind::InvalidArgument, "camera far {} must be greater than near {}", c.far, c.near);
  const vec3 d = c.target - c.position;
  if (!(glm::length(d) > 0.0f)) return fail(ErrorKind::InvalidArgument, "camera position and target are the same point");
  if (!(glm::length(glm::cross(glm::normalize(d), c.up)) > 1e-6f * glm::length(c.up))) {
    return fail(ErrorKind::InvalidArgument, "camera up ({}, {}, {}) is zero or parallel to the view direction", c.up.x,
                c.up.y, c.up.z);
  }
  return {};
}

Camera camera_framing(const Bounds& bounds, float fov_y_degrees) {
  Camera c;
  c.fov_y_degrees = std::clamp(std::isfinite(fov_y_degrees) ? fov_y_degrees : 45.0f, 1.0f, 170.0f);
  if (bounds.empty()) return c;
  const vec3 center = bounds.center();
  const float radius = std::max(0.5f * glm::length(bounds.size()), 1e-4f);
  const float distance = 1.1f * radius / std::sin(glm::radians(c.fov_y_degrees) * 0.5f);
  c.target = center;
  c.position = center + glm::normalize(vec3(0.0f, 0.35f, 1.0f)) * distance;
  c.near = distance * 0.01f;
  c.far = distance + 4.0f * radius;
  return c;
}

mat4 Transform::matrix() const {
  mat4 m = glm::translate(mat4(1.0f), translation) * glm::mat4_cast(rotation);
  return glm::scale(m, scale);
}

quat Transform::rotation_from_euler_degrees(const vec3& degrees) {
  const vec3 r = glm::radians(degrees);
  const quat qx = glm::angleAxis(r.x, vec3(1.0f, 0.0f, 0.0f));
  const quat qy = glm::angleAxis(r.y, vec3(0.0f, 1.0f, 0.0f));
  const quat qz = glm::angleAxis(r.z, vec3(0.0f, 0.0f, 1.0f));
  return qz * qy * qx;
}

}  // namespace weft::scene
