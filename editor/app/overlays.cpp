// Viewport visualisations (overlays.h).
#include "overlays.h"

#include <algorithm>
#include <cmath>

#include <imgui.h>

#include "penumbra/ecs/transform.h"
#include "penumbra/probe_grid/probe_grid.h"

namespace penumbra::editor {

std::optional<glm::vec2> project(const CameraView& camera, glm::vec3 p, glm::vec2 size) {
  const glm::vec4 clip = camera.projection * camera.view * glm::vec4(p, 1.0f);
  if (clip.w <= 1e-6f) return std::nullopt;
  const glm::vec2 ndc(clip.x / clip.w, clip.y / clip.w);  // Vulkan: y already points down
  return glm::vec2((ndc.x * 0.5f + 0.5f) * size.x, (ndc.y * 0.5f + 0.5f) * size.y);
}

Aabb world_bounds(World& world) {
  Aabb bounds;
  world.each<Mesh, WorldTransform>([&](Mesh& m, WorldTransform& wt) {
    if (!m.data || m.data->bounds.empty()) return;
    const Aabb& b = m.data->bounds;
    for (int c = 0; c < 8; ++c)
      bounds.extend(glm::vec3(wt.matrix * glm::vec4((c & 1) ? b.max.x : b.min.x, (c & 2) ? b.max.y : b.min.y,
                                                    (c & 4) ? b.max.z : b.min.z, 1.0f)));
  });
  return bounds;
}

glm::vec3 irradiance_colour(glm::vec3 e, float exposure) {
  const glm::vec3 x = glm::max(e * exposure, glm::vec3(0.0f));
  return x / (glm::vec3(1.0f) + x);
}

namespace {

ImU32 to_imgui(glm::vec3 c, float alpha = 1.0f) {
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

}  // namespace

int draw_probe_overlay(World& world, const CameraView& camera, glm::vec2 size, const ProbeOverlay& options,
                       ImDrawList* dl) {
  int drawn = 0;
  for (Entity e : world.view<IrradianceProbeGrid, WorldTransform>().sorted_entities()) {
    const IrradianceProbeGrid& grid = world.get<IrradianceProbeGrid>(e);
    const ProbeGridData* data = grid.data.get();
    // Bounds: of the baked layout when there is data, else of the authored settings.
    if (options.bounds) {
      if (data) {
        draw_box(dl, camera, size, data->layout.grid_to_world, IM_COL32(255, 220, 60, 220));
      } else if (auto layout = probe_grid_layout(grid, world.get<WorldTransform>(e).matrix, "probe grid"); layout) {
        draw_box(dl, camera, size, layout->grid_to_world, IM_COL32(255, 220, 60, 140));
      }
    }
    if (!data || (!options.probes && !options.invalid)) continue;
    const std::size_t count = data->node_count();
    const std::size_t stride =
        std::max<std::size_t>(1, count / static_cast<std::size_t>(std::max(options.max_points, 1)));
    const glm::uvec3 r = data->layout.resolution;
    for (std::size_t n = 0; n < count; n += stride) {
      const glm::uvec3 ijk(static_cast<unsigned>(n % r.x), static_cast<unsigned>((n / r.x) % r.y),
                           static_cast<unsigned>(n / (std::size_t{r.x} * r.y)));
      const glm::vec3 p = data->layout.node_position(ijk);
      const auto s = project(camera, p, size);
      if (!s || s->x < 0 || s->y < 0 || s->x > size.x || s->y > size.y) continue;
      const bool invalid = data->filled[n] != 0;
      if (invalid && options.invalid) {
        dl->AddCircle(ImVec2(s->x, s->y), 4.0f, IM_COL32(255, 40, 40, 255), 8, 2.0f);
      } else if (!invalid && options.probes) {
        const glm::vec3 c = irradiance_colour(sh_evaluate_non_negative(data->node(n), glm::vec3(0, 1, 0)), options.exposure);
        dl->AddCircleFilled(ImVec2(s->x, s->y), 3.5f, to_imgui(c));
        dl->AddCircle(ImVec2(s->x, s->y), 3.5f, IM_COL32(0, 0, 0, 160), 8, 1.0f);
      }
      ++drawn;
    }
  }
  return drawn;
}

}  // namespace penumbra::editor
