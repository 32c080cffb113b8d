// The indirect-transport views: on the maze, the settings entity's summary repeats the baked data
// and this frame's lightmap, and the receivers' summaries partition its patches, texels and area.
#include "indirect_transport_views.h"

#include <glm/geometric.hpp>
#include <gtest/gtest.h>

#include "load_world.h"
#include "penumbra/bake/baker.h"
#include "penumbra/core/jobs.h"
#include "penumbra/ecs/transform.h"
#include "penumbra/indirect_transport/indirect_transport.h"
#include "penumbra/scene/components.h"

namespace penumbra::editor {
namespace {

TEST(IndirectTransportViews, SummariesRepeatTheBakeAndPartitionItAmongTheReceivers) {
  World w;
  ASSERT_TRUE(cli::load_world(w, "builtin:maze", Preset::Draft).ok());
  const std::vector<Entity> owners = w.view<const IndirectTransport>().sorted_entities();
  ASSERT_EQ(owners.size(), 1u);
  const Entity owner = owners[0];
  auto before = transport_summary(w, owner);
  ASSERT_TRUE(before.ok());
  EXPECT_FALSE(before->baked);
  EXPECT_EQ(before->dynamic_lights, 1u);  // the lantern
  EXPECT_EQ(before->fixed_lights, 0u);    // a clip carries it
  const std::vector<Entity> receivers = w.view<const IndirectReceiver>().sorted_entities();
  ASSERT_FALSE(receivers.empty());
  EXPECT_EQ(before->receivers, receivers.size());
  EXPECT_FALSE(receiver_summary(w, receivers[0])->baked);

  JobContext jobs;
  BakeSettings settings;
  settings.preset = Preset::Draft;
  ASSERT_TRUE(bake_world(w, {"indirect-transport"}, settings, jobs).ok());
  w.update(1.0 / 30.0);  // the lantern moves: the system writes the lightmap
  const TransportData& data = *w.get<IndirectTransport>(owner).data;
  auto s = transport_summary(w, owner);
  ASSERT_TRUE(s.ok());
  EXPECT_TRUE(s->baked);
  EXPECT_EQ(s->patches, data.patches.size());
  EXPECT_EQ(s->leaves, data.leaf_count());
  EXPECT_EQ(s->links, data.links);
  EXPECT_EQ(s->global_coefficients, data.global.nonzeros());
  EXPECT_EQ(s->terms, data.terms);
  EXPECT_TRUE(s->moving_lights);
  ASSERT_TRUE(s->has_lightmap);
  EXPECT_EQ(s->indirect.leaves, data.leaf_count());
  EXPECT_GT(s->indirect.mean, 0.0f);
  EXPECT_GE(s->indirect.max, s->indirect.mean);
  EXPECT_GT(s->direct.max, s->indirect.max);  // next to the lantern, its direct light dominates

  std::uint32_t patches = 0, leaves = 0;
  float area = 0.0f, expected_area = 0.0f;
  double indirect_sum = 0.0;
  for (Entity r : receivers) {
    auto rs = receiver_summary(w, r);
    ASSERT_TRUE(rs.ok());
    EXPECT_TRUE(rs->baked);
    EXPECT_GT(rs->patches, 0u);
    patches += rs->patches;
    leaves += rs->leaves;
    area += rs->area;
    indirect_sum += static_cast<double>(rs->indirect.mean) * static_cast<double>(rs->indirect.leaves);
  }
  for (const TransportPatch& p : data.patches) expected_area += p.area();
  EXPECT_EQ(patches, s->patches);
  EXPECT_EQ(leaves, s->leaves);
  EXPECT_NEAR(area, expected_area, 1e-3f * expected_area);
  EXPECT_NEAR(indirect_sum / leaves, s->indirect.mean, 1e-4 * s->indirect.mean);

  const Entity nothing = w.create();
  EXPECT_EQ(transport_summary(w, nothing).error().code, ErrorCode::NotFound);
  EXPECT_EQ(receiver_summary(w, nothing).error().code, ErrorCode::NotFound);
}

// A dragged point stays under the pointer and keeps its distance along the view direction; a move
// through a parent lands at the world position asked for.
TEST(IndirectTransportViews, ADraggedLightFollowsThePointer) {
  const glm::vec2 size(640.0f, 360.0f);
  const CameraView camera = look_at_view(glm::vec3(1.0f, 2.0f, 6.0f), glm::vec3(0.0f, 1.0f, 0.0f), 1.0f,
                                         size.x / size.y, 0.05f, 100.0f);
  const auto pixel = [&](glm::vec3 p) {
    const glm::vec4 c = camera.projection * camera.view * glm::vec4(p, 1.0f);
    return glm::vec2((c.x / c.w * 0.5f + 0.5f) * size.x, (c.y / c.w * 0.5f + 0.5f) * size.y);
  };
  const glm::vec3 light(0.5f, 1.5f, 0.0f);
  const glm::vec2 from = pixel(light), to = from + glm::vec2(80.0f, -30.0f);
  const glm::vec3 moved = drag_in_view_plane(camera, light, from, to, size);
  EXPECT_NEAR(glm::distance(pixel(moved), to), 0.0f, 0.05f);
  const glm::vec3 forward = glm::normalize(glm::vec3(0.0f, 1.0f, 0.0f) - glm::vec3(1.0f, 2.0f, 6.0f));
  EXPECT_NEAR(glm::dot(moved - light, forward), 0.0f, 1e-4f);
  EXPECT_EQ(drag_in_view_plane(camera, light, from, from, size), light);

  World w;
  const Entity parent = w.create(), lamp = w.create();
  Transform t;
  t.translation = glm::vec3(2.0f, 0.0f, 0.0f);
  t.scale = glm::vec3(2.0f);
  w.add<Transform>(parent, t);
  w.add<Transform>(lamp);
  set_parent(w, lamp, parent);
  w.update(0.0);
  update_world_transforms(w);
  move_to(w, lamp, glm::vec3(3.0f, 1.0f, -1.0f));
  update_world_transforms(w);
  const glm::vec3 at(w.get<WorldTransform>(lamp).matrix[3]);
  EXPECT_NEAR(glm::distance(at, glm::vec3(3.0f, 1.0f, -1.0f)), 0.0f, 1e-5f);
}

}  // namespace
}  // namespace penumbra::editor
