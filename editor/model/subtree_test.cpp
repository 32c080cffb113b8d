// Creating, deleting and duplicating entities as undo entries, on the built-in courtyard (a
// hierarchy with an arch of meshes, a skinned walker) and CesiumMan.
#include "subtree.h"

#include <unistd.h>

#include <filesystem>
#include <set>

#include <gtest/gtest.h>

#include "document.h"
#include "penumbra/ao_field/ao_field.h"
#include "penumbra/ecs/transform.h"
#include "penumbra/scene/components.h"
#include "penumbra/scene/entity_key.h"
#include "checkout_paths.h"

namespace penumbra::editor {
namespace {

std::unique_ptr<Document> open(const std::string& source) {
  auto doc = Document::open(source, Preset::Draft);
  EXPECT_TRUE(doc.ok()) << (doc.ok() ? "" : doc.error().message);
  return doc.ok() ? std::move(*doc) : nullptr;
}

std::vector<std::string> child_names(World& w, Entity e) {
  std::vector<std::string> out;
  for (Entity c : w.get<Children>(e).entities) out.push_back(w.get<Name>(c).value);
  return out;
}

TEST(Subtree, DeleteAndUndoBringBackTheSubtreeInPlaceWithItsComponentsKeysAndEdits) {
  auto doc = open("builtin:courtyard");
  ASSERT_TRUE(doc);
  World& w = doc->world();
  const Entity arch = *doc->find("arch");
  const Entity root = w.get<Parent>(arch).entity;
  const std::vector<std::string> roots_before = child_names(w, root);
  const std::size_t count = w.entity_count();
  const std::vector<Entity> subtree = subtree_of(w, arch);
  ASSERT_GE(subtree.size(), 3u);
  std::vector<std::string> names;
  for (Entity e : subtree) names.push_back(w.get<Name>(e).value);
  const Entity post = subtree[1];
  const std::string post_key = entity_key(w, post);
  const auto mesh = w.get<Mesh>(post).data;
  // A caster on a post and an edit of the arch before the delete.
  ASSERT_TRUE(doc->undo().add_component(w, post, *find_authored_component("AOFieldCaster"), Preset::Draft).ok());
  ASSERT_TRUE(doc->undo().set(w, arch, *find_field("Transform", "translation"), FieldValue(glm::vec3(1, 0, 6))).ok());
  doc->select(post);

  ASSERT_TRUE(doc->delete_entity(arch).ok());
  EXPECT_EQ(w.entity_count(), count - subtree.size());
  for (Entity e : subtree) EXPECT_FALSE(w.alive(e));
  EXPECT_FALSE(doc->selection());
  EXPECT_FALSE(doc->find("arch").ok());

  ASSERT_TRUE(doc->undo_edit());
  EXPECT_EQ(w.entity_count(), count);
  const Entity back = *doc->find("arch");
  EXPECT_EQ(doc->selection(), back);
  EXPECT_EQ(w.get<Parent>(back).entity, root);
  EXPECT_EQ(child_names(w, root), roots_before);  // the same place among its siblings
  const std::vector<Entity> restored = subtree_of(w, back);
  ASSERT_EQ(restored.size(), subtree.size());
  for (std::size_t i = 0; i < restored.size(); ++i) {
    EXPECT_EQ(w.get<Name>(restored[i]).value, names[i]);
    if (i > 0) {
      EXPECT_EQ(w.get<Parent>(restored[i]).entity, back);
    }
  }
  EXPECT_EQ(entity_key(w, restored[1]), post_key);  // a bake attaches to it as before
  EXPECT_EQ(w.get<Mesh>(restored[1]).data, mesh);
  EXPECT_TRUE(w.has<AOFieldCaster>(restored[1]));
  EXPECT_EQ(w.get<Transform>(back).translation, glm::vec3(1, 0, 6));
  // The entries from before the delete follow the new handles: undo the move, then the caster.
  ASSERT_TRUE(doc->undo_edit());
  EXPECT_EQ(w.get<Transform>(back).translation, glm::vec3(0, 0, 6));
  ASSERT_TRUE(doc->undo_edit());
  EXPECT_FALSE(w.has<AOFieldCaster>(restored[1]));
  // Redo all three: the delete again.
  ASSERT_TRUE(doc->redo_edit());
  ASSERT_TRUE(doc->redo_edit());
  ASSERT_TRUE(doc->redo_edit());
  EXPECT_FALSE(doc->find("arch").ok());
  EXPECT_EQ(w.entity_count(), count - subtree.size());
}

TEST(Subtree, DuplicateCopiesTheSubtreeBesideItAndUndoRemovesIt) {
  auto doc = open("builtin:courtyard");
  ASSERT_TRUE(doc);
  World& w = doc->world();
  const Entity arch = *doc->find("arch");
  const Entity root = w.get<Parent>(arch).entity;
  const std::size_t count = w.entity_count(), size = subtree_of(w, arch).size();
  auto copy = doc->duplicate(arch);
  ASSERT_TRUE(copy.ok()) << copy.error().message;
  EXPECT_EQ(doc->selection(), *copy);
  EXPECT_EQ(w.get<Name>(*copy).value, "arch (2)");
  EXPECT_EQ(w.entity_count(), count + size);
  const std::vector<std::string> names = child_names(w, root);
  const auto at = std::find(names.begin(), names.end(), "arch");
  ASSERT_NE(at, names.end());
  ASSERT_NE(at + 1, names.end());
  EXPECT_EQ(*(at + 1), "arch (2)");
  const std::vector<Entity> copies = subtree_of(w, *copy), originals = subtree_of(w, arch);
  ASSERT_EQ(copies.size(), size);
  std::set<std::uint32_t> original_indices;
  for (Entity e : originals) original_indices.insert(e.index);
  for (std::size_t i = 1; i < copies.size(); ++i) {
    EXPECT_FALSE(original_indices.contains(copies[i].index));
    EXPECT_EQ(w.get<Parent>(copies[i]).entity, *copy);
    EXPECT_EQ(w.get<Mesh>(copies[i]).data, w.get<Mesh>(originals[i]).data);
  }
  EXPECT_NE(entity_key(w, copies[1]), entity_key(w, originals[1]));
  // The copy is its own: moving it leaves the original.
  ASSERT_TRUE(doc->undo().set(w, *copy, *find_field("Transform", "translation"), FieldValue(glm::vec3(4, 0, 6))).ok());
  EXPECT_EQ(w.get<Transform>(arch).translation, glm::vec3(0, 0, 6));
  // A second copy of either is "arch (3)".
  EXPECT_EQ(copy_name(w, *copy), "arch (3)");
  EXPECT_EQ(copy_name(w, arch), "arch (3)");
  // Undo the move and the duplicate; redo both: the copy comes back where it was moved.
  ASSERT_TRUE(doc->undo_edit());
  ASSERT_TRUE(doc->undo_edit());
  EXPECT_EQ(w.entity_count(), count);
  EXPECT_FALSE(doc->find("arch (2)").ok());
  ASSERT_TRUE(doc->redo_edit());
  ASSERT_TRUE(doc->redo_edit());
  const Entity again = *doc->find("arch (2)");
  EXPECT_EQ(w.get<Transform>(again).translation, glm::vec3(4, 0, 6));
  EXPECT_EQ(w.entity_count(), count + size);
}

TEST(Subtree, CreatedLightsAreUndoableAndBadRequestsAreRefused) {
  auto doc = open("builtin:courtyard");
  ASSERT_TRUE(doc);
  World& w = doc->world();
  const Entity arch = *doc->find("arch");
  auto lamp = doc->create_entity("spot-light", "lamp 2", arch, glm::vec3(0, 2, 0));
  ASSERT_TRUE(lamp.ok()) << lamp.error().message;
  EXPECT_EQ(w.get<Light>(*lamp).type, Light::Type::Spot);
  EXPECT_EQ(w.get<Parent>(*lamp).entity, arch);
  EXPECT_EQ(w.get<Transform>(*lamp).translation, glm::vec3(0, 2, 0));
  EXPECT_EQ(entity_key(w, *lamp), "arch/lamp 2");
  ASSERT_TRUE(doc->undo_edit());
  EXPECT_FALSE(w.alive(*lamp));
  ASSERT_TRUE(doc->redo_edit());
  const Entity back = *doc->find("lamp 2");
  EXPECT_EQ(w.get<Light>(back).type, Light::Type::Spot);
  EXPECT_EQ(doc->selection(), back);

  const auto kind = doc->create_entity("torch", "t", Entity::null());
  ASSERT_FALSE(kind.ok());
  EXPECT_NE(kind.error().message.find("point-light"), std::string::npos) << kind.error().message;
  EXPECT_FALSE(doc->create_entity("empty", "", Entity::null()).ok());
  EXPECT_FALSE(doc->create_entity("empty", "x", *lamp).ok());  // a stale parent
  EXPECT_FALSE(doc->delete_entity(*lamp).ok());
  EXPECT_FALSE(doc->duplicate(*lamp).ok());
}

// In a glTF document: what was duplicated, created and deleted is saved as the file's nodes and
// comes back on reopening; undone, the file saves as it was.
TEST(Subtree, EditsOfAGltfDocumentSaveAsItsNodes) {
  const std::filesystem::path source = std::filesystem::path(checkout::kSourceDir) / "tests/data/gltf/valid.gltf";
  auto doc = open(source.string());
  ASSERT_TRUE(doc);
  World& w = doc->world();
  auto copy = doc->duplicate(*doc->find("quad"));
  ASSERT_TRUE(copy.ok());
  ASSERT_TRUE(doc->undo().set(w, *copy, *find_field("Transform", "translation"), FieldValue(glm::vec3(2, 0, 0))).ok());
  auto lamp = doc->create_entity("point-light", "lamp", Entity::null(), glm::vec3(0, 2, 0));
  ASSERT_TRUE(lamp.ok());
  ASSERT_TRUE(doc->delete_entity(*doc->find("eye")).ok());
  const auto out = std::filesystem::temp_directory_path() / ("penumbra_doc_" + std::to_string(::getpid()) + ".gltf");
  ASSERT_TRUE(doc->save_gltf(out).ok());

  auto reopened = open(out.string());
  ASSERT_TRUE(reopened);
  World& r = reopened->world();
  const Entity quad2 = *reopened->find("quad (2)");
  EXPECT_EQ(r.get<Transform>(quad2).translation, glm::vec3(2, 0, 0));
  ASSERT_TRUE(r.has<Children>(quad2));
  EXPECT_TRUE(r.has<Mesh>(r.get<Children>(quad2).entities.front()));
  EXPECT_EQ(r.get<Light>(*reopened->find("lamp")).type, Light::Type::Point);
  EXPECT_FALSE(reopened->find("eye").ok());
  EXPECT_EQ(r.view<Camera>().count(), 0u);

  // Undo all four: saving gives back what the file had.
  for (int i = 0; i < 4; ++i) ASSERT_TRUE(doc->undo_edit());
  ASSERT_TRUE(doc->save_gltf(out).ok());
  auto original = open(out.string());
  ASSERT_TRUE(original);
  EXPECT_TRUE(original->find("eye").ok());
  EXPECT_FALSE(original->find("quad (2)").ok());
  EXPECT_FALSE(original->find("lamp").ok());
  EXPECT_EQ(original->world().entity_count(), w.entity_count());
  std::filesystem::remove(out);
}

// The skinned walker: its copy's skin names the copy's joints, and deleting then restoring a
// joint's subtree gives the skin and the clips the restored joints.
TEST(Subtree, SkinsAndClipsFollowCopiedAndRestoredJoints) {
  const std::filesystem::path cesium = std::filesystem::path(checkout::kSharedDir) / "assets/CesiumMan.glb";
  if (!std::filesystem::exists(cesium)) GTEST_SKIP() << cesium << " is absent (../shared/assets)";
  auto doc = open(cesium.string());
  ASSERT_TRUE(doc);
  World& w = doc->world();
  Entity skinned;
  w.each<Skin>([&](Entity e, Skin&) { skinned = e; });
  ASSERT_TRUE(skinned);
  const Entity character = w.get<Parent>(skinned).entity;  // the node that holds the mesh
  const Entity root = w.get<Parent>(character).entity;     // the node the armature is under too
  auto copy = doc->duplicate(root);
  ASSERT_TRUE(copy.ok()) << copy.error().message;
  std::set<std::uint32_t> in_copy;
  for (Entity e : subtree_of(w, *copy)) in_copy.insert(e.index);
  int copied_skins = 0;
  w.each<Skin>([&](Entity e, Skin& s) {
    if (!in_copy.contains(e.index)) {
      for (Entity j : s.joints) EXPECT_FALSE(in_copy.contains(j.index));
      return;
    }
    ++copied_skins;
    for (Entity j : s.joints) {
      EXPECT_TRUE(w.alive(j));
      EXPECT_TRUE(in_copy.contains(j.index));
    }
  });
  EXPECT_GE(copied_skins, 1);
  // Saved and reopened: the copy's skin is over the copy's joints (a new skin in the file), so it
  // stands where it was moved to, not on the original's skeleton.
  ASSERT_TRUE(doc->undo().set(w, *copy, *find_field("Transform", "translation"), FieldValue(glm::vec3(2, 0, 0))).ok());
  const auto out = std::filesystem::temp_directory_path() / ("penumbra_cesium_" + std::to_string(::getpid()) + ".glb");
  ASSERT_TRUE(doc->save_gltf(out).ok());
  {
    auto reopened = open(out.string());
    ASSERT_TRUE(reopened);
    World& r = reopened->world();
    const Entity copy_root = *reopened->find(w.get<Name>(*copy).value);
    std::set<std::uint32_t> below;
    for (Entity e : subtree_of(r, copy_root)) below.insert(e.index);
    int skins_below = 0;
    r.each<Skin>([&](Entity e, Skin& s) {
      const bool mine = below.contains(e.index);
      skins_below += mine ? 1 : 0;
      for (Entity j : s.joints) EXPECT_EQ(below.contains(j.index), mine);
    });
    EXPECT_GE(skins_below, 1);
  }
  std::filesystem::remove(out);

  // A joint alone is refused (the skin needs it), naming it and the mesh.
  const Entity joint = w.get<Skin>(skinned).joints.front();
  const Status refused = doc->delete_entity(joint);
  ASSERT_FALSE(refused.ok());
  EXPECT_NE(refused.error().message.find("is a joint of the skin of"), std::string::npos) << refused.error().message;
  // The character's node with its skeleton and meshes, then undo: skins and clips name live joints.
  const std::size_t skins = w.view<Skin>().count();
  ASSERT_TRUE(doc->delete_entity(root).ok());
  EXPECT_LT(w.view<Skin>().count(), skins);
  ASSERT_TRUE(doc->undo_edit());
  EXPECT_FALSE(w.alive(skinned));  // back under a new handle
  EXPECT_EQ(w.view<Skin>().count(), skins);
  w.each<Skin>([&](Entity, Skin& s) {
    for (Entity j : s.joints) EXPECT_TRUE(w.alive(j));
  });
  w.each<Animator>([&](Entity, Animator& a) {
    for (const AnimationClip& c : *a.clips)
      for (Entity t : c.targets) EXPECT_TRUE(w.alive(t));
  });
}

}  // namespace
}  // namespace penumbra::editor
