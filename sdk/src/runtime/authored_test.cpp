// apply_authored_lighting: a glTF level's PENUMBRA_lighting declarations become the modules'
// components by their field lists (presets first, then the fields), on the node or on its meshes;
// every mistake is refused naming the file, the node, the component and the field.
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <set>
#include <string>
#include <vector>

#include "penumbra/ao_field/ao_field.h"
#include "penumbra/ecs/transform.h"
#include "penumbra/import/gltf.h"
#include "penumbra/probe_grid/probe_grid.h"
#include "penumbra/runtime.h"
#include "penumbra/scene/components.h"
#include "checkout_paths.h"

namespace penumbra {
namespace {

const std::filesystem::path kCases = std::filesystem::path(checkout::kSourceDir) / "tests/data/gltf";

Entity named(World& world, const std::string& name) {
  Entity found;
  world.each<Name>([&](Entity e, Name& n) {
    if (n.value == name && !found) found = e;
  });
  return found;
}

TEST(AuthoredLighting, AGltfLevelDeclaresItsComponents) {
  World world;
  register_lighting(world);
  auto loaded = load_scene(world, (kCases / "lighting_extension.gltf").string());
  ASSERT_TRUE(loaded.ok()) << loaded.error().message;
  world.update(0.0);
  ASSERT_TRUE(add_default_lighting(world, Preset::Medium, true).ok());
  EXPECT_EQ(world.view<AuthoredLighting>().count(), 0u);  // consumed

  // The probe grid on its node (a unit-cube box through the node's transform): the draft preset,
  // then the declared spacing and SH order.
  const Entity probes = named(world, "probes");
  ASSERT_TRUE(world.has<IrradianceProbeGrid>(probes));
  const IrradianceProbeGrid& grid = world.get<IrradianceProbeGrid>(probes);
  const IrradianceProbeGrid draft = IrradianceProbeGrid::preset(Preset::Draft);
  EXPECT_EQ(grid.spacing, 1.0f);
  EXPECT_EQ(grid.sh_order, ProbeShOrder::L1);
  EXPECT_EQ(grid.samples_per_node, draft.samples_per_node);
  EXPECT_EQ(world.view<IrradianceProbeGrid>().count(), 1u);  // no default grid besides it

  // The AO-field caster on the crate's mesh (its primitive's entity), not on the node.
  const Entity crate = named(world, "crate");
  EXPECT_FALSE(world.has<AOFieldCaster>(crate));
  std::size_t casters = 0;
  world.each<AOFieldCaster, Mesh>([&](Entity, AOFieldCaster& c, Mesh&) {
    ++casters;
    EXPECT_EQ(c.falloff_distance, 1.5f);
    EXPECT_EQ(c.rays_per_sample, AOFieldCaster::preset(Preset::Draft).rays_per_sample);
  });
  EXPECT_EQ(casters, 1u);
}

TEST(AuthoredLighting, MistakesNameTheNodeTheComponentAndTheField) {
  struct Case {
    const char* what;
    AuthoredComponent component;
    bool node_has_mesh;
    std::vector<const char*> mentions;
  };
  const auto with = [](const char* type, const char* field, AuthoredValue v, const char* preset = "") {
    AuthoredComponent c;
    c.type = type;
    c.preset = preset;
    if (field[0] != '\0') c.fields.emplace_back(field, std::move(v));
    return c;
  };
  const Case cases[] = {
      {"unknown component", with("Lightmap", "", false), false, {"Lightmap", "use one of", "IrradianceProbeGrid"}},
      {"unknown field", with("IrradianceProbeGrid", "spaceing", 1.0), false, {"no field 'spaceing'", "spacing"}},
      {"wrong form", with("IrradianceProbeGrid", "spacing", std::string("wide")), false,
       {"IrradianceProbeGrid", "field 'spacing' takes a number"}},
      {"out of range", with("IrradianceProbeGrid", "samples_per_node", 0.0), false, {"samples_per_node", "outside"}},
      {"not an integer", with("IrradianceProbeGrid", "samples_per_node", 2.5), false, {"takes an integer"}},
      {"unknown choice", with("IrradianceProbeGrid", "sh_order", std::string("L3")), false, {"\"L1\"", "\"L2\""}},
      {"unknown preset", with("IrradianceProbeGrid", "", false, "ultra"), false, {"preset 'ultra'"}},
      {"read-only field", with("ProbeLit", "covered", true), true, {"written by the runtime"}},
      {"per-mesh on a node without mesh", with("AOFieldCaster", "", false), false, {"belongs on a mesh"}},
      {"NaN", with("AOFieldCaster", "falloff_distance", std::nan("")), true, {"falloff_distance", "finite numbers"}},
      {"beyond float", with("AOFieldCaster", "falloff_distance", 1e300), true, {"falloff_distance", "3.4e38"}},
      {"vector beyond float", with("IrradianceProbeGrid", "box_min", std::vector<double>{0, 1e39, 0}), false,
       {"box_min", "3.4e38"}},
  };
  for (const Case& c : cases) {
    World world;
    register_lighting(world);
    const Entity node = world.create();
    AuthoredLighting a;
    a.source = "level.gltf: nodes[4] 'hall'.extensions.PENUMBRA_lighting";
    a.components.push_back(c.component);
    if (c.node_has_mesh) {
      const Entity mesh = world.create();
      world.add<Mesh>(mesh, Mesh{std::make_shared<MeshData>()});
      a.meshes.push_back(mesh);
    }
    world.add<AuthoredLighting>(node, a);
    const Status s = apply_authored_lighting(world);
    ASSERT_FALSE(s.ok()) << c.what << " was accepted";
    EXPECT_EQ(s.error().code, ErrorCode::InvalidInput) << c.what;
    EXPECT_EQ(s.error().message.rfind(a.source, 0), 0u) << s.error().message;
    for (const char* m : c.mentions) EXPECT_NE(s.error().message.find(m), std::string::npos) << c.what << ": " << s.error().message;
  }
}

World imported(const std::filesystem::path& path) {
  World world;
  register_lighting(world);
  auto loaded = load_scene(world, path.string());
  EXPECT_TRUE(loaded.ok()) << loaded.error().message;
  world.update(0.0);
  EXPECT_TRUE(apply_authored_lighting(world).ok());
  world.update(0.0);
  return world;
}

// gltf_edits, which these scenes never fail.
GltfEdits edits_of(World& world) {
  auto edits = gltf_edits(world);
  EXPECT_TRUE(edits.ok()) << edits.error().message;
  return edits.ok() ? *edits : GltfEdits{};
}

TEST(AuthoredLighting, SavedGltfReopensWithTheEditsAndKeepsTheRest) {
  World world = imported(kCases / "lighting_extension.gltf");
  world.patch<IrradianceProbeGrid>(named(world, "probes")).spacing = 2.0f;
  world.patch<Transform>(named(world, "probes")).translation = {1.0f, 1.5f, -1.0f};
  world.patch<Light>(named(world, "sun")).intensity = 5.0f;
  world.add<Environment>(named(world, "sun"), Environment{{0.1f, 0.2f, 0.3f}});  // a sky, saved on its node
  const auto out = std::filesystem::temp_directory_path() / ("penumbra_saved_" + std::to_string(::getpid()) + ".gltf");
  ASSERT_TRUE(save_gltf(kCases / "lighting_extension.gltf", out, edits_of(world)).ok());

  World reopened = imported(out);
  EXPECT_EQ(reopened.get<IrradianceProbeGrid>(named(reopened, "probes")).spacing, 2.0f);
  EXPECT_EQ(reopened.get<IrradianceProbeGrid>(named(reopened, "probes")).sh_order, ProbeShOrder::L1);
  EXPECT_EQ(reopened.get<Transform>(named(reopened, "probes")).translation, glm::vec3(1.0f, 1.5f, -1.0f));
  EXPECT_EQ(reopened.get<Light>(named(reopened, "sun")).intensity, 5.0f);
  EXPECT_EQ(world_environment(reopened).radiance, glm::vec3(0.1f, 0.2f, 0.3f));
  std::size_t casters = 0;
  reopened.each<AOFieldCaster>([&](Entity, AOFieldCaster& c) {
    ++casters;
    EXPECT_EQ(c.falloff_distance, 1.5f);
  });
  EXPECT_EQ(casters, 1u);
  // Saving what was reopened gives the same file (a fixed point), and what no edit touches is
  // kept as read.
  const auto again = std::filesystem::temp_directory_path() / ("penumbra_saved2_" + std::to_string(::getpid()) + ".gltf");
  ASSERT_TRUE(save_gltf(out, again, edits_of(reopened)).ok());
  const auto text = [](const std::filesystem::path& p) {
    std::ifstream in(p);
    return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  };
  EXPECT_EQ(text(out), text(again));
  const std::string saved = text(out);
  for (const char* kept : {"\"animations\"", "\"samplers\"", "data:application/octet-stream;base64,", "\"grey\""})
    EXPECT_NE(saved.find(kept), std::string::npos) << kept;
  std::filesystem::remove(out);
  std::filesystem::remove(again);
}

// A scene saved without changes is the file it came from, up to formatting: transforms (a matrix
// included), lights and the rest keep the file's own numbers.
TEST(AuthoredLighting, AnUnchangedSceneSavesAsTheFileItCameFrom) {
  for (const char* name : {"valid.gltf", "lighting_extension.gltf", "scaled_armature.gltf"}) {
    World world = imported(kCases / name);
    const auto out = std::filesystem::temp_directory_path() / ("penumbra_same_" + std::to_string(::getpid()) + ".gltf");
    ASSERT_TRUE(save_gltf(kCases / name, out, edits_of(world)).ok()) << name;
    nlohmann::ordered_json source, saved;
    std::ifstream(kCases / name) >> source;
    std::ifstream(out) >> saved;
    EXPECT_EQ(saved, source) << name << ":\n" << saved.dump(1);
    std::filesystem::remove(out);
  }
  // A node given as a matrix keeps it unless it moves.
  nlohmann::ordered_json with_matrix;
  std::ifstream(kCases / "valid.gltf") >> with_matrix;
  with_matrix["nodes"][0].erase("translation");
  with_matrix["nodes"][0]["matrix"] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 1, 0, 1};
  const auto source = std::filesystem::temp_directory_path() / ("penumbra_matrix_" + std::to_string(::getpid()) + ".gltf");
  std::ofstream(source) << with_matrix.dump();
  World world = imported(source);
  const auto out = std::filesystem::temp_directory_path() / ("penumbra_matrix_out_" + std::to_string(::getpid()) + ".gltf");
  ASSERT_TRUE(save_gltf(source, out, edits_of(world)).ok());
  nlohmann::ordered_json saved;
  std::ifstream(out) >> saved;
  EXPECT_EQ(saved["nodes"][0], with_matrix["nodes"][0]);
  world.patch<Transform>(named(world, "root")).translation.y = 2.0f;
  ASSERT_TRUE(save_gltf(source, out, edits_of(world)).ok());
  std::ifstream(out) >> saved;
  EXPECT_FALSE(saved["nodes"][0].contains("matrix"));
  EXPECT_EQ(saved["nodes"][0]["translation"][1], 2.0);
  std::filesystem::remove(source);
  std::filesystem::remove(out);
}

// Entities made after the import (a copy of a node with its mesh primitive, a new light with a
// probe grid, under the copy) are saved as new nodes; a deleted node leaves the scene.
TEST(AuthoredLighting, NewAndDeletedEntitiesSaveAsAddedAndRemovedNodes) {
  World world = imported(kCases / "valid.gltf");
  const Entity root = named(world, "root"), quad = named(world, "quad");
  const Entity copy = world.create();
  world.add<Name>(copy, Name{"quad copy"});
  world.add<Transform>(copy, Transform{{2.0f, 0.0f, 0.0f}});
  world.add<GltfNodeCopy>(copy, GltfNodeCopy{world.get<GltfNode>(quad).index});
  set_parent(world, copy, root);
  const Entity primitive = world.create();
  world.add<Transform>(primitive);
  world.add<Mesh>(primitive, world.get<Mesh>(world.get<Children>(quad).entities.front()));
  set_parent(world, primitive, copy);
  const Entity lamp = world.create();
  world.add<Name>(lamp, Name{"lamp"});
  world.add<Transform>(lamp, Transform{{0.0f, 2.0f, 0.0f}});
  Light light;
  light.intensity = 12.0f;
  world.add<Light>(lamp, light);
  world.add<IrradianceProbeGrid>(lamp, IrradianceProbeGrid::preset(Preset::Draft));
  set_parent(world, lamp, copy);
  destroy_hierarchy(world, named(world, "eye"));
  const Entity outside = world.create();  // not below the file's root: not the file's
  world.add<Name>(outside, Name{"viewer light"});
  world.add<Transform>(outside);
  world.add<Light>(outside);

  const auto out = std::filesystem::temp_directory_path() / ("penumbra_added_" + std::to_string(::getpid()) + ".gltf");
  const GltfEdits edits = edits_of(world);
  ASSERT_EQ(edits.added.size(), 2u);
  EXPECT_EQ(edits.removed, std::vector<std::uint32_t>{3});
  ASSERT_TRUE(save_gltf(kCases / "valid.gltf", out, edits).ok());
  nlohmann::ordered_json saved;
  std::ifstream(out) >> saved;
  ASSERT_EQ(saved["nodes"].size(), 6u);
  EXPECT_EQ(saved["nodes"][0]["children"], nlohmann::ordered_json::array({1, 2, 4}));  // eye (3) out, the copy in
  EXPECT_EQ(saved["nodes"][4]["mesh"], 0);
  EXPECT_EQ(saved["nodes"][4]["children"], nlohmann::ordered_json::array({5}));
  EXPECT_EQ(saved["extensions"]["KHR_lights_punctual"]["lights"].size(), 2u);

  World reopened = imported(out);
  EXPECT_FALSE(reopened.alive(named(reopened, "eye")));
  EXPECT_EQ(reopened.view<Camera>().count(), 0u);
  EXPECT_FALSE(reopened.alive(named(reopened, "viewer light")));
  const Entity quad2 = named(reopened, "quad copy");
  ASSERT_TRUE(reopened.alive(quad2));
  EXPECT_EQ(reopened.get<Transform>(quad2).translation, glm::vec3(2.0f, 0.0f, 0.0f));
  std::size_t meshes = 0;
  for (Entity k : reopened.get<Children>(quad2).entities) meshes += reopened.has<Mesh>(k) ? 1 : 0;
  EXPECT_EQ(meshes, 2u);  // the node's mesh, both its primitives
  const Entity lamp2 = named(reopened, "lamp");
  ASSERT_TRUE(reopened.alive(lamp2));
  EXPECT_EQ(reopened.get<Parent>(lamp2).entity, quad2);
  EXPECT_EQ(reopened.get<Light>(lamp2).type, Light::Type::Point);
  EXPECT_EQ(reopened.get<Light>(lamp2).intensity, 12.0f);
  EXPECT_EQ(reopened.get<IrradianceProbeGrid>(lamp2).samples_per_node,
            IrradianceProbeGrid::preset(Preset::Draft).samples_per_node);
  // Saved again unchanged: the same file.
  const auto again = std::filesystem::temp_directory_path() / ("penumbra_added2_" + std::to_string(::getpid()) + ".gltf");
  ASSERT_TRUE(save_gltf(out, again, edits_of(reopened)).ok());
  nlohmann::ordered_json saved_again;
  std::ifstream(again) >> saved_again;
  EXPECT_EQ(saved_again, saved);

  // A second copy of a primitive under one node has no glTF form: refused, naming it.
  const Entity twin = world.create();
  world.add<Name>(twin, Name{"twin"});
  world.add<Transform>(twin);
  world.add<Mesh>(twin, world.get<Mesh>(primitive));
  set_parent(world, twin, copy);
  const auto refused = gltf_edits(world);
  ASSERT_FALSE(refused.ok());
  EXPECT_NE(refused.error().message.find("twin"), std::string::npos) << refused.error().message;

  // A deleted node an animation targets: the saved file keeps the channel (the node stays in the
  // file, out of the scene) and imports again, the channel skipped with a warning naming it.
  World wave = imported(kCases / "scaled_armature_wave.gltf");
  destroy_hierarchy(wave, named(wave, "rig:prop"));
  const auto waved = std::filesystem::temp_directory_path() / ("penumbra_wave_" + std::to_string(::getpid()) + ".gltf");
  ASSERT_TRUE(save_gltf(kCases / "scaled_armature_wave.gltf", waved, edits_of(wave)).ok());
  World rewaved;
  auto reimported = import_gltf(rewaved, waved);
  ASSERT_TRUE(reimported.ok()) << reimported.error().message;
  EXPECT_FALSE(rewaved.alive(named(rewaved, "rig:prop")));
  bool warned = false;
  for (const std::string& w : reimported->warnings) warned = warned || w.find("is not in the scene; channel skipped") != std::string::npos;
  EXPECT_TRUE(warned);
  std::filesystem::remove(waved);

  // The whole character deleted, skeleton and mesh: its skin stays in the file, used by no node of
  // the scene, and the file imports again without it.
  World gone = imported(kCases / "scaled_armature.gltf");
  destroy_hierarchy(gone, named(gone, "Armature"));
  ASSERT_TRUE(save_gltf(kCases / "scaled_armature.gltf", waved, edits_of(gone)).ok());
  World regone;
  auto without = import_gltf(regone, waved);
  ASSERT_TRUE(without.ok()) << without.error().message;
  EXPECT_EQ(without->skins, 0u);
  EXPECT_EQ(regone.view<Skin>().count(), 0u);
  std::filesystem::remove(waved);

  // save_gltf itself refuses to take a joint of a skinned node of the scene out of it (a fuzz
  // finding: a skin the World had no Skin component for, so gltf_edits could not see it).
  const Status joint_out = save_gltf(kCases / "scaled_armature.gltf", waved, GltfEdits{{}, {}, {3}});
  ASSERT_FALSE(joint_out.ok());
  EXPECT_NE(joint_out.error().message.find("whose joint nodes[3] the edits take out of the scene"), std::string::npos)
      << joint_out.error().message;
  EXPECT_FALSE(std::filesystem::exists(waved));

  // A skin whose joint was deleted has no glTF form either (the file's skin names every joint).
  World armature = imported(kCases / "scaled_armature.gltf");
  destroy_hierarchy(armature, named(armature, "head"));
  const auto jointless = gltf_edits(armature);
  ASSERT_FALSE(jointless.ok());
  EXPECT_NE(jointless.error().message.find("a joint of its skin was deleted"), std::string::npos)
      << jointless.error().message;
  std::filesystem::remove(out);
  std::filesystem::remove(again);
}

TEST(AuthoredLighting, SavedGlbKeepsItsBinaryChunkAndTakesNewComponents) {
  World world = imported(kCases / "valid.glb");
  const Entity root = named(world, "root");
  ASSERT_TRUE(world.alive(root));
  world.add<IrradianceProbeGrid>(root, IrradianceProbeGrid::preset(Preset::Draft));
  const auto out = std::filesystem::temp_directory_path() / ("penumbra_saved_" + std::to_string(::getpid()) + ".glb");
  ASSERT_TRUE(save_gltf(kCases / "valid.glb", out, edits_of(world)).ok());
  World reopened = imported(out);
  ASSERT_TRUE(reopened.has<IrradianceProbeGrid>(named(reopened, "root")));
  EXPECT_EQ(reopened.get<IrradianceProbeGrid>(named(reopened, "root")).samples_per_node,
            IrradianceProbeGrid::preset(Preset::Draft).samples_per_node);
  std::size_t meshes = 0;
  reopened.each<Mesh>([&](Entity, Mesh&) { ++meshes; });
  EXPECT_EQ(meshes, 1u);
  // The wrong extension, and a node the file lacks, are refused; nothing is written.
  const auto wrong = std::filesystem::temp_directory_path() / ("penumbra_saved_" + std::to_string(::getpid()) + ".gltf");
  const Status s = save_gltf(kCases / "valid.glb", wrong, {});
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.error().message.find("ending in .glb"), std::string::npos) << s.error().message;
  EXPECT_FALSE(std::filesystem::exists(wrong));
  GltfNodeEdit far;
  far.node = 99;
  const Status t = save_gltf(kCases / "valid.glb", out, GltfEdits{{far}, {}, {}});
  ASSERT_FALSE(t.ok());
  EXPECT_NE(t.error().message.find("nodes[99] does not exist"), std::string::npos) << t.error().message;
  const Status gone = save_gltf(kCases / "valid.glb", out, GltfEdits{{}, {}, {99}});
  ASSERT_FALSE(gone.ok());
  EXPECT_NE(gone.error().message.find("nodes[99] to remove does not exist"), std::string::npos) << gone.error().message;
  GltfNewNode orphan;
  orphan.name = "orphan";
  orphan.added_parent = 0;  // itself: parents come first
  const Status early = save_gltf(kCases / "valid.glb", out, GltfEdits{{}, {orphan}, {}});
  ASSERT_FALSE(early.ok());
  EXPECT_NE(early.error().message.find("'orphan': its parent must be added before it"), std::string::npos)
      << early.error().message;
  std::filesystem::remove(out);
}

}  // namespace
}  // namespace penumbra
