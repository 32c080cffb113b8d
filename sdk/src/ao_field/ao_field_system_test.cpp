// The ao-field system: receivers get the multiplicative combination of the casters in range,
// update only when something moved, and casters beyond their falloff cost nothing.
#include "penumbra/ao_field/ao_field_system.h"

#include <gtest/gtest.h>

#include <cstring>
#include <memory>
#include <vector>

#include <glm/gtc/matrix_transform.hpp>

#include "penumbra/ao_field/ao_field_baker.h"
#include "penumbra/bake/baker.h"
#include "penumbra/ecs/transform.h"
#include "penumbra/scene/builtin.h"
#include "penumbra/scene/mesh.h"
#include "penumbra/scene/animation.h"

namespace penumbra {
namespace {

std::shared_ptr<const AOFieldData> crate_field() {
  AOFieldCaster c;
  c.resolution = 4;
  c.radial_samples = 8;
  c.rays_per_sample = 64;
  JobContext jobs;
  MemoryBudget budget;
  auto d = bake_ao_field(c, make_box(glm::vec3(0.5f)), 3, jobs, budget);
  EXPECT_TRUE(d.ok());
  return std::make_shared<const AOFieldData>(std::move(*d));
}

Entity add_caster(World& w, std::shared_ptr<const AOFieldData> data, glm::vec3 at) {
  const Entity e = w.create();
  AOFieldCaster c;
  c.data = std::move(data);
  w.add<AOFieldCaster>(e, c);
  w.add<WorldTransform>(e, WorldTransform{glm::translate(glm::mat4(1.0f), at)});
  return e;
}

Entity add_receiver(World& w, glm::vec3 at) {
  const Entity e = w.create();
  w.add<AOFieldReceiver>(e, AOFieldReceiver{glm::vec3(0, 1, 0), 0.0f, 0});
  w.add<WorldTransform>(e, WorldTransform{glm::translate(glm::mat4(1.0f), at)});
  return e;
}

TEST(AOFieldSystem, CombinesCastersInRangeAndUpdatesOnlyOnChange) {
  World w;
  register_ao_field_system(w);
  const auto field = crate_field();
  const Entity a = add_caster(w, field, glm::vec3(0, 0.5f, 0));
  const Entity near = add_receiver(w, glm::vec3(0.7f, 0, 0.1f));
  const Entity far = add_receiver(w, glm::vec3(50, 0, 0));
  w.advance_tick();
  EXPECT_EQ(update_ao_field_receivers(w, 0), 2u);
  const float expected = evaluate(*field, w.get<WorldTransform>(a).matrix, glm::vec3(0.7f, 0, 0.1f), glm::vec3(0, 1, 0));
  EXPECT_GT(expected, 0.05f);
  EXPECT_FLOAT_EQ(w.get<AOFieldReceiver>(near).occlusion, expected);
  EXPECT_EQ(w.get<AOFieldReceiver>(far).occlusion, 0.0f);
  // Nothing changed since: nothing is updated.
  std::uint64_t since = w.tick();
  w.advance_tick();
  EXPECT_EQ(update_ao_field_receivers(w, since), 0u);
  // Only a receiver moved: only it is updated.
  since = w.tick();
  w.advance_tick();
  w.patch<WorldTransform>(far).matrix = glm::translate(glm::mat4(1.0f), glm::vec3(60, 0, 0));
  EXPECT_EQ(update_ao_field_receivers(w, since), 1u);
  // A second caster on the other side: 1 - (1 - A1)(1 - A2).
  since = w.tick();
  w.advance_tick();
  const Entity b = add_caster(w, field, glm::vec3(1.4f, 0.5f, 0));
  EXPECT_EQ(update_ao_field_receivers(w, since), 2u);
  const float second =
      evaluate(*field, w.get<WorldTransform>(b).matrix, glm::vec3(0.7f, 0, 0.1f), glm::vec3(0, 1, 0));
  EXPECT_GT(second, 0.05f);
  EXPECT_NEAR(w.get<AOFieldReceiver>(near).occlusion, 1.0f - (1.0f - expected) * (1.0f - second), 1e-6f);
  // The casters move away: the shadow goes.
  since = w.tick();
  w.advance_tick();
  w.patch<WorldTransform>(a).matrix = glm::translate(glm::mat4(1.0f), glm::vec3(0, 0.5f, 100));
  w.patch<WorldTransform>(b).matrix = glm::translate(glm::mat4(1.0f), glm::vec3(0, 0.5f, -100));
  update_ao_field_receivers(w, since);
  EXPECT_EQ(w.get<AOFieldReceiver>(near).occlusion, 0.0f);
}

TEST(AOFieldSystem, ManyCastersStayInRangeAndTheSystemRuns) {
  World w;
  register_ao_field_system(w);
  const auto field = crate_field();
  for (int i = 0; i < 300; ++i) add_caster(w, field, glm::vec3(0.0f, 0.5f + 0.001f * float(i), 0.0f));
  const Entity r = add_receiver(w, glm::vec3(0.6f, 0, 0));
  w.run_phase(Phase::Lighting, 0.016);
  const float o = w.get<AOFieldReceiver>(r).occlusion;
  EXPECT_GE(o, 0.0f);
  EXPECT_LE(o, 1.0f);
  EXPECT_GT(o, 0.99f);  // 300 overlapping crates darken it almost fully (the rule's known bias)
  EXPECT_GT(w.get<AOFieldReceiver>(r).updated_tick, 0u);
}

TEST(AOFieldSystem, CourtyardCratesCastOnTheWalker) {
  World w;
  register_ao_field_system(w);
  register_ao_field_baker(w);
  register_scene_systems(w);
  ASSERT_TRUE(load_builtin(w, "courtyard").ok());
  w.update(0.0);
  EXPECT_EQ(add_default_ao_field_casters(w, Preset::Draft), 4u);  // the four crates
  EXPECT_EQ(add_default_ao_field_casters(w, Preset::Draft), 0u);  // only once
  std::size_t surfaces = 0, entities = 0;
  w.view<AOFieldReceiver>().each([&](Entity e, AOFieldReceiver& r) {
    if (r.mode == AOFieldReceiver::Mode::Surface) {
      EXPECT_TRUE(w.has<Static>(e));
      ++surfaces;
    } else {
      EXPECT_TRUE(w.has<Skin>(e));
      ++entities;
    }
  });
  EXPECT_GT(surfaces, 10u);
  EXPECT_EQ(entities, 1u);  // the walker
  JobContext jobs;
  auto result = bake_world(w, {"ao-field"}, BakeSettings{}, jobs);
  ASSERT_TRUE(result.ok()) << result.error().message;
  EXPECT_EQ(result->file.chunks.size(), 4u);
  // The crates share one mesh and their settings: one bake, four chunks naming their entities.
  std::vector<AOFieldData> fields;
  for (const BakeChunk& c : result->file.chunks) fields.push_back(*read_ao_field_chunk(c));
  const EntityKeys keys = EntityKeys::build(w);
  for (const AOFieldData& f : fields) {
    EXPECT_EQ(std::memcmp(f.texels.data(), fields[0].texels.data(), f.texels.size() * sizeof(AOFieldTexel)), 0);
    auto e = keys.find(f.key, "test");
    ASSERT_TRUE(e.ok()) << e.error().message;
    EXPECT_TRUE(w.has<AOFieldCaster>(*e));
  }
  EXPECT_NE(fields[0].key, fields[3].key);
  // The walker's occlusion from the crates; then one crate is set down beside it: darker.
  Entity walker, crate;
  w.view<AOFieldReceiver>().each([&](Entity e, AOFieldReceiver& r) {
    if (r.mode == AOFieldReceiver::Mode::Entity) walker = e;
  });
  w.view<AOFieldCaster>().each([&](Entity e, AOFieldCaster&) { crate = e; });
  w.update(0.016);
  const float before = w.get<AOFieldReceiver>(walker).occlusion;
  EXPECT_GE(before, 0.0f);
  const glm::vec3 feet(w.get<WorldTransform>(walker).matrix[3]);
  w.patch<Transform>(crate).translation = feet + glm::vec3(0.55f, 0.4f, 0.0f);
  w.update(0.016);
  const float after = w.get<AOFieldReceiver>(walker).occlusion;
  EXPECT_GT(after, before + 0.05f) << before;
  EXPECT_LE(after, 1.0f);
}

TEST(AOFieldSystem, EvaluateCapAgreesWithEvaluate) {
  const auto field = crate_field();
  const glm::mat4 world = glm::scale(glm::rotate(glm::translate(glm::mat4(1.0f), glm::vec3(1, 0.5f, -2)), 0.6f,
                                                 glm::vec3(0, 1, 0)),
                                     glm::vec3(2.0f));
  for (int i = 0; i < 50; ++i) {
    const glm::vec3 x(-2.0f + 0.1f * float(i), 0.0f, -2.0f + 0.05f * float(i));
    const AOFieldCap cap = evaluate_cap(*field, world, x, glm::vec3(0, 1, 0));
    EXPECT_FLOAT_EQ(cap.occlusion, evaluate(*field, world, x, glm::vec3(0, 1, 0))) << i;
    if (cap.omega > 0.0f) {
      EXPECT_NEAR(glm::length(cap.axis), 1.0f, 1e-5f);
      // The crate sits above the ground point: its cap points upwards.
      EXPECT_GT(cap.axis.y, 0.0f) << i;
    }
  }
  // Beyond the falloff: nothing.
  const AOFieldCap far = evaluate_cap(*field, world, glm::vec3(500, 0, 0), glm::vec3(0, 1, 0));
  EXPECT_EQ(far.occlusion, 0.0f);
  EXPECT_EQ(far.omega, 0.0f);
}

}  // namespace
}  // namespace penumbra
