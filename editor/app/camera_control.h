// The viewport's cameras: orbit (around a target: drag to turn, wheel to zoom, middle-drag to pan)
// and fly (mouse look, WASD/QE to move). Pure math over CameraView (render/renderer.h); the input
// comes from the application.
#pragma once

#include <glm/vec2.hpp>
#include <glm/vec3.hpp>

#include "penumbra/render/renderer.h"
#include "penumbra/scene/components.h"

namespace penumbra::editor {

class CameraControl {
 public:
  enum class Mode { Orbit, Fly };

  // Orbit around the centre of `bounds` from a distance that fits it in the vertical field.
  void frame(const Aabb& bounds);
  // Orbit angles in radians (yaw about +Y from +Z, pitch up from the horizon) and distance.
  void set_orbit(float yaw, float pitch, float distance);
  // Orbit from `eye` along `forward` (unit) with the vertical field `yfov`, around the point
  // level with the framed target (frame() first): what a scene's camera sees, to turn from.
  void look_from(glm::vec3 eye, glm::vec3 forward, float yfov);

  // Mouse drag by `delta` pixels: orbit turns around the target, fly looks around.
  void rotate(glm::vec2 delta);
  // Middle-drag: moves the orbit target in the view plane (fly: sideways/up).
  void pan(glm::vec2 delta);
  // Wheel: orbit distance x 0.9^steps; fly moves forward.
  void zoom(float steps);
  // Fly movement for this frame: x right, y up, z forward, in metres.
  void move(glm::vec3 local);
  // Switches mode keeping the eye where it is.
  void set_mode(Mode mode);

  Mode mode() const { return mode_; }
  glm::vec3 eye() const;
  glm::vec3 forward() const;  // unit view direction
  glm::vec3 target() const { return target_; }
  float distance() const { return distance_; }
  // Vulkan clip conventions (y down, depth 0..1), as camera_view().
  CameraView view(float aspect) const;

  float yfov = 0.9f;         // radians
  float radius = 10.0f;      // scene size for the clip planes and speeds

 private:
  Mode mode_ = Mode::Orbit;
  glm::vec3 target_{0.0f};
  float yaw_ = 0.0f, pitch_ = 0.4f, distance_ = 10.0f;
  glm::vec3 fly_eye_{0.0f, 2.0f, 10.0f};
};

// Looks through the scene's first Camera entity (lowest index, as `penumbra render` picks), framing
// `bounds` for the orbit's centre; false (and nothing changed) when the scene has no camera.
bool look_through_scene_camera(World& world, const Aabb& bounds, CameraControl& control);

}  // namespace penumbra::editor
