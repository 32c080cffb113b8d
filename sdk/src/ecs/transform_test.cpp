// Hierarchy world transforms: closed forms, deep chains, change-driven recomputation, reparenting.
#include "penumbra/ecs/transform.h"

#include <vector>

#include <glm/gtc/matrix_transform.hpp>
#include <glm/gtc/quaternion.hpp>
#include <gtest/gtest.h>

#include "penumbra/core/random.h"

namespace penumbra {
namespace {

float max_abs_diff(const glm::mat4& a, const glm::mat4& b) {
  float d = 0.0f;
  for (int c = 0; c < 4; ++c)
    for (int r = 0; r < 4; ++r) d = std::max(d, std::abs(a[c][r] - b[c][r]));
  return d;
}

Transform random_transform(Rng& rng) {
  const auto u = [&rng](float lo, float hi) { return lo + (hi - lo) * rng.next_float(); };
  Transform t;
  t.translation = {u(-1, 1), u(-1, 1), u(-1, 1)};
  t.rotation = glm::angleAxis(u(0.0f, 6.28f), glm::normalize(glm::vec3(u(-1, 1), u(-1, 1), u(0.1f, 1))));
  t.scale = {u(0.9f, 1.1f), u(0.9f, 1.1f), u(0.9f, 1.1f)};
  return t;
}

TEST(Transform, MatrixIsTranslateRotateScale) {
  Transform t;
  t.translation = {1, 2, 3};
  t.rotation = glm::angleAxis(glm::radians(90.0f), glm::vec3(0, 0, 1));
  t.scale = {2, 3, 4};
  const glm::mat4 expected = glm::translate(glm::mat4(1), t.translation) * glm::mat4_cast(t.rotation) *
                             glm::scale(glm::mat4(1), t.scale);
  EXPECT_LT(max_abs_diff(t.matrix(), expected), 1e-6f);
  // Closed form: x scaled by 2, rotated onto +y, translated.
  const glm::vec4 p = t.matrix() * glm::vec4(1, 0, 0, 1);
  EXPECT_NEAR(p.x, 1.0f, 1e-6f);
  EXPECT_NEAR(p.y, 4.0f, 1e-6f);
  EXPECT_NEAR(p.z, 3.0f, 1e-6f);
  EXPECT_EQ(Transform{}.matrix(), glm::mat4(1.0f));
  EXPECT_EQ(component_name(component_id<Transform>()), "Transform");
}

TEST(Transform, DeepChainGetsTheProductOfLocals) {
  World w;
  Rng rng = Rng::stream(7, 0);
  std::vector<Entity> chain;
  std::vector<glm::dmat4> expected;
  glm::dmat4 acc(1.0);
  for (int i = 0; i < 300; ++i) {
    const Entity e = w.create();
    const Transform& t = w.add<Transform>(e, random_transform(rng));
    acc = acc * glm::dmat4(t.matrix());
    expected.push_back(acc);
    if (!chain.empty()) {
      ASSERT_TRUE(set_parent(w, e, chain.back()));
    }
    chain.push_back(e);
  }
  update_world_transforms(w);
  for (std::size_t i = 0; i < chain.size(); ++i) {
    ASSERT_LT(max_abs_diff(w.get<WorldTransform>(chain[i]).matrix, glm::mat4(expected[i])), 1e-4f) << "depth " << i;
  }
}

TEST(Transform, OnlyChangedSubtreesAreRewritten) {
  // root -> {a -> a1 -> a2, b -> b1}
  World w;
  Rng rng = Rng::stream(8, 0);
  const auto node = [&](Entity parent) {
    const Entity e = w.create();
    w.add<Transform>(e, random_transform(rng));
    if (parent) set_parent(w, e, parent);
    return e;
  };
  const Entity root = node(Entity::null());
  const Entity a = node(root), a1 = node(a), a2 = node(a1);
  const Entity b = node(root), b1 = node(b);
  const std::vector<Entity> all{root, a, a1, a2, b, b1};
  update_world_transforms(w);
  std::vector<std::uint64_t> before;
  for (Entity e : all) before.push_back(w.changed_tick<WorldTransform>(e));

  // Nothing changed: nothing is rewritten.
  update_world_transforms(w);
  for (std::size_t i = 0; i < all.size(); ++i) EXPECT_EQ(w.changed_tick<WorldTransform>(all[i]), before[i]);

  // Moving a1 rewrites a1 and a2 only.
  w.patch<Transform>(a1).translation += glm::vec3(0, 1, 0);
  update_world_transforms(w);
  const std::vector<bool> rewritten{false, false, true, true, false, false};
  for (std::size_t i = 0; i < all.size(); ++i)
    EXPECT_EQ(w.changed_tick<WorldTransform>(all[i]) != before[i], rewritten[i]) << "node " << i;
  const glm::mat4 a2_expected = w.get<Transform>(root).matrix() * w.get<Transform>(a).matrix() *
                                w.get<Transform>(a1).matrix() * w.get<Transform>(a2).matrix();
  EXPECT_LT(max_abs_diff(w.get<WorldTransform>(a2).matrix, a2_expected), 1e-5f);

  // A WorldTransform written by someone else (say physics) propagates to the children.
  const std::uint64_t b_tick = w.changed_tick<WorldTransform>(b);
  w.patch<WorldTransform>(b).matrix = glm::translate(glm::mat4(1), glm::vec3(10, 0, 0));
  update_world_transforms(w);
  EXPECT_GT(w.changed_tick<WorldTransform>(b), b_tick);
  EXPECT_LT(max_abs_diff(w.get<WorldTransform>(b1).matrix,
                         glm::translate(glm::mat4(1), glm::vec3(10, 0, 0)) * w.get<Transform>(b1).matrix()),
            1e-5f);
}

TEST(Transform, ReparentingAndDetachingKeepTheHierarchyConsistent) {
  World w;
  const auto at = [&](glm::vec3 p) {
    const Entity e = w.create();
    Transform t;
    t.translation = p;
    w.add<Transform>(e, t);
    return e;
  };
  const Entity p1 = at({1, 0, 0}), p2 = at({0, 2, 0}), c = at({0, 0, 3});
  EXPECT_TRUE(set_parent(w, c, p1));
  update_world_transforms(w);
  EXPECT_EQ(glm::vec3(w.get<WorldTransform>(c).matrix[3]), glm::vec3(1, 0, 3));

  EXPECT_TRUE(set_parent(w, c, p2));
  EXPECT_TRUE(w.get<Children>(p1).entities.empty());
  EXPECT_EQ(w.get<Children>(p2).entities, std::vector<Entity>{c});
  update_world_transforms(w);
  EXPECT_EQ(glm::vec3(w.get<WorldTransform>(c).matrix[3]), glm::vec3(0, 2, 3));

  // Cycles and stale handles are refused without changes.
  EXPECT_FALSE(set_parent(w, p2, c));
  EXPECT_FALSE(set_parent(w, c, c));
  const Entity gone = w.create();
  w.destroy(gone);
  EXPECT_FALSE(set_parent(w, c, gone));
  EXPECT_EQ(w.get<Parent>(c).entity, p2);

  EXPECT_TRUE(set_parent(w, c, Entity::null()));
  EXPECT_FALSE(w.has<Parent>(c));
  EXPECT_TRUE(w.get<Children>(p2).entities.empty());
  update_world_transforms(w);
  EXPECT_EQ(glm::vec3(w.get<WorldTransform>(c).matrix[3]), glm::vec3(0, 0, 3));

  // Destroying a parent turns its children into roots.
  EXPECT_TRUE(set_parent(w, c, p1));
  w.destroy(p1);
  w.patch<Transform>(c);
  update_world_transforms(w);
  EXPECT_EQ(glm::vec3(w.get<WorldTransform>(c).matrix[3]), glm::vec3(0, 0, 3));
}

TEST(Transform, DestroyHierarchyRemovesTheSubtreeOnly) {
  World w;
  std::vector<Entity> nodes;
  // A complete binary tree of 31 nodes: node i has children 2i+1 and 2i+2.
  for (int i = 0; i < 31; ++i) {
    nodes.push_back(w.create());
    w.add<Transform>(nodes.back());
    if (i > 0) set_parent(w, nodes.back(), nodes[static_cast<std::size_t>((i - 1) / 2)]);
  }
  destroy_hierarchy(w, nodes[1]);  // the left subtree: 15 nodes
  std::size_t alive = 0;
  for (const Entity e : nodes) alive += w.alive(e);
  EXPECT_EQ(alive, 16u);
  EXPECT_EQ(w.entity_count(), 16u);
  EXPECT_FALSE(w.alive(nodes[3]));
  EXPECT_FALSE(w.alive(nodes[15]));  // a leaf below node 1 (15 -> 7 -> 3 -> 1)
  EXPECT_TRUE(w.alive(nodes[2]));
  EXPECT_EQ(w.get<Children>(nodes[0]).entities, std::vector<Entity>{nodes[2]});
  destroy_hierarchy(w, nodes[1]);  // stale: ignored
  EXPECT_EQ(w.entity_count(), 16u);
}

TEST(Transform, RegisteredSystemRunsInTheTransformPhase) {
  World w;
  register_transform_systems(w);
  const Entity parent = w.create();
  Transform tp;
  tp.translation = {0, 1, 0};
  w.add<Transform>(parent, tp);
  const Entity child = w.create();
  w.add<Transform>(child, tp);
  set_parent(w, child, parent);
  w.update(0.0);
  EXPECT_EQ(glm::vec3(w.get<WorldTransform>(child).matrix[3]), glm::vec3(0, 2, 0));
  const std::uint64_t tick = w.changed_tick<WorldTransform>(child);
  w.update(0.0);
  EXPECT_EQ(w.changed_tick<WorldTransform>(child), tick);  // nothing changed
  w.patch<Transform>(parent).translation.y = 5;
  w.update(0.0);
  EXPECT_EQ(glm::vec3(w.get<WorldTransform>(child).matrix[3]), glm::vec3(0, 6, 0));
  ASSERT_EQ(w.systems().size(), 1u);
  EXPECT_EQ(w.systems()[0].name, "transforms");
  EXPECT_EQ(w.systems()[0].phase, Phase::Transform);
  EXPECT_EQ(w.systems()[0].writes, std::vector<ComponentId>{component_id<WorldTransform>()});
}

// A chain 100,000 nodes deep (an importer's worst case) links in linear time and its world
// transforms compose without recursion: the last node sits at depth x the step.
TEST(Transform, AHundredThousandDeepChainLinksAndUpdates) {
  World w;
  constexpr int kDepth = 100000;
  Entity parent = w.create();
  w.add<Transform>(parent);
  Entity last = parent;
  for (int i = 1; i < kDepth; ++i) {
    const Entity e = w.create();
    w.add<Transform>(e, Transform{glm::vec3(0.0f, 0.0f, 0.001f)});
    ASSERT_TRUE(set_parent(w, e, last));
    last = e;
  }
  EXPECT_FALSE(set_parent(w, parent, last)) << "the root below its own descendant: a cycle";
  update_world_transforms(w);
  // 100,000 float products: within 0.1 % of the exact sum.
  EXPECT_NEAR(w.get<WorldTransform>(last).matrix[3].z, 0.001f * (kDepth - 1), 0.1f);
}

}  // namespace
}  // namespace penumbra
