// The probe grid in the editor (extension.h): the baked grid's summary, the node and bounds overlay,
// the error heat map against the path-traced reference, and the probe-grid bench's plot.
#include <algorithm>
#include <cmath>
#include <optional>

#include <imgui.h>

#include "extension.h"
#include "overlays.h"
#include "penumbra/core/memory.h"
#include "penumbra/core/sh.h"
#include "penumbra/ecs/transform.h"
#include "penumbra/probe_grid/probe_grid.h"
#include "probe_grid_views.h"

namespace penumbra::editor {
namespace {

// The node overlays start off (the View panel turns them on); the grid box, the probe volume's
// icon, is on.
struct ProbeOverlay {
  bool probes = false;     // node positions coloured by E(+Y)
  bool invalid = false;    // nodes without an in-domain sample (filled by dilation) as red rings
  bool bounds = true;      // the grid box: the probe volume's icon (12 lines a grid)
  float exposure = 0.3f;   // the courtyard's nodes see 1-10 W/m^2
  int max_points = 20000;  // per grid; larger grids are subsampled by a stride
};

// The View panel's state: the overlay's options and the heat map, computed on demand for the
// camera of the moment and shown until cleared.
struct State {
  ProbeOverlay overlay;
  int reference_paths = 256;  // per cell: its noise falls as 1 / sqrt(paths), its cost grows with them
  ErrorMapJob error_job;
  std::optional<ErrorMap> error_map;
};
State& state() {
  static State s;
  return s;
}

bool applies(World& w, Entity e) { return w.has<IrradianceProbeGrid>(e); }

void inspector(World& w, Entity e) {
  if (const ProbeLit* lit = w.try_get<ProbeLit>(e)) {
    const glm::vec3 up = probe_lit_irradiance(*lit, glm::vec3(0, 1, 0));
    ImGui::TextDisabled("ProbeLit: E(up) = %.3g %.3g %.3g W/m^2%s", up.x, up.y, up.z, lit->covered ? "" : " (no grid)");
  }
  if (!applies(w, e)) return;
  const IrradianceProbeGrid& g = w.get<IrradianceProbeGrid>(e);
  if (!g.data) {
    ImGui::TextDisabled("not baked");
    return;
  }
  const ProbeGridData& d = *g.data;
  ImGui::Text("baked: %ux%ux%u nodes, %s, %.0f%% valid, %s", d.layout.resolution.x, d.layout.resolution.y,
              d.layout.resolution.z, to_string(d.sampling), 100.0 * d.valid_fraction(), format_bytes(d.bytes()).c_str());
}

void view_options(ViewContext& view) {
  State& s = state();
  if (s.error_job.running()) {
    ImGui::Button("Error heat map: computing...");
  } else if (ImGui::Button("Error heat map")) {
    ErrorMapRequest request;
    request.camera = view.camera;
    request.reference.samples = static_cast<std::uint32_t>(s.reference_paths);
    const Status started = s.error_job.start(view.world, request);
    view.message = started ? "computing the error map" : started.error().message;
  }
  if (auto done = s.error_job.take()) {
    if (done->ok()) s.error_map = std::move(done->value());
    else view.message = done->error().message;
  }
  ImGui::SameLine();
  ImGui::SetNextItemWidth(140.0f);
  ImGui::SliderInt("reference paths", &s.reference_paths, 16, 4096, "%d", ImGuiSliderFlags_Logarithmic);
  if (ImGui::IsItemHovered())
    ImGui::SetTooltip("path-traced estimates per cell of the reference: its noise falls as 1 / sqrt(paths)");
  if (s.error_map) {
    const ErrorMap& m = *s.error_map;
    // The error is reported only where it stands above the reference's own noise.
    if (m.above_noise())
      ImGui::Text("error %.1f%% (mean |E_probe - E_ref| / E_ref %.1f%%, reference noise %.1f%% taken out) over %u "
                  "cells, %.1f s",
                  100.0 * m.noise_corrected_rms, 100.0 * m.mean, 100.0 * m.reference_noise, m.cells, m.seconds);
    else
      ImGui::Text("error below the reference's noise (%.1f%%; mean |E_probe - E_ref| / E_ref %.1f%%) over %u cells: "
                  "raise the reference paths",
                  100.0 * m.reference_noise, 100.0 * m.mean, m.cells);
    ImGui::SameLine();
    if (ImGui::SmallButton("clear")) s.error_map.reset();
  }
  ImGui::Checkbox("probes", &s.overlay.probes);
  ImGui::SameLine();
  ImGui::Checkbox("invalid probes", &s.overlay.invalid);
  ImGui::SameLine();
  ImGui::Checkbox("grid bounds", &s.overlay.bounds);
}

// Every IrradianceProbeGrid: its bounds always, its nodes once baked.
void draw_overlay(ViewContext& view, ImDrawList* dl) {
  const State& s = state();
  if (s.error_map) draw_error_map(*s.error_map, view.size, dl);
  const ProbeOverlay& options = s.overlay;
  World& world = view.world;
  for (Entity e : world.view<IrradianceProbeGrid, WorldTransform>().sorted_entities()) {
    const IrradianceProbeGrid& grid = world.get<IrradianceProbeGrid>(e);
    const ProbeGridData* data = grid.data.get();
    // Bounds: of the baked layout when there is data, else of the authored settings.
    if (options.bounds) {
      if (data) {
        draw_box(dl, view.camera, view.size, data->layout.grid_to_world, IM_COL32(255, 220, 60, 220));
      } else if (auto layout = probe_grid_layout(grid, world.get<WorldTransform>(e).matrix, "probe grid"); layout) {
        draw_box(dl, view.camera, view.size, layout->grid_to_world, IM_COL32(255, 220, 60, 140));
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
      const auto p = project(view.camera, data->layout.node_position(ijk), view.size);
      if (!p || p->x < 0 || p->y < 0 || p->x > view.size.x || p->y > view.size.y) continue;
      const bool invalid = data->filled[n] != 0;
      if (invalid && options.invalid) {
        dl->AddCircle(ImVec2(p->x, p->y), 4.0f, IM_COL32(255, 40, 40, 255), 8, 2.0f);
      } else if (!invalid && options.probes) {
        const glm::vec3 c =
            irradiance_colour(sh_evaluate_non_negative(data->node(n), glm::vec3(0, 1, 0)), options.exposure);
        // Two quads a node (a dark edge under the colour): 8 vertices, where a ring and a disc
        // took ~50, so that a large grid's overlay stays cheap for the software rasteriser.
        dl->AddRectFilled(ImVec2(p->x - 3.5f, p->y - 3.5f), ImVec2(p->x + 3.5f, p->y + 3.5f), IM_COL32(0, 0, 0, 160));
        dl->AddRectFilled(ImVec2(p->x - 2.5f, p->y - 2.5f), ImVec2(p->x + 2.5f, p->y + 2.5f), to_imgui(c));
      }
    }
  }
}

CostPlotSource cost_plot(World& w, Entity e) {
  if (!w.alive(e) || !w.has<IrradianceProbeGrid>(e)) return {"probe-grid", "rmse", "", ""};
  const IrradianceProbeGrid& g = w.get<IrradianceProbeGrid>(e);
  return {"probe-grid", "rmse", "mode", std::string(to_string(g.sampling)) + (g.leak_guard ? "+guard" : "")};
}

}  // namespace

PENUMBRA_EDITOR_EXTENSION({.module = "probe-grid",
                           .tag = "probes",
                           .applies = applies,
                           .inspector = inspector,
                           .view_options = view_options,
                           .draw_overlay = draw_overlay,
                           .cost_plot = cost_plot});

}  // namespace penumbra::editor
