// The script parser (every malformed line is reported with its line) and the runner on the model.
#include "script.h"

#include <unistd.h>

#include <filesystem>

#include <gtest/gtest.h>

#include "penumbra/probe_grid/probe_grid.h"
#include "penumbra/scene/components.h"

namespace penumbra::editor {
namespace {

TEST(Script, ParsesEveryActionAndSkipsComments) {
  const char* text =
      "# a demo\n"
      "open builtin:courtyard draft\n"
      "\n"
      "select \"probe grid\"\n"
      "set lamp Light.intensity 40\n"
      "set crate Transform.translation 1, 0.4, 2\n"
      "preset \"probe grid\" probe-grid draft\n"
      "bake probe-grid,ao-field medium\n"
      "bake selection\n"
      "wait\n"
      "frames 3\n"
      "orbit 30 -15 12\n"
      "view indirect\n"
      "screenshot out.png\n"
      "save-bake out.pbake\n"
      "undo\n"
      "redo\n"
      "cancel\n"
      "ui off\n"
      "click 20 10\n"
      "add lamp IrradianceProbeGrid\n"
      "remove lamp IrradianceProbeGrid\n"
      "save-gltf out.glb\n"
      "reset-stats\n"
      "quit 0\n";
  auto script = parse_script(text, "demo.txt");
  ASSERT_TRUE(script.ok()) << script.error().message;
  ASSERT_EQ(script->actions.size(), 23u);
  EXPECT_EQ(script->actions[0].verb, "open");
  EXPECT_EQ(script->actions[0].line, 2);
  EXPECT_EQ(script->actions[1].args[0], "probe grid");
  EXPECT_EQ(script->actions[3].args.size(), 5u);
  EXPECT_EQ(script->actions.back().line, 25);
}

TEST(Script, BadLinesNameTheLineAndTheFix) {
  struct Case {
    const char* line;
    const char* expect;  // part of the message
  };
  const Case cases[] = {
      {"explode now", "unknown action 'explode'"},
      {"open", "'open' takes a scene"},
      {"open builtin:cornell ultra", "optional preset"},
      {"select", "'select' takes one entity"},
      {"select \"probe grid", "unterminated quote"},
      {"set lamp Light.intensity", "'set' takes an entity"},
      {"set lamp intensity 4", "is not COMPONENT.FIELD"},
      {"set lamp Light.wattage 4", "no editable field Light.wattage"},
      {"set lamp Light.intensity bright", "Light.intensity: 'bright' is not a number"},
      {"set lamp Light.intensity -3", "outside [0,"},
      {"set x ProbeLit.covered true", "written by the runtime"},
      {"preset grid lightmaps draft", "unknown technique 'lightmaps'"},
      {"preset grid probe-grid ultra", "unknown preset 'ultra'"},
      {"bake", "'bake' takes all, selection or lighting module names"},
      {"bake all ultra", "optional preset"},
      {"wait 3", "'wait' takes no arguments"},
      {"frames 0", "'frames' takes a count"},
      {"orbit left up", "'orbit' takes YAW and PITCH"},
      {"click 20", "'click' takes X and Y"},
      {"add lamp", "'add' takes an entity and a lighting component"},
      {"add lamp Lightmap", "no lighting component 'Lightmap'"},
      {"save-gltf", "'save-gltf' takes one PATH"},
      {"click -1 5", "'click' takes X and Y"},
      {"quit 300", "exit code"},
  };
  for (const Case& c : cases) {
    const std::string text = "open builtin:cornell\n# comment\n" + std::string(c.line) + "\nquit\n";
    auto script = parse_script(text, "t.txt");
    ASSERT_FALSE(script.ok()) << c.line;
    EXPECT_EQ(script.error().code, ErrorCode::InvalidArgument);
    const std::string& m = script.error().message;
    EXPECT_TRUE(m.starts_with("t.txt:3: ")) << m;
    EXPECT_NE(m.find(c.expect), std::string::npos) << c.line << " -> " << m;
  }
}

TEST(ScriptRunner, SavedEditsReplayToTheSameValues) {
  EditorModel model;
  ASSERT_TRUE(model.open("builtin:courtyard").ok());
  Document& doc = *model.document();
  World& w = doc.world();
  const Entity lamp = *doc.find("lamp"), crate = *doc.find("crate"), grid = *doc.find("probe grid");
  ASSERT_TRUE(doc.undo().set(w, lamp, *find_field("Light", "intensity"), FieldValue(33.5f)).ok());
  ASSERT_TRUE(doc.undo().set(w, crate, *find_field("Transform", "rotation"),
                             *parse_field_value(*find_field("Transform", "rotation"), "0 30 0")).ok());
  const ComponentPreset& p = *find_preset("probe-grid");
  ASSERT_TRUE(doc.undo().record(w, grid, p.component, "preset", [&] { p.apply(w, grid, Preset::High); }).ok());
  ASSERT_TRUE(doc.undo().set(w, lamp, *find_field("Light", "range"), FieldValue(3.0f)).ok());
  ASSERT_TRUE(doc.undo().undo(w));  // undone edits are not saved
  const auto path = std::filesystem::temp_directory_path() / ("penumbra_edits_" + std::to_string(::getpid()) + ".txt");
  ASSERT_TRUE(doc.save_edits(path).ok());

  auto script = load_script(path);
  ASSERT_TRUE(script.ok()) << script.error().message;
  EditorModel replay;
  ScriptRunner runner(std::move(*script));
  while (!runner.finished()) ASSERT_TRUE(runner.step(replay).ok());
  World& r = replay.document()->world();
  for (const FieldDesc& f : editable_fields())
    for (Entity e : {lamp, crate, grid})
      if (f.present(w, e) && !f.read_only) {
        ASSERT_TRUE(f.present(r, e));
        if (f.kind == FieldKind::Rotation)
          EXPECT_NEAR(std::abs(glm::dot(std::get<glm::quat>(f.get(w, e)), std::get<glm::quat>(f.get(r, e)))), 1.0f, 1e-5f);
        else
          EXPECT_TRUE(f.get(w, e) == f.get(r, e)) << f.component << "." << f.name;
      }
  EXPECT_EQ(r.get<Light>(lamp).range, 12.0f);
  std::filesystem::remove(path);
}

TEST(Script, LoadScriptNamesAMissingFile) {
  auto script = load_script("/nonexistent/dir/demo.txt");
  ASSERT_FALSE(script.ok());
  EXPECT_EQ(script.error().code, ErrorCode::NotFound);
  EXPECT_NE(script.error().message.find("/nonexistent/dir/demo.txt"), std::string::npos);
}

TEST(ScriptRunner, EditsUndoAndSelectionOnTheModel) {
  auto script = parse_script(
      "open builtin:courtyard\n"
      "select lamp\n"
      "set lamp Light.intensity 40\n"
      "set lamp Light.color 1 0 0\n"
      "undo\n"
      "frames 2\n"
      "quit 3\n"
      "set lamp Light.intensity 1\n",
      "run.txt");
  ASSERT_TRUE(script.ok()) << script.error().message;
  ScriptRunner runner(std::move(*script));
  EditorModel model;
  int steps = 0;
  while (!runner.finished()) {
    ASSERT_TRUE(runner.step(model).ok());
    ++steps;
  }
  EXPECT_EQ(steps, 3);  // `frames 2` holds the script for two frames
  EXPECT_TRUE(runner.quit_requested());
  EXPECT_EQ(runner.exit_code(), 3);
  Document& doc = *model.document();
  const Entity lamp = *doc.find("lamp");
  EXPECT_EQ(doc.selection(), lamp);
  EXPECT_EQ(doc.world().get<Light>(lamp).intensity, 40.0f);        // the line after quit did not run
  EXPECT_EQ(doc.world().get<Light>(lamp).color, glm::vec3(1.0f, 0.8f, 0.6f));  // undone
}

TEST(ScriptRunner, RunTimeErrorsNameTheLineAndStopTheScript) {
  EditorModel model;
  {
    ScriptRunner runner(*parse_script("select lamp\n", "a.txt"));
    auto s = runner.step(model);
    ASSERT_FALSE(s.ok());
    EXPECT_EQ(s.error().message, "a.txt:1: select: no scene is open; start with 'open SCENE'");
    EXPECT_TRUE(runner.finished());
    EXPECT_EQ(runner.exit_code(), 1);
  }
  {
    ScriptRunner runner(*parse_script("open builtin:cornell\nselect nobody\nquit\n", "b.txt"));
    auto s = runner.step(model);
    ASSERT_FALSE(s.ok());
    EXPECT_TRUE(s.error().message.starts_with("b.txt:2: select: no entity named 'nobody'")) << s.error().message;
  }
  {
    ScriptRunner runner(*parse_script("open builtin:nowhere\n", "c.txt"));
    auto s = runner.step(model);
    ASSERT_FALSE(s.ok());
    EXPECT_NE(s.error().message.find("c.txt:1: open: "), std::string::npos);
    EXPECT_NE(s.error().message.find("courtyard"), std::string::npos) << s.error().message;  // lists valid names
  }
  {
    // Viewport actions need a window; without one they fail naming the line.
    ScriptRunner runner(*parse_script("open builtin:cornell\nscreenshot x.png\n", "d.txt"));
    auto s = runner.step(model);
    ASSERT_FALSE(s.ok());
    EXPECT_TRUE(s.error().message.starts_with("d.txt:2: screenshot: needs the window")) << s.error().message;
  }
  {
    ScriptRunner runner(*parse_script("open builtin:cornell\nundo\n", "e.txt"));
    auto s = runner.step(model);
    ASSERT_FALSE(s.ok());
    EXPECT_EQ(s.error().message, "e.txt:2: undo: nothing to undo");
  }
}

TEST(ScriptRunner, ViewportActionsGoToTheHostOneFrameEach) {
  std::vector<std::string> seen;
  ScriptRunner runner(*parse_script("open builtin:cornell\norbit 10 20\nview albedo\nclick 5 6\nquit\n", "v.txt"),
                      [&](const ScriptAction& a, bool&) {
                        seen.push_back(a.verb);
                        return Status{};
                      });
  EditorModel model;
  ASSERT_TRUE(runner.step(model).ok());
  EXPECT_EQ(seen, std::vector<std::string>{"orbit"});
  ASSERT_TRUE(runner.step(model).ok());
  EXPECT_EQ(seen, (std::vector<std::string>{"orbit", "view"}));
  ASSERT_TRUE(runner.step(model).ok());
  EXPECT_EQ(seen, (std::vector<std::string>{"orbit", "view", "click"}));
  ASSERT_TRUE(runner.step(model).ok());
  EXPECT_TRUE(runner.quit_requested());
}

}  // namespace
}  // namespace penumbra::editor
