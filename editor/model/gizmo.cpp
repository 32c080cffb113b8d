// The translate gizmo's math (gizmo.h).
#include "gizmo.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include <glm/geometric.hpp>
#include <glm/mat4x4.hpp>

#include "penumbra/ecs/transform.h"
#include "penumbra/scene/camera.h"
#include "picking.h"

namespace penumbra::editor {
namespace {

float distance_to_segment(glm::vec2 p, glm::vec2 a, glm::vec2 b) {
  const glm::vec2 ab = b - a;
  const float len2 = glm::dot(ab, ab);
  const float t = len2 > 0.0f ? std::clamp(glm::dot(p - a, ab) / len2, 0.0f, 1.0f) : 0.0f;
  return glm::distance(p, a + t * ab);
}

}  // namespace

const char* to_string(GizmoMode mode) {
  switch (mode) {
    case GizmoMode::Move: return "move";
    case GizmoMode::Rotate: return "rotate";
    case GizmoMode::Scale: return "scale";
  }
  return "?";
}

std::optional<GizmoHandles> gizmo_handles(const CameraView& camera, glm::vec3 origin, glm::vec2 size,
                                          GizmoMode mode, const glm::mat3& axes) {
  const auto o = project(camera, origin, size);
  if (!o) return std::nullopt;
  GizmoHandles h;
  h.mode = mode;
  h.origin = *o;
  const glm::vec3 eye(glm::inverse(camera.view)[3]);
  h.length = std::max(0.2f * glm::distance(eye, origin), 1e-4f);
  for (int a = 0; a < 3; ++a) {
    if (mode != GizmoMode::Rotate) {
      h.tips[a] = project(camera, origin + h.length * axes[a], size);
      continue;
    }
    // The ring in the plane across the axis.
    const glm::vec3 u = axes[(a + 1) % 3], v = axes[(a + 2) % 3];
    constexpr int kPoints = 48;
    for (int i = 0; i < kPoints; ++i) {
      const float t = 6.2831853f * float(i) / kPoints;
      if (const auto p = project(camera, origin + h.length * (std::cos(t) * u + std::sin(t) * v), size))
        h.rings[a].push_back(*p);
    }
  }
  return h;
}

glm::mat3 gizmo_axes(const World& world, Entity e, GizmoMode mode) {
  const WorldTransform* wt = world.try_get<WorldTransform>(e);
  if (mode != GizmoMode::Scale || wt == nullptr) return glm::mat3(1.0f);
  glm::mat3 axes(wt->matrix);
  for (int a = 0; a < 3; ++a) {
    const float length = glm::length(axes[a]);
    if (!(length > 1e-12f) || !std::isfinite(length)) return glm::mat3(1.0f);
    axes[a] /= length;
  }
  return axes;
}

int pick_gizmo_axis(const GizmoHandles& handles, glm::vec2 pointer, float reach) {
  int best = -1;
  float nearest = reach;
  for (int a = 0; a < 3; ++a) {
    float d = std::numeric_limits<float>::infinity();
    if (handles.mode != GizmoMode::Rotate) {
      if (handles.tips[a]) d = distance_to_segment(pointer, handles.origin, *handles.tips[a]);
    } else {
      const std::vector<glm::vec2>& ring = handles.rings[a];
      for (std::size_t i = 0; i < ring.size(); ++i)
        d = std::min(d, distance_to_segment(pointer, ring[i], ring[(i + 1) % ring.size()]));
    }
    if (d <= nearest) {
      nearest = d;
      best = a;
    }
  }
  return best;
}

float rotate_about_axis(const CameraView& camera, glm::vec3 origin, glm::vec3 axis, glm::vec2 from, glm::vec2 to,
                        glm::vec2 size) {
  const auto o = project(camera, origin, size);
  if (!o) return 0.0f;
  const glm::vec2 a = from - *o, b = to - *o;
  if (glm::dot(a, a) < 1e-6f || glm::dot(b, b) < 1e-6f) return 0.0f;
  // The screen turn, counter-clockwise positive as seen (y grows downwards on screen).
  const float turn = -std::atan2(a.x * b.y - a.y * b.x, glm::dot(a, b));
  // Right-handed about an axis that points at the camera is counter-clockwise as seen.
  const glm::vec3 eye(glm::inverse(camera.view)[3]);
  return glm::dot(axis, eye - origin) >= 0.0f ? turn : -turn;
}

float scale_along_axis(const CameraView& camera, glm::vec3 origin, glm::vec3 axis, float length, glm::vec2 from,
                       glm::vec2 to, glm::vec2 size) {
  const glm::vec3 offset = drag_along_axis(camera, origin, axis, from, to, size);
  return std::max(0.01f, 1.0f + glm::dot(offset, axis) / std::max(length, 1e-6f));
}

glm::vec3 drag_along_axis(const CameraView& camera, glm::vec3 origin, glm::vec3 axis, glm::vec2 from, glm::vec2 to,
                          glm::vec2 size) {
  const glm::mat4 clip_to_world = glm::inverse(camera.projection * camera.view);
  const auto w = static_cast<std::uint32_t>(std::max(size.x, 1.0f));
  const auto h = static_cast<std::uint32_t>(std::max(size.y, 1.0f));
  // The parameter s of the axis point origin + s axis nearest the ray through `pixel`.
  const auto along = [&](glm::vec2 pixel, float& s) {
    const CameraRay ray = camera_ray(clip_to_world, pixel, w, h);
    const glm::vec3 r = origin - ray.origin;
    const float b = glm::dot(axis, ray.direction);
    const float denom = 1.0f - b * b;  // |axis| = |direction| = 1
    if (!(denom > 1e-6f)) return false;
    s = (b * glm::dot(ray.direction, r) - glm::dot(axis, r)) / denom;
    return std::isfinite(s);
  };
  float s0 = 0.0f, s1 = 0.0f;
  if (!along(from, s0) || !along(to, s1)) return glm::vec3(0.0f);
  return (s1 - s0) * axis;
}

glm::mat4 parent_world_matrix(const World& world, Entity e) {
  const Parent* parent = world.alive(e) ? world.try_get<Parent>(e) : nullptr;
  const WorldTransform* up =
      parent != nullptr && world.alive(parent->entity) ? world.try_get<WorldTransform>(parent->entity) : nullptr;
  return up != nullptr ? up->matrix : glm::mat4(1.0f);
}

}  // namespace penumbra::editor
