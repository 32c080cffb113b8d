// The indirect transport in the editor (extension.h): the baked operator and this frame's
// lightmap in the inspector (on the settings entity, on each receiving mesh, on each dynamic
// light), in the viewport a marker on each dynamic light, which Ctrl + left drag moves (the bounce
// light follows live), and the patches' outlines (the selected receiver's with its leaf texels),
// and the indirect-transport bench's plot.
#include <string>
#include <vector>

#include <glm/geometric.hpp>

#include <imgui.h>

#include "extension.h"
#include "indirect_transport_views.h"
#include "overlays.h"
#include "penumbra/core/memory.h"
#include "penumbra/ecs/transform.h"
#include "penumbra/indirect_transport/indirect_transport.h"
#include "penumbra/scene/components.h"
#include "penumbra/scene/entity_key.h"

namespace penumbra::editor {
namespace {

// The View panel's options and the drag in progress (main thread only, as every extension).
struct State {
  bool patches = false;
  Entity dragged;
};
State& state() {
  static State s;
  return s;
}

bool applies(World& w, Entity e) {
  return w.has<IndirectTransport>(e) || w.has<IndirectReceiver>(e) || w.has<DynamicLight>(e);
}

void irradiance_line(const char* what, const IrradianceStats& s) {
  ImGui::Text("%s: mean %.4g, max %.4g W/m^2 over %zu texels", what, static_cast<double>(s.mean),
              static_cast<double>(s.max), s.leaves);
}

void inspector(World& w, Entity e) {
  if (auto s = transport_summary(w, e)) {
    if (!s->baked) {
      ImGui::TextDisabled("not baked (%zu receiving meshes, %zu dynamic lights)", s->receivers, s->dynamic_lights);
    } else {
      ImGui::Text("baked: %s, %u patches, %u texels (finest level %u)", format_bytes(s->bytes).c_str(), s->patches,
                  s->leaves, s->finest_level);
      ImGui::TextDisabled("threshold %.3g: %llu links, %llu direct coefficients; %u Neumann terms%s (last %.2g of "
                          "the sum), %llu global coefficients",
                          static_cast<double>(s->refinement_threshold), static_cast<unsigned long long>(s->links),
                          static_cast<unsigned long long>(s->direct_coefficients), s->terms,
                          s->converged ? "" : " (not converged)", static_cast<double>(s->last_term_ratio),
                          static_cast<unsigned long long>(s->global_coefficients));
      ImGui::Text("%zu dynamic lights (%zu fixed: their bounce baked), %zu receiving meshes", s->dynamic_lights,
                  s->fixed_lights, s->receivers);
      if (!s->moving_lights)
        ImGui::TextDisabled("no light moved when it baked: no operator kept; a light set to move needs a re-bake");
      if (s->has_lightmap) {
        ImGui::Text("last update: %u significant direct coefficients", s->kept_coefficients);
        irradiance_line("direct", s->direct);
        irradiance_line("indirect", s->indirect);
      }
    }
  }
  if (auto r = receiver_summary(w, e)) {
    if (!r->baked) {
      ImGui::TextDisabled("receives bounce light once the transport is baked");
    } else if (r->patches == 0) {
      ImGui::TextDisabled("no patches in the bake (re-bake: it was baked before this mesh received)");
    } else {
      ImGui::Text("%u patches, %u texels, %.2f m^2", r->patches, r->leaves, static_cast<double>(r->area));
      if (r->indirect.leaves > 0) irradiance_line("indirect on it", r->indirect);
    }
  }
  if (const DynamicLight* d = w.try_get<DynamicLight>(e))
    ImGui::TextDisabled(d->enabled ? "dynamic: its bounce light follows it (Ctrl + drag it in the viewport)"
                                   : "dynamic, disabled: sends no bounce light");
}

void view_options(ViewContext&) {
  ImGui::Checkbox("Bounce patches", &state().patches);
  if (ImGui::IsItemHovered())
    ImGui::SetTooltip("Outlines of the indirect transport's patches; the selected receiver's with its texels");
}

// The outlines of the baked patches; the selected receiver's in white with its leaf grid.
void draw_patches(ViewContext& view, ImDrawList* dl) {
  const TransportData* data = nullptr;
  view.world.view<const IndirectTransport>().each([&](const IndirectTransport& t) {
    if (!data && t.data) data = t.data.get();
  });
  if (!data) return;
  const std::string selected = view.selection && view.world.has<IndirectReceiver>(view.selection)
                                   ? entity_key(view.world, view.selection)
                                   : std::string();
  for (const TransportPatch& p : data->patches) {
    const bool mine = !selected.empty() && p.key == selected;
    const unsigned colour = mine ? IM_COL32(255, 255, 255, 230) : IM_COL32(90, 200, 255, 140);
    draw_loop(dl, view.camera, view.size,
              {p.origin, p.origin + p.edge_u, p.origin + p.edge_u + p.edge_v, p.origin + p.edge_v}, colour);
    if (!mine) continue;
    const float n = static_cast<float>(p.side());
    for (std::uint32_t k = 1; k < p.side(); ++k) {
      const float f = static_cast<float>(k) / n;
      draw_loop(dl, view.camera, view.size, {p.origin + f * p.edge_u, p.origin + f * p.edge_u + p.edge_v},
                IM_COL32(255, 255, 255, 90));
      draw_loop(dl, view.camera, view.size, {p.origin + f * p.edge_v, p.origin + f * p.edge_v + p.edge_u},
                IM_COL32(255, 255, 255, 90));
    }
  }
}

// A ring with a cross on each dynamic light, so that the lights whose bounce follows them are found
// at a glance; Ctrl + left drag on one moves it in the plane facing the camera.
void draw_overlay(ViewContext& view, ImDrawList* dl) {
  State& s = state();
  if (s.patches) draw_patches(view, dl);
  const ImGuiIO& io = ImGui::GetIO();
  const glm::vec2 mouse(io.MousePos.x, io.MousePos.y);
  const bool grab = io.KeyCtrl && !io.WantCaptureMouse && ImGui::IsMouseClicked(ImGuiMouseButton_Left);
  float nearest = 12.0f;  // pixels: how close to a marker a grab must be
  view.world.view<const DynamicLight, const Light, const WorldTransform>().each(
      [&](Entity e, const DynamicLight& d, const Light&, const WorldTransform& wt) {
        const auto p = project(view.camera, glm::vec3(wt.matrix[3]), view.size);
        if (!p) return;
        if (grab && glm::distance(*p, mouse) < nearest) {
          nearest = glm::distance(*p, mouse);
          s.dragged = e;
        }
        const unsigned colour = e == view.selection || e == s.dragged ? IM_COL32(255, 255, 255, 255)
                                : d.enabled                         ? IM_COL32(255, 200, 90, 230)
                                                                    : IM_COL32(140, 140, 140, 200);
        dl->AddCircle(ImVec2(p->x, p->y), 9.0f, colour, 16, 2.0f);
        dl->AddLine(ImVec2(p->x - 5, p->y), ImVec2(p->x + 5, p->y), colour, 1.5f);
        dl->AddLine(ImVec2(p->x, p->y - 5), ImVec2(p->x, p->y + 5), colour, 1.5f);
      });
  if (!s.dragged) return;
  if (!ImGui::IsMouseDown(ImGuiMouseButton_Left) || !view.world.has<WorldTransform>(s.dragged)) {
    s.dragged = Entity::null();
    return;
  }
  const glm::vec2 delta(io.MouseDelta.x, io.MouseDelta.y);
  if (delta == glm::vec2(0.0f)) return;
  const glm::vec3 at(view.world.get<WorldTransform>(s.dragged).matrix[3]);
  move_to(view.world, s.dragged, drag_in_view_plane(view.camera, at, mouse - delta, mouse, view.size));
}

CostPlotSource cost_plot(World&, Entity) { return {"indirect-transport", "rel_rmse_net", "method", "hierarchical"}; }

}  // namespace

PENUMBRA_EDITOR_EXTENSION({.module = "indirect-transport",
                           .tag = "bounce",
                           .applies = applies,
                           .inspector = inspector,
                           .view_options = view_options,
                           .draw_overlay = draw_overlay,
                           .cost_plot = cost_plot});

}  // namespace penumbra::editor
