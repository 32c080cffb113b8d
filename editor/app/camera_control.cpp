// Orbit and fly cameras (camera_control.h).
#include "camera_control.h"

#include <algorithm>
#include <cmath>

#include <glm/ext/matrix_clip_space.hpp>
#include <glm/ext/matrix_transform.hpp>
#include <glm/geometric.hpp>

#include "penumbra/ecs/transform.h"

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

void CameraControl::look_from(glm::vec3 eye, glm::vec3 forward, float field) {
  mode_ = Mode::Orbit;
  yfov = field;
  yaw_ = std::atan2(-forward.x, -forward.z);
  pitch_ = std::clamp(-std::asin(std::clamp(forward.y, -1.0f, 1.0f)), -kPitchLimit, kPitchLimit);
  distance_ = std::max(glm::dot(target_ - eye, this->forward()), 0.1f * radius);
  target_ = eye + distance_ * this->forward();
  fly_eye_ = eye;
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

bool look_through_scene_camera(World& world, const Aabb& bounds, CameraControl& control) {
  Entity first;
  world.view<const Camera, const WorldTransform>().each([&](Entity e, const Camera&, const WorldTransform&) {
    if (!first || e.index < first.index) first = e;
  });
  if (!first) return false;
  const glm::mat4& m = world.get<WorldTransform>(first).matrix;
  const glm::vec3 forward = -glm::vec3(m[2]);  // a camera looks down its local -Z (glTF)
  if (!(glm::length(forward) > 0.0f)) return false;
  control.frame(bounds);
  control.look_from(glm::vec3(m[3]), glm::normalize(forward), world.get<Camera>(first).yfov);
  return true;
}

}  // namespace penumbra::editor
