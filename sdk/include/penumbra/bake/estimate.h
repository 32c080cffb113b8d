// What a bake will cost before it runs: time and bytes per baker and per group (a group is what
// one lighting component bakes, named by its entity key), extrapolated from a few measured samples
// of the bake itself.
//
// Per baker: plan() on the scene's RayScene as bake_world does; per group, `ranges` runs of
// consecutive elements spread evenly over it, each long enough to keep every worker busy, timed:
// the group's seconds are the measured seconds per element times its elements. A group no larger
// than the samples runs whole (exact). Then finish() on results where every element takes the
// results of the nearest sampled element, timed, and the bytes of the chunks it makes. That needs
// a fixed size of result per element; a baker whose elements' results vary in size (the transport's
// links per patch) gets its run estimate only (finish and bytes known after the bake).
// Extrapolation from samples: a data-driven layout (pose-AO's fitted locality and clusters) sees
// fewer distinct elements than the bake, so its bytes are an estimate, not a bound.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "penumbra/bake/baker.h"

namespace penumbra {

struct BakeEstimate {
  struct Group {
    std::string baker;
    std::string name;            // BakeGroup::name: the entity key of what it bakes
    std::uint64_t elements = 0;
    std::uint64_t sampled = 0;   // elements run to measure it (== elements: exact)
    double seconds = 0.0;        // estimated time of running all its elements
  };
  struct Item {
    std::string baker;
    double seconds = 0.0;                 // plan + every group's run estimate + finish
    double finish_seconds = 0.0;          // measured finish() on the extrapolated results (0 when unknown)
    std::optional<std::uint64_t> bytes;   // of the chunks; unknown when results vary in size per element
    double sampled_seconds = 0.0;         // what the estimate itself spent on this baker
  };
  // A chunk finish() made from the extrapolated results: the entity key it belongs to
  // (Baker::chunk_key; "" for a scene-wide one) and its bytes. Per component where items are per module.
  struct Part {
    std::string baker;
    std::string key;
    std::uint64_t bytes = 0;
  };
  double ray_scene_seconds = 0.0;
  std::vector<Group> groups;
  std::vector<Item> items;
  std::vector<Part> parts;
  // The whole bake's estimate: the RayScene plus every item.
  double seconds() const;
};

// Estimates a bake of `names` (all registered bakers when empty) with `settings` as above, with
// `ranges` sample runs per group (>= 1). The World must be up to date, as for bake_world; it is
// not changed (nothing is attached). Errors as bake_world's, and those of finish() on the
// extrapolated results, prefixed with the baker's name. Cost: the RayScene, up to `ranges` x
// max(block, 4 x workers) elements per group, and one finish() per baker.
Result<BakeEstimate> estimate_bake(World& world, const std::vector<std::string>& names, const BakeSettings& settings,
                                   JobContext& jobs, std::uint32_t ranges = 4);

}  // namespace penumbra
