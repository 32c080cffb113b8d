// Viewport visualisations (overlays.h).
#include "overlays.h"

#include <algorithm>
#include <cmath>
#include <vector>

#include <glm/common.hpp>

#include <imgui.h>

#include "lighting_views.h"
#include "penumbra/ao_field/ao_field.h"
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

// A closed polyline through world points; segments with an end behind the camera are skipped.
void draw_loop(ImDrawList* dl, const CameraView& camera, glm::vec2 size, const std::vector<glm::vec3>& loop,
               ImU32 colour) {
  for (std::size_t i = 0; i < loop.size(); ++i) {
    const auto a = project(camera, loop[i], size), b = project(camera, loop[(i + 1) % loop.size()], size);
    if (a && b) dl->AddLine(ImVec2(a->x, a->y), ImVec2(b->x, b->y), colour, 1.5f);
  }
}

}  // namespace

int draw_ao_field_overlay(World& world, Entity caster, const CameraView& camera, glm::vec2 size,
                          const AOFieldOverlay& options, ImDrawList* dl) {
  if (!world.alive(caster) || !world.has<AOFieldCaster>(caster)) return 0;
  if (options.bounds) {
    if (auto b = ao_field_bounds(world, caster); b) {
      for (const auto& loop : b->falloff) draw_loop(dl, camera, size, loop, IM_COL32(120, 200, 255, 150));
      for (const auto& loop : b->hull) draw_loop(dl, camera, size, loop, IM_COL32(255, 150, 40, b->baked ? 230 : 120));
    }
  }
  if (!options.slice) return 0;
  AOFieldSliceRequest request;
  request.resolution = options.resolution;
  request.height = options.height;
  auto slice = ao_field_slice(world, caster, request);
  if (!slice) return 0;  // not baked yet
  int drawn = 0;
  for (std::size_t i = 0; i < slice->points.size(); ++i) {
    const auto s = project(camera, slice->points[i], size);
    if (!s || s->x < 0 || s->y < 0 || s->x > size.x || s->y > size.y) continue;
    // Occlusion 0 (open) dim blue, rising through magenta to white at 0.5 and above.
    const float a = slice->occlusion[i];
    const float t = std::clamp(a / 0.5f, 0.0f, 1.0f);
    const glm::vec3 c = a > 0.0f ? glm::mix(glm::vec3(0.3f, 0.2f, 0.9f), glm::vec3(1.0f, 0.3f, 0.6f), std::min(2.0f * t, 1.0f))
                                 : glm::vec3(0.2f, 0.3f, 0.5f);
    const glm::vec3 shown = t > 0.5f ? glm::mix(c, glm::vec3(1.0f), 2.0f * t - 1.0f) : c;
    dl->AddCircleFilled(ImVec2(s->x, s->y), a > 0.0f ? 3.0f : 1.5f, to_imgui(shown, a > 0.0f ? 0.9f : 0.5f));
    ++drawn;
  }
  return drawn;
}

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
