// The viewer's camera: yaw/pitch/distance about a target, so orbiting never rolls the view.
// Every move keeps the pose finite: a NaN or an overflowing argument leaves it where it was.
// (A NaN pose compares unequal to itself, so the session saw a new camera every frame, posted
// a new render job each time and never got the refined frame a script's `refine` or
// `screenshot` waits for: `orbit nan nan` hung the viewer, issue 33.)
module;
#include <algorithm>
#include <cmath>
#include <glm/glm.hpp>
module weft.viewer;

namespace weft::viewer {

namespace {
constexpr float max_pitch = glm::radians(89.0f);
constexpr float min_distance = 1e-3f;
constexpr float two_pi = 6.28318530717958647692f;
bool finite(glm::vec3 v) { return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z); }
}  // namespace

OrbitCamera::OrbitCamera(CameraPose start) : start_(start), target_(start.target) {
  // A start that is not finite (a scene built in code) would make every pose NaN: look at
  // the origin from +Z instead.
  if (!finite(start.position) || !finite(start.target)) start_ = start = {{0.0f, 0.0f, 3.0f}, {0.0f, 0.0f, 0.0f}};
  target_ = start.target;
  const glm::vec3 offset = start.position - start.target;
  const float length = glm::length(offset);
  distance_ = std::isfinite(length) ? std::max(length, min_distance) : min_distance;
  yaw_ = std::isfinite(length) && length > 0.0f ? std::atan2(offset.x, offset.z) : 0.0f;
  pitch_ = std::isfinite(length) && length > 0.0f ? std::asin(std::clamp(offset.y / distance_, -1.0f, 1.0f)) : 0.0f;
}

glm::vec3 OrbitCamera::forward() const {  // from the camera towards the target
  return -glm::vec3(std::cos(pitch_) * std::sin(yaw_), std::sin(pitch_), std::cos(pitch_) * std::cos(yaw_));
}

CameraPose OrbitCamera::pose() const { return {target_ - forward() * distance_, target_}; }

bool OrbitCamera::keep_if_finite(const OrbitCamera& before) {
  const CameraPose p = pose();
  if (finite(p.position) && finite(p.target) && std::isfinite(distance_) && p.position != p.target) return true;
  *this = before;
  return false;
}

bool OrbitCamera::orbit(float yaw_degrees, float pitch_degrees) {
  if (!std::isfinite(yaw_degrees) || !std::isfinite(pitch_degrees)) return false;
  const OrbitCamera before = *this;
  // The yaw stays within one turn, so a long session's sum keeps its float precision.
  yaw_ = std::remainder(yaw_ + std::remainder(glm::radians(yaw_degrees), two_pi), two_pi);
  pitch_ = std::clamp(pitch_ + glm::radians(pitch_degrees), -max_pitch, max_pitch);
  return keep_if_finite(before);
}

bool OrbitCamera::pan(float right, float up) {
  if (!std::isfinite(right) || !std::isfinite(up)) return false;
  const OrbitCamera before = *this;
  const glm::vec3 f = forward();
  const glm::vec3 r = glm::normalize(glm::cross(f, glm::vec3(0, 1, 0)));
  const glm::vec3 u = glm::cross(r, f);
  target_ += (r * right + u * up) * distance_;
  return keep_if_finite(before);
}

bool OrbitCamera::zoom(float factor) {
  if (!std::isfinite(factor) || !(factor > 0.0f)) return false;
  const OrbitCamera before = *this;
  distance_ = std::max(distance_ * factor, min_distance);
  return keep_if_finite(before);
}

bool OrbitCamera::fly(float forward_amount, float right, float up) {
  if (!std::isfinite(forward_amount) || !std::isfinite(right) || !std::isfinite(up)) return false;
  const OrbitCamera before = *this;
  const glm::vec3 f = forward();
  const glm::vec3 r = glm::normalize(glm::cross(f, glm::vec3(0, 1, 0)));
  target_ += (f * forward_amount + r * right + glm::vec3(0, 1, 0) * up) * distance_;
  return keep_if_finite(before);
}

}  // namespace weft::viewer
