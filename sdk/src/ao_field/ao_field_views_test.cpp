// The AO-field caster views: a baked crate's slice is darkest next to it, falls off with distance,
// is exactly 0 beyond the falloff and follows the crate when it is dragged; its bounds lie on the
// falloff sphere and the box's hull.
#include "ao_field_views.h"

#include <cmath>
#include <limits>
#include <numeric>

#include <glm/geometric.hpp>
#include <gtest/gtest.h>

#include "editor_model.h"
#include "editor_test_support.h"
#include "fields.h"
#include "load_world.h"
#include "penumbra/ao_field/ao_field.h"
#include "penumbra/ecs/transform.h"
#include "penumbra/scene/components.h"

namespace penumbra::editor {
namespace {

TEST(AOFieldViews, AOFieldSliceFallsOffWithDistanceAndFollowsTheCaster) {
  EditorModel model;
  ASSERT_TRUE(model.open("builtin:courtyard", Preset::Draft).ok());
  model.bake_settings.preset = Preset::Draft;
  Document& doc = *model.document();
  const Entity crate = *doc.find("crate");
  // Not baked yet: a clear error, no values.
  auto early = ao_field_slice(doc.world(), crate, {});
  ASSERT_FALSE(early.ok());
  EXPECT_NE(early.error().message.find("not baked"), std::string::npos) << early.error().message;
  ASSERT_NO_FATAL_FAILURE(bake_selected(model, crate));

  World& w = doc.world();
  AOFieldSliceRequest request;
  request.resolution = 41;
  auto slice = ao_field_slice(w, crate, request);
  ASSERT_TRUE(slice.ok()) << slice.error().message;
  ASSERT_EQ(slice->points.size(), 41u * 41u);
  ASSERT_EQ(slice->occlusion.size(), slice->points.size());
  auto bounds = ao_field_bounds(w, crate);
  ASSERT_TRUE(bounds.ok()) << bounds.error().message;
  ASSERT_TRUE(bounds->baked);
  const glm::vec3 centre = bounds->centre;
  const float reach = bounds->falloff_radius;
  // The plane is the crate's floor (its lowest point, y = 0 for a crate resting on the ground).
  EXPECT_NEAR(slice->points[0].y, 0.0f, 1e-5f);

  // Mean occlusion in rings of horizontal distance: decreasing outwards, 0 beyond the falloff.
  constexpr int kRings = 6;
  double sum[kRings] = {}, count[kRings] = {};
  std::size_t beyond = 0;
  for (std::size_t i = 0; i < slice->points.size(); ++i) {
    const float a = slice->occlusion[i];
    ASSERT_GE(a, 0.0f);
    ASSERT_LE(a, 1.0f);
    const glm::vec3 p = slice->points[i];
    if (glm::length(p - centre) >= reach) {
      EXPECT_EQ(a, 0.0f) << "at " << p.x << " " << p.z;
      ++beyond;
      continue;
    }
    const float h = glm::length(glm::vec2(p.x - centre.x, p.z - centre.z));
    // Rings outside the crate's footprint (half-size 0.4 m), out to the falloff.
    const float t = (h - 0.45f) / (reach - 0.45f);
    if (t < 0.0f || t >= 1.0f) continue;
    const int ring = static_cast<int>(t * kRings);
    sum[ring] += a;
    count[ring] += 1.0;
  }
  EXPECT_GT(beyond, 100u);  // the square's corners reach past the falloff sphere
  double previous = 1.0;
  for (int r = 0; r < kRings; ++r) {
    ASSERT_GT(count[r], 0.0);
    const double mean = sum[r] / count[r];
    EXPECT_LT(mean, previous) << "ring " << r;
    previous = mean;
  }
  EXPECT_GT(sum[0] / count[0], 0.05);   // a visible contact shadow next to the crate
  EXPECT_LT(sum[kRings - 1] / count[kRings - 1], 0.01);  // faded out near the falloff
  EXPECT_GT(slice->max_occlusion, 0.2f);

  // Dragging the crate: the slice moves with it and keeps its values (the field is rigid).
  w.patch<Transform>(crate).translation += glm::vec3(1.0f, 0.0f, -0.5f);
  w.update(0.0);
  auto moved = ao_field_slice(w, crate, request);
  ASSERT_TRUE(moved.ok());
  // Up to float rounding of the local coordinates, which can flip a point on a cube-face diagonal
  // to the neighbouring face (the fit is not continuous across faces): small everywhere, and
  // nothing on average.
  double mean_difference = 0.0;
  for (std::size_t i = 0; i < slice->points.size(); ++i) {
    EXPECT_NEAR(moved->points[i].x, slice->points[i].x + 1.0f, 1e-4f);
    EXPECT_NEAR(moved->points[i].z, slice->points[i].z - 0.5f, 1e-4f);
    EXPECT_NEAR(moved->occlusion[i], slice->occlusion[i], 0.02f) << i;
    mean_difference += std::abs(moved->occlusion[i] - slice->occlusion[i]);
  }
  EXPECT_LT(mean_difference / double(slice->points.size()), 1e-4);
  // A bad request names the fix.
  request.resolution = 1;
  auto bad = ao_field_slice(w, crate, request);
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(bad.error().message.find("2..512"), std::string::npos);
}

TEST(AOFieldViews, AOFieldBoundsLieOnTheFalloffSphereAndTheBoxHull) {
  EditorModel model;
  ASSERT_TRUE(model.open("builtin:courtyard", Preset::Draft).ok());
  model.bake_settings.preset = Preset::Draft;
  World& w = model.document()->world();
  const Entity crate = *model.document()->find("crate");
  constexpr float kHalf = 0.4f;  // the courtyard's crate: a box of half-size 0.4 m
  // Before the bake: the bounding sphere (the farthest vertex, a corner) and 6x it.
  auto before = ao_field_bounds(w, crate, 32);
  ASSERT_TRUE(before.ok()) << before.error().message;
  EXPECT_FALSE(before->baked);
  EXPECT_NEAR(before->falloff_radius, 6.0f * kHalf * std::sqrt(3.0f), 1e-4f);
  ASSERT_EQ(before->hull.size(), 3u);
  for (const auto& loop : before->hull)
    for (glm::vec3 p : loop) EXPECT_NEAR(glm::length(p - before->centre), kHalf * std::sqrt(3.0f), 1e-4f);

  ASSERT_NO_FATAL_FAILURE(bake_selected(model, crate));
  auto b = ao_field_bounds(w, crate, 32);
  ASSERT_TRUE(b.ok());
  EXPECT_TRUE(b->baked);
  EXPECT_NEAR(b->centre.x, 1.0f, 1e-4f);  // the crate at (1, 0.4, 2)
  EXPECT_NEAR(b->centre.y, 0.4f, 1e-4f);
  EXPECT_NEAR(b->centre.z, 2.0f, 1e-4f);
  ASSERT_EQ(b->falloff.size(), 3u);
  for (const auto& loop : b->falloff) {
    ASSERT_EQ(loop.size(), 32u);
    for (glm::vec3 p : loop) EXPECT_NEAR(glm::length(p - b->centre), b->falloff_radius, 1e-3f);
  }
  // The hull along directions in the box's coordinate planes: from the face (kHalf) to the edge
  // (kHalf sqrt 2), up to the cube map's bilinear smoothing.
  ASSERT_EQ(b->hull.size(), 3u);
  for (const auto& loop : b->hull)
    for (glm::vec3 p : loop) {
      const float r = glm::length(p - b->centre);
      EXPECT_GT(r, 0.97f * kHalf);
      EXPECT_LT(r, 1.03f * kHalf * std::sqrt(2.0f));
    }
  // An entity without a caster: an error, not a crash.
  auto none = ao_field_bounds(w, *model.document()->find("sun"));
  ASSERT_FALSE(none.ok());
  EXPECT_NE(none.error().message.find("no AOFieldCaster"), std::string::npos);
}

}  // namespace
}  // namespace penumbra::editor
