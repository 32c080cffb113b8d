// The bake driver that bake_world and bake_shard share (internal to penumbra_bake).
#pragma once

#include <chrono>
#include <functional>
#include <vector>

#include "penumbra/bake/baker.h"

namespace penumbra {

// Seconds from `start` to now (steady clock).
double seconds_since(std::chrono::steady_clock::time_point start);

// What a driver does with one baker's plan: run some of its groups' elements, record in `item`.
using DriveStep = std::function<Status(const Baker& baker, BakeWork& work, BakeReport::Item& item)>;

// Builds the ray scene once (static geometry), then per baker in order: plan() and `step` (timed
// into report.items). Errors are prefixed with the baker's name.
Status drive_bake(World& world, const std::vector<const Baker*>& bakers, const BakeSettings& settings,
                  JobContext& jobs, BakeReport& report, const DriveStep& step);

// baker.finish() over `groups` and their results (one byte vector per group).
Result<std::vector<BakeChunk>> finish_groups(const Baker& baker, const std::vector<BakeGroup>& groups,
                                             const std::vector<std::vector<std::byte>>& results, JobContext& jobs);

}  // namespace penumbra
