// The pose-AO views: AO statistics against hand counts; the courtyard's character bakes through
// the editor's snapshot (skin, hierarchy and clips carried over) bit for bit like a foreground
// bake, and its inspector summary describes the data and this frame's AO.
#include "pose_ao_views.h"

#include <cmath>
#include <limits>
#include <numeric>

#include <glm/geometric.hpp>
#include <gtest/gtest.h>

#include "editor_model.h"
#include "editor_test_support.h"
#include "fields.h"
#include "load_world.h"
#include "penumbra/ecs/transform.h"
#include "penumbra/pose_ao/pose_ao.h"
#include "penumbra/pose_ao/pose_ao_system.h"
#include "penumbra/scene/components.h"

namespace penumbra::editor {
namespace {

TEST(PoseAOViews, AOStatsCountsByHand) {
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const std::vector<float> ao = {0.0f, 0.5f, 1.0f, 0.25f, nan, 1.5f, -0.5f};
  const AOStats s = ao_stats(ao);
  EXPECT_EQ(s.count, 6u);  // the NaN skipped
  EXPECT_EQ(s.min, 0.0f);
  EXPECT_EQ(s.max, 1.0f);
  EXPECT_NEAR(s.mean, (0.0f + 0.5f + 1.0f + 0.25f + 1.0f + 0.0f) / 6.0f, 1e-6f);
  EXPECT_EQ(s.histogram[0], 2u);   // 0 and -0.5 clamped
  EXPECT_EQ(s.histogram[5], 1u);   // 0.25
  EXPECT_EQ(s.histogram[10], 1u);  // 0.5
  EXPECT_EQ(s.histogram[19], 2u);  // 1 and 1.5 clamped
  EXPECT_EQ(std::accumulate(s.histogram.begin(), s.histogram.end(), 0u), 6u);
  EXPECT_EQ(ao_stats({}).count, 0u);
}

TEST(PoseAOViews, PoseAOBakesThroughTheSnapshotLikeAForegroundBake) {
  EditorModel model;
  ASSERT_TRUE(model.open("builtin:courtyard", Preset::Draft).ok());
  model.bake_settings.preset = Preset::Draft;
  model.bake_settings.seed = 11;
  model.bake_threads = 2;
  Document& doc = *model.document();
  const Entity body = *doc.find("character_mesh");
  EXPECT_EQ(bakers_for(doc.world(), body), std::vector<std::string>{"pose-ao"});
  auto unbaked = pose_ao_summary(doc.world(), body);
  ASSERT_TRUE(unbaked.ok());
  EXPECT_FALSE(unbaked->baked);
  ASSERT_NO_FATAL_FAILURE(bake_selected(model, body));
  ASSERT_EQ(doc.baked().chunks.size(), 1u);
  EXPECT_EQ(fourcc_to_string(doc.baked().chunks[0].type), "PSAO");

  // The same bake in the foreground on a freshly loaded World: the same bytes.
  World fresh;
  ASSERT_TRUE(cli::load_world(fresh, "builtin:courtyard", Preset::Draft).ok());
  JobContext serial;
  BakeSettings settings;
  settings.preset = Preset::Draft;
  settings.seed = 11;
  auto direct = bake_world(fresh, {"pose-ao"}, settings, serial);
  ASSERT_TRUE(direct.ok()) << direct.error().message;
  ASSERT_EQ(direct->file.chunks.size(), 1u);
  EXPECT_TRUE(direct->file.chunks[0].payload == doc.baked().chunks[0].payload);

  // The summary: the data's size and fit, and this frame's AO once the system has run.
  World& w = doc.world();
  w.update(1.0 / 30.0);
  auto s = pose_ao_summary(w, body);
  ASSERT_TRUE(s.ok()) << s.error().message;
  const PoseAOData& data = *w.get<SkinnedPoseAO>(body).data;
  EXPECT_TRUE(s->baked);
  EXPECT_EQ(s->vertices, w.get<Mesh>(body).data->positions.size());
  EXPECT_EQ(s->joint_sets, data.groups.size());
  EXPECT_GT(s->joint_sets, 1u);
  EXPECT_EQ(s->bytes, data.bytes());
  EXPECT_EQ(s->locality, 3u);  // the draft preset's
  EXPECT_GT(s->poses, 100u);   // 100 random poses and the clip's frames
  EXPECT_GT(s->training_rmse, 0.0f);
  EXPECT_LT(s->training_rmse, 0.2f);
  ASSERT_TRUE(s->has_values);
  EXPECT_EQ(s->current.count, s->vertices);
  EXPECT_GE(s->current.min, 0.0f);
  EXPECT_LE(s->current.max, 1.0f);
  EXPECT_LT(s->current.min, s->current.mean);  // some self-occlusion (armpits, between the legs)
  EXPECT_GT(s->current.mean, 0.5f);            // mostly open
}

TEST(PoseAOViews, PoseAOFieldsAndPreset) {
  World w;
  ASSERT_TRUE(cli::load_world(w, "builtin:courtyard", Preset::Medium).ok());
  Entity body;
  w.each<Skin>([&](Entity e, Skin&) { body = e; });
  ASSERT_TRUE(w.alive(body));
  const FieldDesc* locality = find_field("SkinnedPoseAO", "locality");
  ASSERT_NE(locality, nullptr);
  ASSERT_TRUE(locality->present(w, body));
  EXPECT_EQ(std::get<std::int64_t>(locality->get(w, body)), 4);
  auto too_many = parse_field_value(*locality, "5");
  ASSERT_FALSE(too_many.ok());
  EXPECT_NE(too_many.error().message.find("SkinnedPoseAO.locality"), std::string::npos);
  const FieldDesc* margin = find_field("SkinnedPoseAO", "range_margin");
  ASSERT_NE(margin, nullptr);
  margin->set(w, body, FieldValue(0.5f));
  const ComponentPreset* preset = find_preset("pose-ao");
  ASSERT_NE(preset, nullptr);
  ASSERT_TRUE(preset->present(w, body));
  preset->apply(w, body, Preset::High);
  const SkinnedPoseAO& c = w.get<SkinnedPoseAO>(body);
  EXPECT_EQ(c.reference_poses, SkinnedPoseAO::preset(Preset::High).reference_poses);
  EXPECT_EQ(c.rays_per_vertex, SkinnedPoseAO::preset(Preset::High).rays_per_vertex);
  EXPECT_EQ(c.range_margin, 0.5f);  // placement-like settings are kept
}

}  // namespace
}  // namespace penumbra::editor
