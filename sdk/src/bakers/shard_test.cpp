// Sharded bakes (penumbra/bake/shard.h) with every module's baker: parts merged in any order are
// the single-machine file byte for byte, at 1, 2, 4 and 7 shards, at any thread count and with each
// representation that has its own global step; the merge names what is missing, duplicated or
// from another bake; the assignment is balanced.
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <numeric>
#include <unistd.h>
#include <string>

#include "penumbra/ao_field/ao_field.h"
#include "penumbra/bake/shard.h"
#include "penumbra/bakers.h"
#include "penumbra/probe_grid/probe_grid.h"
#include "penumbra/runtime.h"
#include "penumbra/scene/builtin.h"
#include "penumbra/scene/components.h"
#include "test_courtyard.h"

namespace penumbra {
namespace {

// The courtyard with every module's draft components; `variant` switches the probe grid's sampling
// and the AO fields' representation, whose global steps differ.
World courtyard(ProbeSampling sampling = ProbeSampling::Supersampled,
                AOFieldRepresentation fields = AOFieldRepresentation::RadialFit) {
  World world = test_scenes::courtyard_with_defaults();
  for (Entity e : world.view<IrradianceProbeGrid>().sorted_entities()) world.patch<IrradianceProbeGrid>(e).sampling = sampling;
  for (Entity e : world.view<AOFieldCaster>().sorted_entities()) {
    AOFieldCaster& c = world.patch<AOFieldCaster>(e);
    c.representation = fields;
    c.grid_size = 12;
  }
  return world;
}

BakeSettings draft() {
  BakeSettings s;
  s.preset = Preset::Draft;
  s.seed = 7;
  return s;
}

std::vector<char> file_bytes(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

class Scratch {
 public:
  Scratch() : dir_(std::filesystem::temp_directory_path() / ("penumbra-shard-" + std::to_string(::getpid()))) {
    std::filesystem::create_directories(dir_);
  }
  ~Scratch() { std::filesystem::remove_all(dir_); }
  std::filesystem::path operator/(const std::string& name) const { return dir_ / name; }

 private:
  std::filesystem::path dir_;
};

// The bytes on disk of a single-machine bake, and of the merge of `shards` parts (baked one after
// another, with 1 thread, merged in reverse order).
struct Files {
  std::vector<char> single, merged;
  std::size_t items = 0;
};
Files bake_both(World (*make)(), const std::vector<std::string>& bakers, std::uint32_t shards, const Scratch& dir) {
  Files out;
  World world = make();
  ThreadPool pool(2);
  JobContext jobs(&pool);
  auto whole = bake_world(world, bakers, draft(), jobs);
  EXPECT_TRUE(whole.ok()) << whole.error().message;
  if (!whole.ok()) return out;
  EXPECT_TRUE(write_bake_file(dir / "single.pbake", whole->file).ok());
  out.single = file_bytes(dir / "single.pbake");

  std::vector<NamedPart> parts;
  for (std::uint32_t i = 0; i < shards; ++i) {
    World w = make();
    ThreadPool one(1);
    JobContext serial(&one);
    auto part = bake_shard(w, bakers, draft(), ShardSpec{i, shards}, "builtin:courtyard", serial);
    EXPECT_TRUE(part.ok()) << part.error().message;
    if (!part.ok()) return out;
    const std::string path = (dir / ("part_" + std::to_string(i) + ".pbake")).string();
    EXPECT_TRUE(write_bake_file(path, part->file).ok());
    auto read = read_bake_file(path);
    EXPECT_TRUE(read.ok()) << read.error().message;
    auto parsed = read_bake_part(*read, path);
    EXPECT_TRUE(parsed.ok()) << parsed.error().message;
    out.items += parsed->items.size();
    parts.push_back({path, std::move(*parsed)});
  }
  std::reverse(parts.begin(), parts.end());
  World registry;
  register_bakers(registry);
  JobContext jobs2;
  auto merged = merge_bake_parts(registry.resource<BakerRegistry>(), parts, jobs2);
  EXPECT_TRUE(merged.ok()) << merged.error().message;
  if (!merged.ok()) return out;
  EXPECT_TRUE(write_bake_file(dir / "merged.pbake", *merged).ok());
  out.merged = file_bytes(dir / "merged.pbake");
  return out;
}

World default_courtyard() { return courtyard(); }
World fitted_grids() { return courtyard(ProbeSampling::Fitted, AOFieldRepresentation::Grid); }
World point_grids() { return courtyard(ProbeSampling::Point); }

TEST(ShardedBake, MergedPartsAreTheSingleMachineFileByteForByteForEveryBaker) {
  const Scratch dir;
  for (const std::string baker : {"vertex-ao", "probe-grid", "ao-field", "pose-ao", "indirect-transport"})
    for (std::uint32_t shards : {1u, 2u, 4u, 7u}) {
      const Files f = bake_both(default_courtyard, {baker}, shards, dir);
      ASSERT_FALSE(f.single.empty()) << baker;
      EXPECT_GT(f.items, 1u) << baker << ": split into several work items";
      EXPECT_TRUE(f.single == f.merged) << baker << " at " << shards << " shards: the merged file differs ("
                                        << f.single.size() << " and " << f.merged.size() << " bytes)";
    }
}

TEST(ShardedBake, EachGlobalStepMergesByteForByte) {
  // Fitted probes (fill, the lookup from neighbours' reach, the fit) with grid AO fields (the inside
  // fill), and point-sampled probes (no fill), every baker at once.
  const Scratch dir;
  for (World (*make)() : {fitted_grids, point_grids}) {
    const Files f = bake_both(make, {}, 4, dir);
    ASSERT_FALSE(f.single.empty());
    EXPECT_TRUE(f.single == f.merged) << "the merged file differs (" << f.single.size() << " and " << f.merged.size()
                                      << " bytes)";
  }
}

// Parts of one 3-shard bake, read back.
std::vector<NamedPart> three_parts(const BakeSettings& settings = draft()) {
  std::vector<NamedPart> parts;
  for (std::uint32_t i = 0; i < 3; ++i) {
    World w = courtyard();
    JobContext jobs;
    auto part = bake_shard(w, {"vertex-ao", "probe-grid"}, settings, ShardSpec{i, 3}, "builtin:courtyard", jobs);
    EXPECT_TRUE(part.ok());
    auto parsed = read_bake_part(part->file, "part_" + std::to_string(i) + ".pbake");
    EXPECT_TRUE(parsed.ok()) << parsed.error().message;
    parts.push_back({"part_" + std::to_string(i) + ".pbake", std::move(*parsed)});
  }
  return parts;
}

Result<BakeFile> merge(std::span<const NamedPart> parts) {
  World registry;
  register_bakers(registry);
  JobContext jobs;
  return merge_bake_parts(registry.resource<BakerRegistry>(), parts, jobs);
}

TEST(ShardedBake, MergeNamesMissingDuplicatedAndForeignParts) {
  std::vector<NamedPart> parts = three_parts();
  ASSERT_TRUE(merge(parts).ok());

  // A missing part: the item, the shard that bakes it and the command.
  std::vector<NamedPart> two(parts.begin(), parts.begin() + 2);
  auto missing = merge(two);
  ASSERT_FALSE(missing.ok());
  EXPECT_NE(missing.error().message.find("no part holds item"), std::string::npos) << missing.error().message;
  EXPECT_NE(missing.error().message.find("--shard 2/3 -o part_2.pbake"), std::string::npos) << missing.error().message;

  // A part given twice: both names.
  std::vector<NamedPart> twice = parts;
  twice.push_back(parts[1]);
  twice.back().path = "copy_of_part_1.pbake";
  auto duplicated = merge(twice);
  ASSERT_FALSE(duplicated.ok());
  EXPECT_NE(duplicated.error().message.find("is in both part_1.pbake (shard 1/3) and copy_of_part_1.pbake"),
            std::string::npos)
      << duplicated.error().message;

  // A part of the same scene with another seed.
  BakeSettings other = draft();
  other.seed = 8;
  std::vector<NamedPart> mixed = parts;
  mixed[2] = three_parts(other)[2];
  mixed[2].path = "seed8.pbake";
  auto foreign = merge(mixed);
  ASSERT_FALSE(foreign.ok());
  EXPECT_NE(foreign.error().message.find("seed 8 and 7"), std::string::npos) << foreign.error().message;

  // The same settings, other scene content: the input hashes.
  World moved = courtyard();
  for (Entity e : moved.view<Light>().sorted_entities()) moved.patch<Light>(e).intensity *= 2.0f;
  JobContext jobs;
  auto part = bake_shard(moved, {"vertex-ao", "probe-grid"}, draft(), ShardSpec{2, 3}, "builtin:courtyard", jobs);
  ASSERT_TRUE(part.ok());
  mixed[2] = NamedPart{"brighter.pbake", *read_bake_part(part->file, "brighter.pbake")};
  auto changed = merge(mixed);
  ASSERT_FALSE(changed.ok());
  EXPECT_NE(changed.error().message.find("scene content: input hashes"), std::string::npos) << changed.error().message;
}

TEST(ShardedBake, AWholeBakeIsNoPartAndAPartIsNoBake) {
  World world = courtyard();
  JobContext jobs;
  auto whole = bake_world(world, {"vertex-ao"}, draft(), jobs);
  ASSERT_TRUE(whole.ok());
  auto not_part = read_bake_part(whole->file, "level.pbake");
  ASSERT_FALSE(not_part.ok());
  EXPECT_NE(not_part.error().message.find("level.pbake: not a part"), std::string::npos);

  auto part = bake_shard(world, {"vertex-ao"}, draft(), ShardSpec{0, 2}, "builtin:courtyard", jobs);
  ASSERT_TRUE(part.ok());
  EXPECT_NE(part->file.input_hash, whole->file.input_hash) << "a part is never taken for the bake";
  World fresh = courtyard();
  const Status attached = attach_bake(fresh, part->file);
  ASSERT_FALSE(attached.ok());
  EXPECT_NE(attached.error().message.find("merge the parts first"), std::string::npos);
}

TEST(ShardAssignment, LongestFirstIsBalancedAndDeterministic) {
  // Costs 1..40: every shard within the largest item of the mean (Graham's bound for LPT is
  // tighter: 4/3 of the optimum).
  std::vector<double> costs(40);
  std::iota(costs.begin(), costs.end(), 1.0);
  for (std::uint32_t shards : {1u, 2u, 3u, 7u, 16u}) {
    std::vector<double> loads(shards, 0.0);
    const std::vector<std::uint32_t> owners = assign_items(costs, loads);
    const double total = std::accumulate(costs.begin(), costs.end(), 0.0);
    EXPECT_DOUBLE_EQ(std::accumulate(loads.begin(), loads.end(), 0.0), total);
    EXPECT_LE(*std::max_element(loads.begin(), loads.end()), total / shards + 40.0) << shards << " shards";
    std::vector<double> again(shards, 0.0);
    EXPECT_EQ(assign_items(costs, again), owners);
    for (std::uint32_t o : owners) EXPECT_LT(o, shards);
  }
  // Loads carry over: a second baker's first item goes to the least-loaded shard.
  std::vector<double> loads{5.0, 1.0, 3.0};
  const std::vector<double> one{2.0};
  EXPECT_EQ(assign_items(one, loads), std::vector<std::uint32_t>{1});
}

TEST(ShardSpec, ParsesIOfNAndRefusesTheRest) {
  auto s = parse_shard("3/7");
  ASSERT_TRUE(s.ok());
  EXPECT_EQ(s->index, 3u);
  EXPECT_EQ(s->count, 7u);
  for (const char* bad : {"7/7", "1", "/4", "1/", "-1/4", "1/0", "a/4", "1/4x", "0/5000", " 1/4"}) {
    auto r = parse_shard(bad);
    ASSERT_FALSE(r.ok()) << bad;
    EXPECT_NE(r.error().message.find("I/N"), std::string::npos);
  }
}

}  // namespace
}  // namespace penumbra
