// AO fields in the editor (extension.h): the baked field's summary, the selected caster's bounds and
// a floor slice coloured by its occlusion (recomputed every frame, so it follows a dragged caster),
// and the ao-field bench's plot.
#include <algorithm>

#include <glm/common.hpp>
#include <imgui.h>

#include "ao_field_views.h"
#include "extension.h"
#include "overlays.h"
#include "penumbra/ao_field/ao_field.h"
#include "penumbra/core/memory.h"

namespace penumbra::editor {
namespace {

// Every overlay starts off: the View panel turns them on.
struct Overlay {
  bool bounds = false;  // the hull (radial fit) or grid cube, and the falloff sphere
  bool slice = false;   // once baked
  int resolution = 32;  // slice points per side (~0.1 ms at 32)
  float height = 0.0f;  // of the slice above the caster's lowest point, metres
};
Overlay& overlay() {
  static Overlay o;
  return o;
}

bool applies(World& w, Entity e) { return w.has<AOFieldCaster>(e); }

void inspector(World& w, Entity e) {
  if (!applies(w, e)) return;
  const AOFieldData* d = w.get<AOFieldCaster>(e).data.get();
  if (d == nullptr) {
    ImGui::TextDisabled("not baked");
    return;
  }
  if (d->representation == AOFieldRepresentation::Grid)
    ImGui::Text("baked: grid %u^3, %s", d->grid_size, format_bytes(d->bytes()).c_str());
  else
    ImGui::Text("baked: radial fit %u^2 x 6 texels, %s, %u clamped fits", d->resolution,
                format_bytes(d->bytes()).c_str(), d->clamped_fits);
  ImGui::TextDisabled("centre %.3g %.3g %.3g, bounding radius %.3g, falloff %.3g (mesh units)", d->centre.x,
                      d->centre.y, d->centre.z, d->bounding_radius, d->r_far);
}

void view_options(ViewContext&) {
  Overlay& o = overlay();
  ImGui::Checkbox("AO field bounds", &o.bounds);
  ImGui::SameLine();
  ImGui::Checkbox("AO field slice", &o.slice);
  ImGui::SameLine();
  ImGui::SetNextItemWidth(80);
  ImGui::DragFloat("slice height", &o.height, 0.01f, -10.0f, 10.0f, "%.2f m");
}

// The selected caster's bounds and slice (nothing when the selection casts no AO field).
void draw_overlay(ViewContext& view, ImDrawList* dl) {
  const Overlay& options = overlay();
  World& world = view.world;
  const Entity caster = view.selection;
  if (!world.alive(caster) || !world.has<AOFieldCaster>(caster)) return;
  if (options.bounds) {
    if (auto b = ao_field_bounds(world, caster); b) {
      for (const auto& loop : b->falloff) draw_loop(dl, view.camera, view.size, loop, IM_COL32(120, 200, 255, 150));
      for (const auto& loop : b->hull)
        draw_loop(dl, view.camera, view.size, loop, IM_COL32(255, 150, 40, b->baked ? 230 : 120));
    }
  }
  if (!options.slice) return;
  AOFieldSliceRequest request;
  request.resolution = options.resolution;
  request.height = options.height;
  auto slice = ao_field_slice(world, caster, request);
  if (!slice) return;  // not baked yet
  for (std::size_t i = 0; i < slice->points.size(); ++i) {
    const auto s = project(view.camera, slice->points[i], view.size);
    if (!s || s->x < 0 || s->y < 0 || s->x > view.size.x || s->y > view.size.y) continue;
    // Occlusion 0 (open) dim blue, rising through magenta to white at 0.5 and above.
    const float a = slice->occlusion[i];
    const float t = std::clamp(a / 0.5f, 0.0f, 1.0f);
    const glm::vec3 c = a > 0.0f ? glm::mix(glm::vec3(0.3f, 0.2f, 0.9f), glm::vec3(1.0f, 0.3f, 0.6f), std::min(2.0f * t, 1.0f))
                                 : glm::vec3(0.2f, 0.3f, 0.5f);
    const glm::vec3 shown = t > 0.5f ? glm::mix(c, glm::vec3(1.0f), 2.0f * t - 1.0f) : c;
    dl->AddCircleFilled(ImVec2(s->x, s->y), a > 0.0f ? 3.0f : 1.5f, to_imgui(shown, a > 0.0f ? 0.9f : 0.5f));
  }
}

CostPlotSource cost_plot(World& w, Entity e) {
  if (!w.alive(e) || !w.has<AOFieldCaster>(e)) return {"ao-field", "mae", "", ""};
  return {"ao-field", "mae", "representation", to_string(w.get<AOFieldCaster>(e).representation)};
}

}  // namespace

PENUMBRA_EDITOR_EXTENSION({.module = "ao-field",
                           .tag = "ao field",
                           .applies = applies,
                           .inspector = inspector,
                           .view_options = view_options,
                           .draw_overlay = draw_overlay,
                           .cost_plot = cost_plot});

}  // namespace penumbra::editor
