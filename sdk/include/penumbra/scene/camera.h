// Camera views of a World, shared by the real-time renderer and the CPU paths (the offline
// renderer, the image benches): one pinhole model, Vulkan clip conventions (y down the image,
// depth 0..1), so pixel (x, y) of every path sees the same point.
#pragma once

#include <cstdint>

#include <glm/mat4x4.hpp>
#include <glm/vec2.hpp>
#include <glm/vec3.hpp>

#include "penumbra/ecs/world.h"

namespace penumbra {

struct CameraView {
  glm::mat4 view{1.0f};        // world -> camera
  glm::mat4 projection{1.0f};  // camera -> clip, Vulkan conventions (y down, depth 0..1)
  glm::vec3 position{0.0f};    // world-space eye
};

// The CameraView of a Camera entity at its WorldTransform, for a target of the given aspect (width /
// height), which wins over Camera::aspect: the image is never stretched; the vertical field is yfov.
CameraView camera_view(const World& world, Entity camera, float aspect);
// A camera that frames every mesh as posed now (posed_bounds: skinned meshes by their skinned
// vertices), looking from the front and above. Run after the skinning system.
CameraView framing_camera_view(World& world, float aspect);
// A camera at `eye` looking at `target` with +Y up (a game's follow camera): vertical field `yfov`
// radians, `aspect` width / height, depths znear..zfar metres. Preconditions: eye != target, the
// view not straight up or down, 0 < znear < zfar. O(1).
CameraView look_at_view(glm::vec3 eye, glm::vec3 target, float yfov, float aspect, float znear, float zfar);

// The primary ray through point `pixel` of a width x height image (pixel (x, y)'s centre is
// (x + 0.5, y + 0.5); y = 0 is the top row): from the near plane, unit direction. O(1) after the
// caller inverts projection x view once (clip_to_world).
struct CameraRay {
  glm::vec3 origin{0.0f};
  glm::vec3 direction{0.0f, 0.0f, -1.0f};
};
CameraRay camera_ray(const glm::mat4& clip_to_world, glm::vec2 pixel, std::uint32_t width, std::uint32_t height);

}  // namespace penumbra
