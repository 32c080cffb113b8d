// Bake state per lighting component: never baked before a bake, up to date after it, out of date
// naming what changed (a light, a mesh, the component's settings, the preset), up to date again
// after an undo, loaded from a file, and a sibling component's edit leaves the others up to date.
#include "bake_state.h"

#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <thread>

#include <gtest/gtest.h>

#include "editor_model.h"
#include "fields.h"
#include "penumbra/ecs/transform.h"
#include "penumbra/scene/entity_key.h"
#include "script.h"

namespace penumbra::editor {
namespace {

const BakeState* state_of(const std::vector<BakeState>& states, std::string_view module, Entity e = Entity::null()) {
  for (const BakeState& s : states)
    if (s.module == module && (!e || s.entity == e)) return &s;
  return nullptr;
}

void bake(EditorModel& model, std::vector<std::string> bakers) {
  ASSERT_TRUE(model.bake(std::move(bakers)).ok());
  model.bakes().wait();
  ASSERT_TRUE(model.poll());
  ASSERT_EQ(model.bakes().status().state, BakeStatus::State::Done) << model.bakes().status().error;
}

Status set(Document& doc, std::string_view entity, std::string_view component, std::string_view field,
           std::string_view value) {
  auto e = doc.find(entity);
  if (!e) return e.error();
  const FieldDesc* f = find_field(component, field);
  if (f == nullptr) return make_error(ErrorCode::NotFound, "no field");
  auto parsed = parse_field_value(*f, value);
  if (!parsed) return parsed.error();
  PENUMBRA_TRY(doc.undo().set(doc.world(), *e, *f, *parsed));
  update_world_transforms(doc.world());
  return {};
}

void undo(Document& doc) {
  ASSERT_TRUE(doc.undo().undo(doc.world()));
  update_world_transforms(doc.world());
}

TEST(BakeState, FollowsTheEditsSinceTheBake) {
  EditorModel model;
  ASSERT_TRUE(model.open("builtin:cornell", Preset::Draft).ok());  // the next bake at draft too
  Document& doc = *model.document();
  const Entity grid = *doc.find("probe grid");

  std::vector<BakeState> states = model.bake_states();
  ASSERT_NE(state_of(states, "probe-grid", grid), nullptr);
  ASSERT_NE(state_of(states, "vertex-ao"), nullptr);  // module-wide: no authoring component
  EXPECT_FALSE(state_of(states, "vertex-ao")->entity);
  for (const BakeState& s : states) EXPECT_EQ(s.freshness, Freshness::NeverBaked) << s.module;

  bake(model, {"probe-grid"});
  states = model.bake_states();
  const BakeState* probe = state_of(states, "probe-grid", grid);
  ASSERT_NE(probe, nullptr);
  EXPECT_EQ(probe->freshness, Freshness::UpToDate) << probe->why;
  EXPECT_GT(probe->seconds, 0.0);
  EXPECT_GT(probe->bytes, 0u);
  EXPECT_EQ(state_of(states, "vertex-ao")->freshness, Freshness::NeverBaked);  // not in that bake
  bake(model, {"vertex-ao"});

  // A light's change: out of date, naming it; the undo brings the scene back, and the state.
  ASSERT_TRUE(set(doc, "light", "Light", "intensity", "3").ok());
  probe = state_of(states = model.bake_states(), "probe-grid", grid);
  EXPECT_EQ(probe->freshness, Freshness::OutOfDate);
  EXPECT_EQ(probe->why, "light '" + entity_key(doc.world(), *doc.find("light")) + "' changed");
  EXPECT_EQ(state_of(states, "vertex-ao")->freshness, Freshness::UpToDate);  // AO reads no light
  undo(doc);
  EXPECT_EQ(state_of(states = model.bake_states(), "probe-grid", grid)->freshness, Freshness::UpToDate);

  // A mesh moved.
  ASSERT_TRUE(set(doc, "tall_block", "Transform", "translation", "0.1 0 0").ok());
  probe = state_of(states = model.bake_states(), "probe-grid", grid);
  EXPECT_EQ(probe->freshness, Freshness::OutOfDate);
  EXPECT_EQ(probe->why, "mesh '" + entity_key(doc.world(), *doc.find("tall_block")) + "' changed");
  undo(doc);

  // The component's own settings, and the next bake's preset.
  ASSERT_TRUE(set(doc, "probe grid", "IrradianceProbeGrid", "samples_per_node", "7").ok());
  probe = state_of(states = model.bake_states(), "probe-grid", grid);
  EXPECT_EQ(probe->why, "its settings changed");
  undo(doc);
  model.bake_settings.preset = Preset::Medium;
  probe = state_of(states = model.bake_states(), "probe-grid", grid);
  EXPECT_EQ(probe->why, "the bake preset is now medium (baked at draft)");
  model.bake_settings.preset = Preset::Draft;
  EXPECT_EQ(state_of(states = model.bake_states(), "probe-grid", grid)->freshness, Freshness::UpToDate);

  // A file read back: its data is "loaded", named by the file.
  const auto path = std::filesystem::temp_directory_path() /
                    ("penumbra_bake_state_" + std::to_string(::getpid()) + ".pbake");
  ASSERT_TRUE(doc.save_bake(path).ok());
  ASSERT_TRUE(doc.open_bake(path).ok());
  probe = state_of(states = model.bake_states(), "probe-grid", grid);
  EXPECT_EQ(probe->freshness, Freshness::Loaded);
  EXPECT_EQ(probe->why, path.filename().string());
  EXPECT_EQ(state_of(states, "vertex-ao")->freshness, Freshness::Loaded);
  std::filesystem::remove(path);
}

TEST(BakeState, AnotherComponentsEditLeavesTheRestUpToDate) {
  EditorModel model;
  ASSERT_TRUE(model.open("builtin:courtyard", Preset::Draft).ok());  // the next bake at draft too
  Document& doc = *model.document();
  bake(model, {"ao-field"});
  std::vector<BakeState> states = model.bake_states();
  std::vector<Entity> casters;
  for (const BakeState& s : states)
    if (s.module == "ao-field") {
      casters.push_back(s.entity);
      EXPECT_EQ(s.freshness, Freshness::UpToDate) << doc.label(s.entity) << ": " << s.why;
    }
  ASSERT_GE(casters.size(), 2u);
  const FieldDesc* f = find_field("AOFieldCaster", "rays_per_sample");
  ASSERT_NE(f, nullptr);
  auto value = parse_field_value(*f, "17");
  ASSERT_TRUE(value.ok()) << value.error().message;
  ASSERT_TRUE(doc.undo().set(doc.world(), casters[0], *f, *value).ok());
  states = model.bake_states();
  EXPECT_EQ(state_of(states, "ao-field", casters[0])->why, "its settings changed");
  EXPECT_EQ(state_of(states, "ao-field", casters[1])->freshness, Freshness::UpToDate)
      << state_of(states, "ao-field", casters[1])->why;

  // A caster added after the bake has never been baked; baking the selection bakes it alone.
  const Entity wall = *doc.find("north_wall");
  const ComponentInfo& caster = *find_authored_component("AOFieldCaster");
  ASSERT_TRUE(doc.undo().add_component(doc.world(), wall, caster, Preset::Draft).ok());
  update_world_transforms(doc.world());
  EXPECT_EQ(state_of(states = model.bake_states(), "ao-field", wall)->freshness, Freshness::NeverBaked);
  doc.select(wall);
  ASSERT_TRUE(model.bake_selection().ok());
  model.bakes().wait();
  ASSERT_TRUE(model.poll());
  states = model.bake_states();
  const BakeState* baked = state_of(states, "ao-field", wall);
  EXPECT_EQ(baked->freshness, Freshness::UpToDate) << baked->why;
  EXPECT_EQ(state_of(states, "ao-field", casters[0])->freshness, Freshness::OutOfDate);
}

// The courtyard's walker animates and walks, and a pushed crate moves: no bake reads where they
// are (hash_scene), so everything stays up to date while they do; the crate's scale does matter.
TEST(BakeState, MovingCharactersAndCratesLeaveTheBakeUpToDate) {
  EditorModel model;
  ASSERT_TRUE(model.open("builtin:courtyard", Preset::Draft).ok());  // the next bake at draft too
  Document& doc = *model.document();
  bake(model, {});
  World& world = doc.world();
  const Entity crate = *doc.find("crate");
  for (int frame = 0; frame < 40; ++frame) {
    world.patch<Transform>(crate).translation.x += 0.01f;
    world.update(1.0 / 30.0);
  }
  for (const BakeState& s : model.bake_states())
    EXPECT_EQ(s.freshness, Freshness::UpToDate) << s.module << " " << (s.entity ? doc.label(s.entity) : "") << ": "
                                                << s.why;
  world.patch<Transform>(crate).scale = glm::vec3(1.5f);
  world.update(1.0 / 30.0);
  const std::vector<BakeState> states = model.bake_states();
  ASSERT_NE(state_of(states, "ao-field", crate), nullptr);
  EXPECT_EQ(state_of(states, "ao-field", crate)->why, "its transform changed");
}

// Auto-bake: nothing before the edits have settled for the delay, then a bake of what is stale
// (everything at first, then the grid and the transport after the light changed: vertex AO reads
// no light).
TEST(BakeState, AutoBakeBakesWhatIsStaleOnceTheEditsSettle) {
  EditorModel model;
  ASSERT_TRUE(model.open("builtin:cornell", Preset::Draft).ok());  // the next bake at draft too
  model.auto_bake = true;
  model.auto_bake_delay = 1.0;
  Document& doc = *model.document();
  const auto run_until_idle = [&](double now) {
    model.bakes().wait();
    model.poll();
    ASSERT_TRUE(model.auto_bake_tick(now).ok());
  };
  ASSERT_TRUE(model.auto_bake_tick(0.0).ok());
  EXPECT_FALSE(model.bakes().running());
  EXPECT_EQ(model.auto_bake_status(), "auto-bake: waiting for the edits to settle");
  ASSERT_TRUE(model.auto_bake_tick(0.5).ok());
  EXPECT_FALSE(model.bakes().running());
  ASSERT_TRUE(model.auto_bake_tick(1.1).ok());
  EXPECT_TRUE(model.bakes().running() || model.bakes().status().state == BakeStatus::State::Done);
  run_until_idle(1.2);
  for (const BakeState& s : model.bake_states()) EXPECT_EQ(s.freshness, Freshness::UpToDate) << s.module;
  EXPECT_EQ(model.auto_bake_status(), "auto-bake: everything is up to date");

  ASSERT_TRUE(set(doc, "light", "Light", "intensity", "3").ok());
  ASSERT_TRUE(model.auto_bake_tick(2.0).ok());  // the change is seen
  ASSERT_TRUE(model.auto_bake_tick(2.5).ok());
  EXPECT_FALSE(model.bakes().running());
  ASSERT_TRUE(model.auto_bake_tick(3.1).ok());
  run_until_idle(3.2);
  const BakeStatus status = model.bakes().status();
  ASSERT_EQ(status.state, BakeStatus::State::Done) << status.error;
  std::vector<std::string> baked;
  for (const auto& item : status.report.items) baked.push_back(item.baker);
  // Vertex AO reads no light; the transport bakes the fixed rect light's bounce.
  EXPECT_EQ(baked, (std::vector<std::string>{"probe-grid", "indirect-transport"}));
  for (const BakeState& s : model.bake_states()) EXPECT_EQ(s.freshness, Freshness::UpToDate) << s.module;

  model.auto_bake = false;
  ASSERT_TRUE(set(doc, "light", "Light", "intensity", "4").ok());
  ASSERT_TRUE(model.auto_bake_tick(10.0).ok());
  ASSERT_TRUE(model.auto_bake_tick(20.0).ok());
  EXPECT_FALSE(model.bakes().running());
  EXPECT_EQ(model.auto_bake_status(), "");
}

// A bake that fails (a crate scaled unevenly: its AO field refuses it) is not started again for
// the same changes; the next change starts one, which succeeds once the scale is uniform again.
TEST(BakeState, AutoBakeDoesNotRetryAFailedBakeUntilSomethingChanges) {
  EditorModel model;
  ASSERT_TRUE(model.open("builtin:courtyard", Preset::Draft).ok());  // the next bake at draft too
  Document& doc = *model.document();
  bake(model, {});
  model.auto_bake = true;
  model.auto_bake_delay = 0.0;
  ASSERT_TRUE(set(doc, "crate", "Transform", "scale", "1 2 1").ok());
  ASSERT_TRUE(model.auto_bake_tick(1.0).ok());
  model.bakes().wait();
  model.poll();
  ASSERT_EQ(model.bakes().status().state, BakeStatus::State::Failed);
  EXPECT_NE(model.bakes().status().error.find("non-uniform scale"), std::string::npos) << model.bakes().status().error;
  ASSERT_TRUE(model.auto_bake_tick(2.0).ok());
  ASSERT_TRUE(model.auto_bake_tick(3.0).ok());
  EXPECT_FALSE(model.bakes().running());
  EXPECT_NE(model.auto_bake_status().find("failed"), std::string::npos) << model.auto_bake_status();
  ASSERT_TRUE(set(doc, "crate", "Transform", "scale", "1.5 1.5 1.5").ok());
  ASSERT_TRUE(model.auto_bake_tick(4.0).ok());
  model.bakes().wait();
  model.poll();
  EXPECT_EQ(model.bakes().status().state, BakeStatus::State::Done) << model.bakes().status().error;
  ASSERT_TRUE(model.auto_bake_tick(5.0).ok());
  for (const BakeState& st : model.bake_states())
    EXPECT_EQ(st.freshness, Freshness::UpToDate) << st.module << ": " << st.why;
}

TEST(BakeState, ScriptsExpectAState) {
  EditorModel model;
  auto script = parse_script(
      "open builtin:cornell draft\n"
      "expect-bake all never-baked\n"
      "bake probe-grid draft\n"
      "wait\n"
      "expect-bake \"probe grid\" up-to-date\n"
      "set light Light.intensity 3\n"
      "frames 1\n"
      "expect-bake \"probe grid\" up-to-date\n",
      "state.txt");
  ASSERT_TRUE(script.ok()) << script.error().message;
  ScriptRunner runner(*script);
  Status last;
  // One step per frame, as the editor runs it; the bake takes a second or less.
  for (int step = 0; step < 60000 && !runner.finished(); ++step) {
    last = runner.step(model);
    if (!last) break;
    if (Document* doc = model.document()) doc->world().update(1.0 / 60.0);
    if (model.bakes().running()) std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  ASSERT_FALSE(last.ok());
  const std::string light = entity_key(model.document()->world(), *model.document()->find("light"));
  EXPECT_NE(last.error().message.find("state.txt:8: expect-bake: expected up-to-date, but probe-grid on 'probe grid' "
                                      "is out of date (light '" + light + "' changed)"),
            std::string::npos)
      << last.error().message;
  EXPECT_FALSE(parse_script("expect-bake all fresh\n", "bad.txt").ok());
}

}  // namespace
}  // namespace penumbra::editor
