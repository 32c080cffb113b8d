// Viewport visualisations (overlays.h).
#include "overlays.h"

#include <algorithm>
#include <cmath>
#include <vector>

#include <glm/common.hpp>
#include <glm/gtc/matrix_transform.hpp>
#include <imgui.h>

#include "gizmo.h"
#include "light_icons.h"
#include "penumbra/ecs/transform.h"
#include "penumbra/scene/animation.h"
#include "penumbra/scene/components.h"

namespace penumbra::editor {

glm::vec3 irradiance_colour(glm::vec3 e, float exposure) {
  const glm::vec3 x = glm::max(e * exposure, glm::vec3(0.0f));
  return x / (glm::vec3(1.0f) + x);
}

ImU32 to_imgui(glm::vec3 c, float alpha) {
  return ImGui::ColorConvertFloat4ToU32(ImVec4(c.x, c.y, c.z, alpha));
}

void draw_box(ImDrawList* dl, const CameraView& camera, glm::vec2 size, const glm::mat4& unit_to_world, ImU32 colour) {
  // The 12 edges of the unit cube [0, 1]^3 mapped through unit_to_world.
  static const int kEdges[12][2] = {{0, 1}, {2, 3}, {4, 5}, {6, 7}, {0, 2}, {1, 3},
                                    {4, 6}, {5, 7}, {0, 4}, {1, 5}, {2, 6}, {3, 7}};
  std::optional<glm::vec2> corner[8];
  for (int c = 0; c < 8; ++c)
    corner[c] = project(camera,
                        glm::vec3(unit_to_world * glm::vec4(float(c & 1), float((c >> 1) & 1), float((c >> 2) & 1), 1.0f)),
                        size);
  for (const auto& e : kEdges)
    if (corner[e[0]] && corner[e[1]])
      dl->AddLine(ImVec2(corner[e[0]]->x, corner[e[0]]->y), ImVec2(corner[e[1]]->x, corner[e[1]]->y), colour, 1.5f);
}

// A closed polyline through world points; segments with an end behind the camera are skipped.
void draw_loop(ImDrawList* dl, const CameraView& camera, glm::vec2 size, const std::vector<glm::vec3>& loop,
               ImU32 colour) {
  for (std::size_t i = 0; i < loop.size(); ++i) {
    const auto a = project(camera, loop[i], size), b = project(camera, loop[(i + 1) % loop.size()], size);
    if (a && b) dl->AddLine(ImVec2(a->x, a->y), ImVec2(b->x, b->y), colour, 1.5f);
  }
}

void draw_selection(ImDrawList* dl, World& world, Entity selection, const CameraView& camera, glm::vec2 size) {
  if (!selection || !world.alive(selection)) return;
  const Aabb box = posed_bounds(world, selection);
  if (box.empty()) return;
  const glm::vec3 extent = glm::max(box.extent(), glm::vec3(1e-3f));
  const glm::mat4 unit_to_world = glm::scale(glm::translate(glm::mat4(1.0f), box.min), extent);
  draw_box(dl, camera, size, unit_to_world, IM_COL32(255, 255, 255, 220));
}

void draw_gizmo(ImDrawList* dl, const CameraView& camera, glm::vec3 origin, glm::vec2 size, GizmoMode mode,
                const glm::mat3& axes, int active) {
  const auto handles = gizmo_handles(camera, origin, size, mode, axes);
  if (!handles) return;
  const ImU32 colours[3] = {IM_COL32(230, 60, 60, 230), IM_COL32(80, 210, 80, 230), IM_COL32(70, 120, 255, 230)};
  for (int a = 0; a < 3; ++a) {
    const bool on = a == active;
    const ImU32 colour = on ? IM_COL32(255, 255, 160, 255) : colours[a];
    const float width = on ? 4.0f : 2.5f;
    if (mode == GizmoMode::Rotate) {
      std::vector<ImVec2> points;
      for (const glm::vec2 p : handles->rings[a]) points.emplace_back(p.x, p.y);
      dl->AddPolyline(points.data(), static_cast<int>(points.size()), colour, ImDrawFlags_Closed, width);
      continue;
    }
    if (!handles->tips[a]) continue;
    const glm::vec2 o = handles->origin, t = *handles->tips[a];
    dl->AddLine(ImVec2(o.x, o.y), ImVec2(t.x, t.y), colour, width);
    if (mode == GizmoMode::Scale)
      dl->AddRectFilled(ImVec2(t.x - 5.0f, t.y - 5.0f), ImVec2(t.x + 5.0f, t.y + 5.0f), colour);
    else
      dl->AddCircleFilled(ImVec2(t.x, t.y), on ? 6.0f : 5.0f, colour, 12);
  }
}

void draw_lights(ImDrawList* dl, World& world, Entity selection, const CameraView& camera, glm::vec2 size) {
  const glm::vec3 eye(glm::inverse(camera.view)[3]);
  world.view<const Light, const WorldTransform>().each([&](Entity e, const Light& light, const WorldTransform& wt) {
    const glm::vec3 at(wt.matrix[3]);
    // A tenth of the distance to the camera: the icon keeps its size on screen.
    const LightIcon icon = light_icon(light, wt.matrix, std::max(0.1f * glm::distance(eye, at), 1e-3f));
    const auto marker = project(camera, icon.position, size);
    const float peak = std::max({light.color.r, light.color.g, light.color.b, 1e-6f});
    const unsigned colour = e == selection ? IM_COL32(255, 255, 255, 255) : to_imgui(light.color / peak, 0.85f);
    for (const auto& [a, b] : icon.lines) {
      const auto pa = project(camera, a, size), pb = project(camera, b, size);
      if (pa && pb) dl->AddLine(ImVec2(pa->x, pa->y), ImVec2(pb->x, pb->y), colour, 1.5f);
    }
    if (!marker) return;
    dl->AddCircleFilled(ImVec2(marker->x, marker->y), 4.0f, colour, 12);
    dl->AddCircle(ImVec2(marker->x, marker->y), 7.0f, IM_COL32(0, 0, 0, 160), 12, 1.0f);
  });
}

void draw_error_map(const ErrorMap& map, glm::vec2 size, ImDrawList* dl) {
  const float w = size.x / static_cast<float>(map.columns), h = size.y / static_cast<float>(map.rows);
  for (std::uint32_t r = 0; r < map.rows; ++r)
    for (std::uint32_t c = 0; c < map.columns; ++c) {
      const std::size_t i = std::size_t{r} * map.columns + c;
      const float e = map.relative_error[i];
      if (std::isnan(e)) continue;
      const float t = std::clamp(e / 0.5f, 0.0f, 1.0f);  // 0 blue .. 0.5 and more red
      const ImU32 colour = map.cell_above_noise(i)
                               ? ImGui::ColorConvertFloat4ToU32(ImVec4(t, 0.2f * (1.0f - t), 1.0f - t, 0.55f))
                               : IM_COL32(128, 128, 128, 110);
      dl->AddRectFilled(ImVec2(static_cast<float>(c) * w, static_cast<float>(r) * h),
                        ImVec2(static_cast<float>(c + 1) * w, static_cast<float>(r + 1) * h), colour);
    }
}

}  // namespace penumbra::editor
