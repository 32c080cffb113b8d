// The editor's pose-AO views (see pose_ao_views.h).
#include "pose_ao_views.h"

#include <algorithm>
#include <cmath>

#include "penumbra/pose_ao/pose_ao.h"
#include "penumbra/pose_ao/pose_ao_system.h"
#include "penumbra/scene/components.h"

namespace penumbra::editor {

AOStats ao_stats(std::span<const float> ao) {
  AOStats s;
  double sum = 0.0;
  for (float v : ao) {
    if (std::isnan(v)) continue;
    const float c = std::clamp(v, 0.0f, 1.0f);
    if (s.count == 0) s.min = s.max = c;
    s.min = std::min(s.min, c);
    s.max = std::max(s.max, c);
    sum += c;
    const auto bin = std::min<std::size_t>(AOStats::kBins - 1, static_cast<std::size_t>(c * AOStats::kBins));
    ++s.histogram[bin];
    ++s.count;
  }
  s.mean = s.count ? static_cast<float>(sum / static_cast<double>(s.count)) : 0.0f;
  return s;
}

Result<PoseAOSummary> pose_ao_summary(World& world, Entity e) {
  const SkinnedPoseAO* settings = world.alive(e) ? world.try_get<SkinnedPoseAO>(e) : nullptr;
  if (!settings)
    return make_error(ErrorCode::NotFound, "pose-AO: entity #" + std::to_string(e.index) +
                                               " has no SkinnedPoseAO; select a skinned mesh");
  PoseAOSummary s;
  if (const PoseAOData* d = settings->data.get()) {
    s.baked = true;
    s.bytes = d->bytes();
    s.bytes_per_vertex = d->bytes_per_vertex();
    s.joint_sets = d->groups.size();
    s.vertices = d->vertex_count;
    s.joints = d->joint_count;
    s.poses = d->poses;
    s.rays_per_vertex = d->rays_per_vertex;
    s.locality = d->locality;
    s.requested_locality = d->requested_locality;
    s.clusters = d->clusters;
    s.requested_clusters = d->requested_clusters;
    s.lambda = d->lambda;
    s.training_rmse = d->training_rmse;
  }
  if (const VertexAO* values = world.try_get<VertexAO>(e); values && !values->ao.empty()) {
    s.has_values = true;
    s.current = ao_stats(values->ao);
  }
  return s;
}

}  // namespace penumbra::editor
