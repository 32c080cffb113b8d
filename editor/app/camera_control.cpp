// Orbit and fly cameras (camera_control.h).
#include "camera_control.h"

#include <algorithm>
#include <cmath>

#include <glm/ext/matrix_clip_space.hpp>
#include <glm/ext/matrix_transform.hpp>
#include <glm/geometric.hpp>

namespace penumbra::editor {

namespace {
constexpr float kPitchLimit = 1.55f;  // just short of straight up/down, where lookAt degenerates
constexpr float kRadiansPerPixel = 0.005f;
}  // namespace

void CameraControl::frame(const Aabb& bounds) {
  const Aabb b = bounds.empty() ? Aabb{glm::vec3(-1.0f), glm::vec3(1.0f)} : bounds;
  target_ = b.center();
  radius = std::max(0.5f * glm::length(b.extent()), 0.01f);
  // The bounding sphere fits the vertical field; 0.7 of that fills the window with most scenes.
  distance_ = 0.7f * radius / std::sin(0.5f * yfov);
  fly_eye_ = eye();
}

void CameraControl::set_orbit(float yaw, float pitch, float distance) {
  mode_ = Mode::Orbit;
  yaw_ = yaw;
  pitch_ = std::clamp(pitch, -kPitchLimit, kPitchLimit);
  if (distance > 0.0f) distance_ = distance;
}

glm::vec3 CameraControl::forward() const {
  // The direction from the eye towards the target for yaw 0, pitch 0 is -Z.
  const float cp = std::cos(pitch_);
  return glm::vec3(-std::sin(yaw_) * cp, -std::sin(pitch_), -std::cos(yaw_) * cp);
}

glm::vec3 CameraControl::eye() const { return mode_ == Mode::Orbit ? target_ - distance_ * forward() : fly_eye_; }

void CameraControl::rotate(glm::vec2 delta) {
  const glm::vec3 e = eye();
  yaw_ -= delta.x * kRadiansPerPixel;
  pitch_ = std::clamp(pitch_ + delta.y * kRadiansPerPixel, -kPitchLimit, kPitchLimit);
  if (mode_ == Mode::Fly) fly_eye_ = e;
}

void CameraControl::pan(glm::vec2 delta) {
  const glm::vec3 f = forward();
  const glm::vec3 right = glm::normalize(glm::cross(f, glm::vec3(0, 1, 0)));
  const glm::vec3 up = glm::cross(right, f);
  const float scale = (mode_ == Mode::Orbit ? distance_ : radius) * 0.0015f;
  const glm::vec3 shift = (-delta.x * right + delta.y * up) * scale;
  if (mode_ == Mode::Orbit) target_ += shift;
  else fly_eye_ += shift;
}

void CameraControl::zoom(float steps) {
  if (mode_ == Mode::Orbit) distance_ = std::clamp(distance_ * std::pow(0.9f, steps), 1e-3f, 1e6f);
  else fly_eye_ += forward() * (steps * 0.05f * radius);
}

void CameraControl::move(glm::vec3 local) {
  const glm::vec3 f = forward();
  const glm::vec3 right = glm::normalize(glm::cross(f, glm::vec3(0, 1, 0)));
  const glm::vec3 shift = local.x * right + local.y * glm::vec3(0, 1, 0) + local.z * f;
  if (mode_ == Mode::Orbit) target_ += shift;
  else fly_eye_ += shift;
}

void CameraControl::set_mode(Mode mode) {
  if (mode == mode_) return;
  if (mode == Mode::Fly) {
    fly_eye_ = eye();
  } else {
    // Orbit around the point the fly camera looks at, at the same distance as before.
    target_ = fly_eye_ + distance_ * forward();
  }
  mode_ = mode;
}

CameraView CameraControl::view(float aspect) const {
  CameraView v;
  v.position = eye();
  v.view = glm::lookAtRH(v.position, v.position + forward(), glm::vec3(0, 1, 0));
  const float reach = (mode_ == Mode::Orbit ? distance_ : 0.0f) + 4.0f * radius;
  v.projection = glm::perspectiveRH_ZO(yfov, aspect, std::max(reach * 1e-4f, 1e-3f), reach);
  v.projection[1][1] = -v.projection[1][1];  // Vulkan: y down the image
  return v;
}

}  // namespace penumbra::editor
