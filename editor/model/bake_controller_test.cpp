// Background bakes: a real bake of a built-in scene finishes and attaches, matches a foreground
// bake bit for bit, can be cancelled, and leaves the live World usable while it runs.
#include "bake_controller.h"

#include <unistd.h>

#include <filesystem>

#include <gtest/gtest.h>

#include "editor_model.h"
#include "load_world.h"
#include "penumbra/ao_field/ao_field.h"
#include "penumbra/ecs/transform.h"
#include "penumbra/lighting/module.h"
#include "penumbra/probe_grid/probe_grid.h"
#include "penumbra/scene/components.h"
#include "penumbra/scene/entity_key.h"

namespace penumbra::editor {
namespace {

std::filesystem::path temp_path(const char* name) {
  return std::filesystem::temp_directory_path() / ("penumbra_editor_" + std::to_string(::getpid()) + "_" + name);
}

TEST(BakeController, BakesInTheBackgroundAndAttachesOnPoll) {
  EditorModel model;
  ASSERT_TRUE(model.open("builtin:courtyard", Preset::Draft).ok());
  model.bake_settings.preset = Preset::Draft;
  Document& doc = *model.document();
  const Entity grid = *doc.find("probe grid");
  ASSERT_TRUE(model.bake({"probe-grid"}).ok());
  // The live World keeps running while the bake works on its snapshot.
  const Entity crate = *doc.find("crate");
  int frames = 0;
  while (model.bakes().running()) {
    doc.world().patch<Transform>(crate).translation.x += 0.001f;
    doc.world().update(1.0 / 60.0);
    EXPECT_EQ(doc.world().get<IrradianceProbeGrid>(grid).data, nullptr);  // nothing swapped in yet
    ++frames;
  }
  EXPECT_GT(frames, 0);
  ASSERT_TRUE(model.poll());
  const BakeStatus status = model.bakes().status();
  ASSERT_EQ(status.state, BakeStatus::State::Done) << status.error;
  EXPECT_GT(status.seconds, 0.0);
  ASSERT_EQ(status.report.items.size(), 1u);
  EXPECT_EQ(status.report.items[0].baker, "probe-grid");
  EXPECT_EQ(status.bytes, status.report.items[0].bytes);
  // Per-stage progress: the ray scene and the probe stages, each complete.
  ASSERT_GE(status.stages.size(), 3u);
  EXPECT_EQ(status.stages[0].name, "ray scene");
  EXPECT_EQ(status.stages[1].name, "probe samples");
  for (const BakeStage& s : status.stages) EXPECT_EQ(s.fraction, 1.0) << s.name;
  // The results are attached to the live component and kept for saving.
  const auto& data = doc.world().get<IrradianceProbeGrid>(grid).data;
  ASSERT_NE(data, nullptr);
  EXPECT_EQ(data->key, entity_key(doc.world(), grid));
  EXPECT_GT(data->valid_fraction(), 0.5f);
  ASSERT_TRUE(doc.has_bake());
  EXPECT_EQ(doc.baked().chunks.size(), 1u);
  EXPECT_FALSE(model.poll());  // collected once
}

// An estimate runs in the background like a bake, attaches nothing, and holds while the scene and
// preset it estimated stay: the probe grid's bytes are those of the bake that follows, and each
// component's groups are named by its entity key.
TEST(BakeController, EstimatesInTheBackgroundWithoutAttaching) {
  EditorModel model;
  ASSERT_TRUE(model.open("builtin:courtyard", Preset::Draft).ok());
  Document& doc = *model.document();
  const Entity grid = *doc.find("probe grid");
  ASSERT_TRUE(model.estimate().ok());
  model.bakes().wait();
  ASSERT_TRUE(model.poll());
  const BakeStatus status = model.bakes().status();
  ASSERT_EQ(status.state, BakeStatus::State::Done) << status.error;
  EXPECT_TRUE(status.estimating);
  EXPECT_EQ(doc.world().get<IrradianceProbeGrid>(grid).data, nullptr);
  EXPECT_FALSE(doc.has_bake());
  const BakeEstimate* estimate = model.estimate_for(model.input_hash());
  ASSERT_NE(estimate, nullptr);
  std::optional<std::uint64_t> grid_bytes;
  for (const BakeEstimate::Item& item : estimate->items)
    if (item.baker == "probe-grid") grid_bytes = item.bytes;
  ASSERT_TRUE(grid_bytes);
  bool named = false;
  for (const BakeEstimate::Group& g : estimate->groups) named = named || g.name == entity_key(doc.world(), grid);
  EXPECT_TRUE(named);
  // Another preset, or an edit of the scene: the estimate no longer holds.
  model.bake_settings.preset = Preset::High;
  EXPECT_EQ(model.estimate_for(model.input_hash()), nullptr);
  model.bake_settings.preset = Preset::Draft;
  ASSERT_NE(model.estimate_for(model.input_hash()), nullptr);
  ASSERT_TRUE(model.bake({"probe-grid"}).ok());
  model.bakes().wait();
  ASSERT_TRUE(model.poll());
  EXPECT_EQ(model.bakes().status().bytes, *grid_bytes);
  doc.world().patch<Light>(*doc.find("sun")).intensity *= 2.0f;
  EXPECT_EQ(model.estimate_for(model.input_hash()), nullptr);

  // Presets in turn (draft, medium), the components set to each in the snapshot: each holds at its
  // own input hash and has more elements to bake than the one before (elements, not seconds: those
  // are measured); the live components keep their settings.
  const float spacing = doc.world().get<IrradianceProbeGrid>(grid).spacing;
  ASSERT_TRUE(model.estimate_presets(false, {Preset::Draft, Preset::Medium}).ok());
  for (int finished = 0; finished < 2;) {
    model.bakes().wait();
    if (model.poll()) ++finished;
    ASSERT_NE(model.bakes().status().state, BakeStatus::State::Failed) << model.bakes().status().error;
  }
  std::uint64_t previous = 0;
  for (Preset q : {Preset::Draft, Preset::Medium}) {
    const BakeEstimate* e = model.preset_estimate(q, model.input_hash(q));
    ASSERT_NE(e, nullptr) << to_string(q);
    std::uint64_t elements = 0;
    for (const BakeEstimate::Group& g : e->groups) elements += g.elements;
    EXPECT_GT(elements, previous) << to_string(q);
    previous = elements;
  }
  EXPECT_EQ(doc.world().get<IrradianceProbeGrid>(grid).spacing, spacing);

  // Baked exactly instead (draft alone, to keep the test short): a whole bake on the snapshot,
  // nothing attached; the probe grid's bytes are the estimate's (exact for its fixed layout).
  std::optional<std::uint64_t> estimated_draft;
  for (const BakeEstimate::Item& item : model.preset_estimate(Preset::Draft, model.input_hash(Preset::Draft))->items)
    if (item.baker == "probe-grid") estimated_draft = item.bytes;
  const std::size_t chunks = doc.baked().chunks.size();
  ASSERT_TRUE(model.estimate_presets(true, {Preset::Draft}).ok());
  model.bakes().wait();
  ASSERT_TRUE(model.poll());
  ASSERT_EQ(model.bakes().status().state, BakeStatus::State::Done) << model.bakes().status().error;
  EXPECT_EQ(doc.baked().chunks.size(), chunks);  // nothing kept
  ASSERT_TRUE(model.preset_exact(Preset::Draft));
  EXPECT_FALSE(model.preset_exact(Preset::Medium));
  const BakeEstimate* baked = model.preset_estimate(Preset::Draft, model.input_hash(Preset::Draft));
  ASSERT_NE(baked, nullptr);
  bool found = false;
  for (const BakeEstimate::Item& item : baked->items)
    if (item.baker == "probe-grid") {
      found = true;
      EXPECT_EQ(item.bytes, estimated_draft);
    }
  EXPECT_TRUE(found);
}

// On the Cornell box and on the courtyard, whose sky and dynamic lamp the snapshot must carry.
class BakeControllerScenes : public testing::TestWithParam<const char*> {};

TEST_P(BakeControllerScenes, MatchesAForegroundBakeBitForBit) {
  EditorModel model;
  ASSERT_TRUE(model.open(GetParam(), Preset::Draft).ok());
  model.bake_settings.preset = Preset::Draft;
  model.bake_settings.seed = 7;
  model.bake_threads = 2;
  ASSERT_TRUE(model.bake({}).ok());
  model.bakes().wait();
  ASSERT_TRUE(model.poll());
  ASSERT_EQ(model.bakes().status().state, BakeStatus::State::Done) << model.bakes().status().error;

  World world;
  ASSERT_TRUE(cli::load_world(world, GetParam(), Preset::Draft).ok());
  JobContext serial;
  BakeSettings settings;
  settings.preset = Preset::Draft;
  settings.seed = 7;
  auto direct = bake_world(world, {}, settings, serial);
  ASSERT_TRUE(direct.ok()) << direct.error().message;
  const BakeFile& mine = model.document()->baked();
  EXPECT_EQ(mine.input_hash, direct->file.input_hash);
  ASSERT_EQ(mine.chunks.size(), direct->file.chunks.size());
  for (std::size_t i = 0; i < mine.chunks.size(); ++i) {
    EXPECT_EQ(mine.chunks[i].type, direct->file.chunks[i].type);
    EXPECT_EQ(mine.chunks[i].label, direct->file.chunks[i].label);
    EXPECT_TRUE(mine.chunks[i].payload == direct->file.chunks[i].payload) << mine.chunks[i].label;
  }
}

INSTANTIATE_TEST_SUITE_P(BakeController, BakeControllerScenes, testing::Values("builtin:cornell", "builtin:courtyard"),
                         [](const testing::TestParamInfo<const char*>& p) {
                           return std::string(p.param).substr(8);  // after "builtin:"
                         });

TEST(BakeController, CancelStopsTheBakeAndAttachesNothing) {
  EditorModel model;
  ASSERT_TRUE(model.open("builtin:courtyard", Preset::High).ok());
  model.bake_settings.preset = Preset::High;
  const Entity grid = *model.document()->find("probe grid");
  ASSERT_TRUE(model.bake({"probe-grid"}).ok());
  // A second bake while one runs is refused.
  auto busy = model.bake({"probe-grid"});
  ASSERT_FALSE(busy.ok());
  EXPECT_NE(busy.error().message.find("already running"), std::string::npos);
  model.bakes().cancel();
  model.bakes().wait();
  ASSERT_TRUE(model.poll());
  EXPECT_EQ(model.bakes().status().state, BakeStatus::State::Cancelled) << model.bakes().status().error;
  EXPECT_EQ(model.document()->world().get<IrradianceProbeGrid>(grid).data, nullptr);
  EXPECT_FALSE(model.document()->has_bake());
}

TEST(BakeController, SelectionBakesOnlyTheSelectedComponent) {
  EditorModel model;
  ASSERT_TRUE(model.open("builtin:cornell", Preset::Draft).ok());
  model.bake_settings.preset = Preset::Draft;
  Document& doc = *model.document();
  // Nothing selected, or an entity without a lighting component: refused with the fix.
  auto none = model.bake_selection();
  ASSERT_FALSE(none.ok());
  EXPECT_NE(none.error().message.find("nothing is selected"), std::string::npos);
  auto light = doc.world().view<Light>().sorted_entities();
  ASSERT_FALSE(light.empty());
  doc.select(light[0]);
  auto wrong = model.bake_selection();
  ASSERT_FALSE(wrong.ok());
  EXPECT_NE(wrong.error().message.find("no lighting component"), std::string::npos);
  auto unknown = model.bake({"lightmaps"});
  ASSERT_FALSE(unknown.ok());
  EXPECT_NE(unknown.error().message.find("known bakers: "), std::string::npos);

  const Entity grid = *doc.find("probe grid");
  doc.select(grid);
  ASSERT_TRUE(model.bake_selection().ok());
  model.bakes().wait();
  ASSERT_TRUE(model.poll());
  ASSERT_EQ(model.bakes().status().state, BakeStatus::State::Done) << model.bakes().status().error;
  ASSERT_EQ(doc.baked().chunks.size(), 1u);
  EXPECT_EQ(doc.baked().chunks[0].label, "probe-grid:probe grid");
}

TEST(BakeController, SavedBakeLoadsIntoAFreshDocument) {
  EditorModel model;
  ASSERT_TRUE(model.open("builtin:cornell", Preset::Draft).ok());
  model.bake_settings.preset = Preset::Draft;
  const auto path = temp_path("cornell.pbake");
  auto nothing = model.document()->save_bake(path);
  ASSERT_FALSE(nothing.ok());
  EXPECT_NE(nothing.error().message.find("nothing is baked yet"), std::string::npos);
  ASSERT_TRUE(model.bake({"probe-grid"}).ok());
  model.bakes().wait();
  ASSERT_TRUE(model.poll());
  ASSERT_TRUE(model.document()->save_bake(path).ok());

  auto fresh = Document::open("builtin:cornell", Preset::Draft);
  ASSERT_TRUE(fresh.ok());
  ASSERT_TRUE((*fresh)->open_bake(path).ok());
  const Entity grid = *(*fresh)->find("probe grid");
  const auto& loaded = (*fresh)->world().get<IrradianceProbeGrid>(grid).data;
  const auto& baked = model.document()->world().get<IrradianceProbeGrid>(grid).data;
  ASSERT_NE(loaded, nullptr);
  ASSERT_NE(baked, nullptr);
  EXPECT_TRUE(loaded->coefficients == baked->coefficients);
  std::filesystem::remove(path);
  // A missing file is an error naming it; the document is unchanged.
  auto missing = (*fresh)->open_bake(path);
  ASSERT_FALSE(missing.ok());
  EXPECT_NE(missing.error().message.find(path.string()), std::string::npos) << missing.error().message;
}

// Baked vertex AO reaches the document's static meshes (the renderer's per-vertex AO attribute),
// after a bake and after opening the saved file in a fresh document.
TEST(BakeController, VertexAOIsAttachedAfterABakeAndAReload) {
  EditorModel model;
  ASSERT_TRUE(model.open("builtin:cornell", Preset::Draft).ok());
  model.bake_settings.preset = Preset::Draft;
  ASSERT_TRUE(model.bake({"vertex-ao"}).ok());
  model.bakes().wait();
  ASSERT_TRUE(model.poll());
  ASSERT_EQ(model.bakes().status().state, BakeStatus::State::Done) << model.bakes().status().error;
  World& world = model.document()->world();
  const std::vector<Entity> meshes = world.view<Static, Mesh>().sorted_entities();
  ASSERT_FALSE(meshes.empty());
  double sum = 0.0;
  std::size_t values = 0;
  for (Entity e : meshes) {
    ASSERT_TRUE(world.has<VertexAO>(e)) << model.document()->label(e);
    EXPECT_EQ(world.get<VertexAO>(e).ao.size(), world.get<Mesh>(e).data->positions.size());
    for (float a : world.get<VertexAO>(e).ao) sum += a, ++values;
  }
  EXPECT_LT(sum / double(values), 0.99) << "the box's corners are occluded";
  const auto path = temp_path("cornell_vxao.pbake");
  ASSERT_TRUE(model.document()->save_bake(path).ok());
  auto fresh = Document::open("builtin:cornell", Preset::Draft);
  ASSERT_TRUE(fresh.ok());
  ASSERT_TRUE((*fresh)->open_bake(path).ok());
  for (Entity e : (*fresh)->world().view<Static, Mesh>().sorted_entities())
    EXPECT_TRUE((*fresh)->world().has<VertexAO>(e)) << (*fresh)->label(e);
  std::filesystem::remove(path);
}

// Two casters whose keys share their last 24 bytes get the same cut chunk label; re-baking one
// keeps the other's chunk (the document matches chunks by entity key, not by label).
TEST(BakeController, ChunksWithTheSameCutLabelAreKeptApart) {
  EditorModel model;
  ASSERT_TRUE(model.open("builtin:courtyard", Preset::Draft).ok());
  model.bake_settings.preset = Preset::Draft;
  World& w = model.document()->world();
  std::vector<Entity> casters = w.view<AOFieldCaster>().sorted_entities();
  ASSERT_GE(casters.size(), 2u);
  w.add<EntityKey>(casters[0], EntityKey{"level-north/storage/shelves/wooden-crate"});
  w.add<EntityKey>(casters[1], EntityKey{"level-south/storage/shelves/wooden-crate"});
  for (Entity e : {casters[0], casters[1], casters[0]}) {
    model.document()->select(e);
    ASSERT_TRUE(model.bake_selection().ok());
    model.bakes().wait();
    ASSERT_TRUE(model.poll());
    ASSERT_EQ(model.bakes().status().state, BakeStatus::State::Done) << model.bakes().status().error;
  }
  const auto& chunks = model.document()->baked().chunks;
  ASSERT_EQ(chunks.size(), 2u);
  EXPECT_EQ(chunks[0].label, chunks[1].label) << "the labels are cut to the same tail";
  EXPECT_NE(leading_chunk_key(chunks[0]), leading_chunk_key(chunks[1]));
}

}  // namespace
}  // namespace penumbra::editor
