// What the editor's inspector shows about a pose-AO character, kept out of the app so that tests
// check it: statistics of its per-vertex AO and a summary of its baked data. Plain functions over a
// World; main thread (they read components). Part of the editor (pose_ao_editor.cpp draws them).
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>

#include "penumbra/core/result.h"
#include "penumbra/ecs/world.h"

namespace penumbra::editor {

// Summary of per-vertex AO values (1 = open): range, mean and a histogram of kBins equal bins over
// [0, 1] (a value of 1 falls in the last bin).
struct AOStats {
  static constexpr std::size_t kBins = 20;
  std::size_t count = 0;
  float min = 0.0f, mean = 0.0f, max = 0.0f;
  std::array<std::uint32_t, kBins> histogram{};
};
// Statistics of `ao` (values outside [0, 1] are clamped into the end bins; NaNs are skipped).
// O(n). Thread-safe.
AOStats ao_stats(std::span<const float> ao);

// What the inspector shows for a skinned mesh with baked pose-AO.
struct PoseAOSummary {
  bool baked = false;
  std::uint64_t bytes = 0;         // held in memory (PoseAOData::bytes)
  double bytes_per_vertex = 0.0;   // stored
  std::size_t joint_sets = 0;      // groups of vertices sharing a joint set
  std::uint32_t vertices = 0, joints = 0, poses = 0, rays_per_vertex = 0, locality = 0, requested_locality = 0;
  std::uint32_t clusters = 0, requested_clusters = 0;  // the most any joint set uses, and asked for
  float lambda = 0.0f;
  float training_rmse = 0.0f;      // of the clamped model over the reference poses
  bool has_values = false;         // the system has written this frame's AO
  AOStats current;                 // of this frame's per-vertex AO (the system's output)
};
// NotFound when the entity has no SkinnedPoseAO. Cost: O(vertices).
Result<PoseAOSummary> pose_ao_summary(World& world, Entity mesh);

}  // namespace penumbra::editor
