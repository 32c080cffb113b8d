// Sharded bakes: one bake split over machines (a Slurm job array, a Kubernetes Indexed Job), each
// shard baking some of the work items into a part file, and the merge that turns the parts into
// the file a single machine writes, byte for byte.
//
// Work items are the blocks of every baker's groups (BakeGroup, baker.h). Which shard bakes an
// item: per baker in registration order, its items by decreasing estimated cost (ties: plan
// order) each go to the shard with the least estimated work so far (ties: the lowest index), the
// loads carried from one baker to the next (longest processing time first; Graham 1969, "Bounds on
// multiprocessing timing anomalies"). Every shard and the merge compute the same assignment from
// the same plan.
//
// A part is a .pbake whose header holds part_input_hash() (so it is never taken for a whole bake,
// and `penumbra bake --shard` finds an up-to-date part by it), with
//   chunk 'SHRD' v1   the manifest: the bake's input hash, shard I of N, preset, seed, the scene
//                     argument, and every group of every selected baker (name, elements, block,
//                     cost, header): all a merge needs besides the items' results;
//   chunk 'SITM' v1   per work item of this shard: baker and group index, block index, results.
// The global steps (the probe grid's fill, fit and convolution; the AO-field grid's inside fill;
// the pose-AO fit) are each baker's finish(), which the merge runs.
#pragma once

#include <cstdint>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "penumbra/bake/baker.h"

namespace penumbra {

inline constexpr std::uint32_t kShardItemChunk = fourcc("SITM");
inline constexpr std::uint32_t kShardChunkVersion = 1;
inline constexpr std::uint32_t kMaxShards = 4096;

// Shard `index` of `count` (0 <= index < count <= kMaxShards).
struct ShardSpec {
  std::uint32_t index = 0;
  std::uint32_t count = 1;
};
// "I/N" (I from 0, as Slurm's SLURM_ARRAY_TASK_ID of --array=0-N-1). InvalidArgument naming the
// text and the form otherwise.
Result<ShardSpec> parse_shard(std::string_view text);

// The input hash a part's header holds: the bake's input hash mixed with the shard.
std::uint64_t part_input_hash(std::uint64_t bake_input_hash, ShardSpec shard);

// The shard of each work item: owners[i] for item i of `costs` (one baker's items in plan order),
// given the estimated loads so far (updated). Cost: O(items log items + items x shards).
std::vector<std::uint32_t> assign_items(std::span<const double> costs, std::vector<double>& loads);

// A work item's stable id, "<baker>:<group>#<block>".
std::string item_id(std::string_view baker, std::string_view group, std::uint64_t block);

// Bakes the work items of shard `shard` of the bake of `names` with `settings` into a part file
// (report: per baker the items baked and their time). `scene` is what the manifest names the
// scene by in messages. The World must be up to date, as for bake_world.
Result<BakeResult> bake_shard(World& world, const std::vector<std::string>& names, const BakeSettings& settings,
                              ShardSpec shard, std::string_view scene, JobContext& jobs);

// A part file's contents, parsed.
struct BakePart {
  struct Baker {
    std::string name;
    std::vector<BakeGroup> groups;
  };
  struct Item {
    std::uint32_t baker = 0;  // index into bakers
    std::uint32_t group = 0;  // index into bakers[baker].groups
    std::uint64_t block = 0;
    std::vector<std::byte> results;
  };
  std::uint64_t input_hash = 0;  // the whole bake's
  ShardSpec shard;
  Preset preset = Preset::Medium;
  std::uint64_t seed = 0;
  std::string sdk_version;
  std::string scene;
  std::vector<Baker> bakers;
  std::vector<Item> items;
};

// Reads a part with every check: one manifest, items that name existing groups and blocks with
// results. InvalidInput naming `context` (the file) and the element; for a whole bake (no
// manifest) the message says to give part files.
Result<BakePart> read_bake_part(const BakeFile& file, std::string_view context);

// A part as read from disk, with the path messages name it by.
struct NamedPart {
  std::string path;
  BakePart part;
};

// What a merge did: per baker the time of its global steps.
struct MergeReport {
  struct Item {
    std::string baker;
    double seconds = 0.0;
    std::uint64_t bytes = 0;
    std::size_t items = 0;
  };
  std::vector<Item> items;
};

// Merges the parts of one sharded bake into the file a single machine writes: checks that every
// part comes from the same inputs and settings (naming the parts and what differs), that no item
// is missing (naming it and the shard that bakes it) or given twice (naming both parts), then
// runs each baker's finish() over the items' results in order and checks every chunk with its
// module's reader (InvalidInput: a corrupt part). `registry` supplies finish();
// Unsupported when a part names a baker it lacks or was written by another SDK version.
Result<BakeFile> merge_bake_parts(const BakerRegistry& registry, std::span<const NamedPart> parts, JobContext& jobs,
                                  MergeReport* report = nullptr);

}  // namespace penumbra
