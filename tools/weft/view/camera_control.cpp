// The viewer's camera: yaw/pitch/distance about a target, so orbiting never rolls the view.
module;
#include <algorithm>
#include <cmath>
#include <glm/glm.hpp>
module weft.viewer;

namespace weft::viewer {

namespace {
constexpr float max_pitch = glm::radians(89.0f);
constexpr float min_distance = 1e-3f;
}  // namespace

OrbitCamera::OrbitCamera(CameraPose start) : start_(start), target_(start.target) {
  const glm::vec3 offset = start.position - start.target;
  distance_ = std::max(glm::length(offset), min_distance);
  yaw_ = std::atan2(offset.x, offset.z);
  pitch_ = std::asin(std::clamp(offset.y / distance_, -1.0f, 1.0f));
}

glm::vec3 OrbitCamera::forward() const {  // from the camera towards the target
  return -glm::vec3(std::cos(pitch_) * std::sin(yaw_), std::sin(pitch_), std::cos(pitch_) * std::cos(yaw_));
}

CameraPose OrbitCamera::pose() const { return {target_ - forward() * distance_, target_}; }

void OrbitCamera::orbit(float yaw_degrees, float pitch_degrees) {
  yaw_ += glm::radians(yaw_degrees);
  pitch_ = std::clamp(pitch_ + glm::radians(pitch_degrees), -max_pitch, max_pitch);
}

void OrbitCamera::pan(float right, float up) {
  const glm::vec3 f = forward();
  const glm::vec3 r = glm::normalize(glm::cross(f, glm::vec3(0, 1, 0)));
  const glm::vec3 u = glm::cross(r, f);
  target_ += (r * right + u * up) * distance_;
}

void OrbitCamera::zoom(float factor) {
  if (std::isfinite(factor) && factor > 0.0f) distance_ = std::max(distance_ * factor, min_distance);
}

void OrbitCamera::fly(float forward_amount, float right, float up) {
  const glm::vec3 f = forward();
  const glm::vec3 r = glm::normalize(glm::cross(f, glm::vec3(0, 1, 0)));
  target_ += (f * forward_amount + r * right + glm::vec3(0, 1, 0) * up) * distance_;
}

}  // namespace weft::viewer
