// Pose-AO in the editor (extension.h): the baked model's summary with this frame's per-vertex AO
// as a histogram, and the pose-ao bench's plot.
#include <cfloat>

#include <imgui.h>

#include "extension.h"
#include "penumbra/core/memory.h"
#include "penumbra/pose_ao/pose_ao.h"
#include "pose_ao_views.h"

namespace penumbra::editor {
namespace {

bool applies(World& w, Entity e) { return w.has<SkinnedPoseAO>(e); }

void inspector(World& w, Entity e) {
  if (!applies(w, e)) return;
  auto s = pose_ao_summary(w, e);
  if (!s || !s->baked) {
    ImGui::TextDisabled("not baked");
  } else {
    ImGui::Text("baked: %s (%.1f B per vertex stored), %zu joint sets", format_bytes(s->bytes).c_str(),
                s->bytes_per_vertex, s->joint_sets);
    ImGui::TextDisabled("%u vertices, %u joints, %u poses x %u rays, locality %u of %u, clusters %u of %u, lambda %.3g",
                        s->vertices, s->joints, s->poses, s->rays_per_vertex, s->locality, s->requested_locality,
                        s->clusters, s->requested_clusters, static_cast<double>(s->lambda));
    ImGui::Text("training RMSE %.4f", static_cast<double>(s->training_rmse));
    if (s->has_values) {
      // This frame's per-vertex AO (the pose-ao system's output), 1 = open.
      ImGui::Text("this frame: AO min %.3f mean %.3f max %.3f", static_cast<double>(s->current.min),
                  static_cast<double>(s->current.mean), static_cast<double>(s->current.max));
      float bins[AOStats::kBins];
      for (std::size_t i = 0; i < AOStats::kBins; ++i) bins[i] = static_cast<float>(s->current.histogram[i]);
      ImGui::PlotHistogram("##poseao", bins, static_cast<int>(AOStats::kBins), 0, "vertices by AO, 0 .. 1", 0.0f,
                           FLT_MAX, ImVec2(-1, 60));
    }
  }
}

CostPlotSource cost_plot(World&, Entity) { return {"pose-ao", "rmse", "method", "linear"}; }

}  // namespace

PENUMBRA_EDITOR_EXTENSION({.module = "pose-ao",
                           .tag = "pose ao",
                           .applies = applies,
                           .inspector = inspector,
                           .cost_plot = cost_plot});

}  // namespace penumbra::editor
