// Bake estimates (penumbra/bake/estimate.h) with every module's baker on the courtyard: the chunks'
// bytes of the layout-fixed bakers are the bake's exactly, pose-AO's within a factor; a group no
// larger than its samples runs whole; the World is left as it was; the estimate's bytes do not
// depend on the thread count. (Its seconds are measured, so they are compared in the note and the
// editor, never here.)
#include <gtest/gtest.h>

#include <cmath>
#include <map>

#include "penumbra/bake/estimate.h"
#include "penumbra/bakers.h"
#include "penumbra/runtime.h"
#include "penumbra/scene/builtin.h"
#include "penumbra/scene/components.h"
#include "test_courtyard.h"

namespace penumbra {
namespace {

World courtyard() { return test_scenes::courtyard_with_defaults(); }

BakeSettings draft() {
  BakeSettings s;
  s.preset = Preset::Draft;
  return s;
}

TEST(BakeEstimate, BytesMatchTheBakeAndTheWorldIsLeftAlone) {
  World world = courtyard();
  ThreadPool pool(2);
  JobContext jobs(&pool);
  auto estimate = estimate_bake(world, {}, draft(), jobs, 2);
  ASSERT_TRUE(estimate.ok()) << estimate.error().message;
  EXPECT_EQ(world.view<VertexAO>().count(), 0u);  // nothing attached

  auto baked = bake_world(world, {}, draft(), jobs);
  ASSERT_TRUE(baked.ok()) << baked.error().message;
  std::map<std::string, std::uint64_t> actual;
  for (const BakeReport::Item& item : baked->report.items) actual[item.baker] = item.bytes;
  ASSERT_EQ(estimate->items.size(), baked->report.items.size());
  for (const BakeEstimate::Item& item : estimate->items) {
    SCOPED_TRACE(item.baker);
    EXPECT_TRUE(std::isfinite(item.seconds) && item.seconds > 0.0);
    if (item.baker == "vertex-ao" || item.baker == "probe-grid" || item.baker == "ao-field") {
      ASSERT_TRUE(item.bytes);
      EXPECT_EQ(*item.bytes, actual[item.baker]);
    } else if (item.baker == "pose-ao") {
      ASSERT_TRUE(item.bytes);
      EXPECT_GT(*item.bytes, actual[item.baker] / 2);
      EXPECT_LT(*item.bytes, actual[item.baker] * 2);
    }
  }
  // The parts add up to each baker's bytes, and name the components: the probe grid's is its entity's.
  std::map<std::string, std::uint64_t> part_bytes;
  for (const BakeEstimate::Part& p : estimate->parts) part_bytes[p.baker] += p.bytes;
  for (const BakeEstimate::Item& item : estimate->items)
    if (item.bytes) {
      EXPECT_EQ(part_bytes[item.baker], *item.bytes) << item.baker;
    }
  std::size_t grids = 0;
  for (const BakeEstimate::Part& p : estimate->parts)
    if (p.baker == "probe-grid") {
      ++grids;
      EXPECT_EQ(p.key, "probe grid");
    }
  EXPECT_EQ(grids, 1u);
  for (const BakeEstimate::Group& g : estimate->groups) {
    EXPECT_LE(g.sampled, g.elements) << g.baker << " " << g.name;
    EXPECT_GT(g.sampled, 0u) << g.baker << " " << g.name;
    if (g.elements <= 2 * 4 * 2) {  // 2 ranges of 4 x 2 workers hold all of it
      EXPECT_EQ(g.sampled, g.elements) << g.baker << " " << g.name;
    }
  }
  EXPECT_GT(estimate->seconds(), estimate->ray_scene_seconds);

  // One worker: other ranges, the same layouts.
  ThreadPool one(1);
  JobContext serial(&one);
  World again = courtyard();
  auto single = estimate_bake(again, {"probe-grid", "vertex-ao"}, draft(), serial, 3);
  ASSERT_TRUE(single.ok()) << single.error().message;
  ASSERT_EQ(single->items.size(), 2u);
  for (const BakeEstimate::Item& item : single->items) EXPECT_EQ(item.bytes, std::optional(actual[item.baker])) << item.baker;
  EXPECT_FALSE(estimate_bake(again, {"no-such-baker"}, draft(), serial).ok());
}

}  // namespace
}  // namespace penumbra
