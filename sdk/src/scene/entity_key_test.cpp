// Stable entity keys: name paths below the root, sibling disambiguation, host keys, lookups that
// survive another creation order, and errors that name the key.
#include "penumbra/scene/entity_key.h"

#include <gtest/gtest.h>

#include <vector>

#include "penumbra/ecs/transform.h"
#include "penumbra/scene/components.h"

namespace penumbra {
namespace {

Entity named(World& w, const char* name, Entity parent = Entity::null()) {
  const Entity e = w.create();
  w.add<Name>(e, Name{name});
  if (parent) set_parent(w, e, parent);
  return e;
}

TEST(EntityKey, NamePathBelowTheRootWithDuplicateSiblingsNumbered) {
  World w;
  const Entity root = named(w, "/some/dir/level.glb");
  const Entity body = named(w, "Body", root);
  const Entity mesh = named(w, "mesh", body);
  const Entity twin = named(w, "mesh", body);
  const Entity third = named(w, "mesh", body);
  EXPECT_EQ(entity_key(w, root), "/some/dir/level.glb");  // a root is its own name
  EXPECT_EQ(entity_key(w, body), "Body");
  EXPECT_EQ(entity_key(w, mesh), "Body/mesh");
  EXPECT_EQ(entity_key(w, twin), "Body/mesh[1]");
  EXPECT_EQ(entity_key(w, third), "Body/mesh[2]");
  w.add<EntityKey>(twin, EntityKey{"engine:42"});
  EXPECT_EQ(entity_key(w, twin), "engine:42");
  const Entity unnamed = w.create();
  EXPECT_EQ(entity_key(w, unnamed), "");
  EXPECT_EQ(entity_key(w, named(w, "child", unnamed)), "child");  // an unnamed root is left out too
  EXPECT_EQ(entity_key(w, Entity::null()), "");
  // A host key on an ancestor prefixes its subtree; on the root, every key below it.
  w.add<EntityKey>(body, EntityKey{"hero"});
  EXPECT_EQ(entity_key(w, mesh), "hero/mesh");
  w.add<EntityKey>(root, EntityKey{"level-2"});
  EXPECT_EQ(entity_key(w, named(w, "Floor", root)), "level-2/Floor");
  // An unnamed node on the path leaves no key; the index gives the same keys as one by one.
  const Entity hidden = w.create();
  set_parent(w, hidden, root);
  EXPECT_EQ(entity_key(w, named(w, "leaf", hidden)), "");
  const EntityKeys keys = EntityKeys::build(w);
  for (Entity e : {body, mesh, twin, third})
    EXPECT_EQ(*keys.find(entity_key(w, e), "test"), e) << entity_key(w, e);
}

// Ten thousand siblings under one root: the index is built in linear time (a quadratic sibling scan
// would take seconds) and numbers the shared names in order.
TEST(EntityKey, ManySiblingsAreIndexedOnceEach) {
  World w;
  const Entity root = named(w, "scene");
  std::vector<Entity> crates;
  for (int i = 0; i < 10000; ++i) crates.push_back(named(w, "crate", root));
  const EntityKeys keys = EntityKeys::build(w);
  EXPECT_EQ(*keys.find("crate", "test"), crates[0]);
  EXPECT_EQ(*keys.find("crate[9999]", "test"), crates[9999]);
}

// The same scene created in another order (other indices) resolves each key to the same node.
TEST(EntityKey, KeysFindTheSameNodesWhateverTheCreationOrder) {
  World a, b;
  const Entity ra = named(a, "scene");
  const Entity lamp_a = named(a, "lamp", named(a, "props", ra));
  for (int i = 0; i < 5; ++i) b.create();  // shift every index
  const Entity rb = named(b, "scene");
  const Entity props_b = named(b, "props", rb);
  const Entity lamp_b = named(b, "lamp", props_b);
  ASSERT_NE(lamp_a.index, lamp_b.index);
  const std::string key = entity_key(a, lamp_a);
  auto found = EntityKeys::build(b).find(key, "test");
  ASSERT_TRUE(found.ok()) << found.error().message;
  EXPECT_EQ(*found, lamp_b);
}

TEST(EntityKey, MissingAndSharedKeysAreErrorsNamingTheKey) {
  World w;
  const Entity root = named(w, "scene");
  named(w, "crate", root);
  const Entity other = named(w, "other", root);
  w.add<EntityKey>(other, EntityKey{"crate"});  // the host key collides with a name path
  const EntityKeys keys = EntityKeys::build(w);
  auto shared = keys.find("crate", "chunk 'AOFC'");
  ASSERT_FALSE(shared.ok());
  EXPECT_EQ(shared.error().code, ErrorCode::InvalidInput);
  EXPECT_NE(shared.error().message.find("2 entities have the key 'crate'"), std::string::npos)
      << shared.error().message;
  auto missing = keys.find("barrel", "chunk 'AOFC'");
  ASSERT_FALSE(missing.ok());
  EXPECT_EQ(missing.error().code, ErrorCode::NotFound);
  EXPECT_NE(missing.error().message.find("chunk 'AOFC': no entity has the key 'barrel'"), std::string::npos)
      << missing.error().message;
}

}  // namespace
}  // namespace penumbra
