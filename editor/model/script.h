// Scripted mode (`penumbra-editor --script FILE`): a line-by-line list of editor actions that tests
// and demos replay through the same model functions as the UI.
//
//   open SOURCE [draft|medium|high]     builtin:NAME or a glTF path (preset of the default grid)
//   open-bake PATH | save-bake PATH     read and attach / write the document's .pbake
//   save-edits PATH                     the document's edits as a script
//   save-gltf PATH                      the scene as glTF with its lighting components (a glTF document)
//   select REF                          REF: an entity Name or #INDEX
//   set REF COMPONENT.FIELD VALUE...    e.g. set lamp Light.intensity 40; undoable
//   add REF COMPONENT | remove REF COMPONENT   a lighting component (e.g. IrradianceProbeGrid), undoable
//   create KIND NAME [PARENT]           KIND: empty, point-light, spot-light, directional-light,
//                                       rect-light; at the parent's origin (a root without one); undoable
//   duplicate REF | delete REF          REF and everything below it; undoable
//   preset REF MODULE PRESET            a lighting module's preset on REF's component, e.g. preset grid <module> draft
//   undo | redo
//   bake all|selection|BAKER[,BAKER...] [draft|medium|high]   starts a background bake
//   estimate [draft|medium|high|all [exact]]   starts a background estimate of baking everything
//                                       (bake/estimate.h); all: each preset in turn (the plot of this
//                                       scene); all exact: bakes each instead, keeping nothing
//   cancel                              cancels the running bake
//   wait                                until the running bake ends; fails the script if it failed
//   auto-bake on|off [DELAY]            bakes what is never baked or out of date once edits have
//                                       settled for DELAY seconds (EditorModel::auto_bake_tick)
//   expect-bake REF|all STATE           fails the script unless every lighting component of REF (all:
//                                       of the scene) is in STATE: never-baked, up-to-date,
//                                       out-of-date or loaded (bake_state.h), naming those that are not
//   frames N                            lets N frames run
//   screenshot PATH | orbit YAW PITCH [DISTANCE] | view DEBUGVIEW | ui on|off
//   click X Y                           a left click at window pixel (X, Y): the pointer moves there,
//                                       the button goes down and up over three frames; the script
//                                       goes on after the release (drives menus as a user would)
//   gizmo move|rotate|scale             the selection's gizmo (gizmo.h)
//   drag-gizmo x|y|z PIXELS             drags the gizmo's handle of that axis: an arrow from 60 % along
//                                       it, PIXELS along it; a ring from its point farthest from the
//                                       centre, PIXELS across the screen; over six frames, then
//                                       releases (one undoable edit of Transform.translation,
//                                       .rotation or .scale)
//   reset-stats                         starts the frame-time statistics afresh
//                                       viewport actions (window only; ui hides/shows the panels and overlays)
//   quit [CODE]
// Words are separated by blanks; "double quotes" group words; # starts a comment line.
#pragma once

#include <cstddef>
#include <filesystem>
#include <functional>
#include <string>
#include <string_view>
#include <vector>

#include "editor_model.h"

namespace penumbra::editor {

struct ScriptAction {
  std::string verb;                // e.g. "set"
  std::vector<std::string> args;   // the words after it
  int line = 0;                    // 1-based line in the script
};

struct Script {
  std::string name;  // file name for messages
  std::vector<ScriptAction> actions;
};

// Parses a script. Errors (InvalidArgument) name the script, the line and the fix, e.g.
//   "demo.txt:3: 'bake' takes all, selection or baker names, then an optional preset".
Result<Script> parse_script(std::string_view text, std::string_view name);
// Reads and parses a script file (NotFound / Io name the path).
Result<Script> load_script(const std::filesystem::path& path);

// Replays a script against an EditorModel. step() runs actions until one has to wait for frames
// (wait, frames, and the viewport actions, which take effect at the next frame), then returns;
// call it once per frame. Viewport actions go to `viewport` (Unsupported without one), which sets
// its bool to be called with the same action again next frame (an action that waits, e.g.
// reference-map); `quit` ends the script.
class ScriptRunner {
 public:
  using ViewportFn = std::function<Status(const ScriptAction&, bool& again)>;
  ScriptRunner(Script script, ViewportFn viewport = {});

  // Errors carry "NAME:LINE: " before the action's message; the script stops there.
  Status step(EditorModel& model);
  bool finished() const { return next_ >= script_.actions.size() || quit_; }
  bool quit_requested() const { return quit_; }
  int exit_code() const { return exit_code_; }
  // The action that step() is waiting on, or nullptr.
  const ScriptAction* current() const { return next_ < script_.actions.size() ? &script_.actions[next_] : nullptr; }

 private:
  Status run(EditorModel& model, const ScriptAction& action, bool& blocked);

  Script script_;
  ViewportFn viewport_;
  std::size_t next_ = 0;
  int frames_left_ = -1;  // for `frames N`: -1 when not counting
  bool quit_ = false;
  int exit_code_ = 0;
};

}  // namespace penumbra::editor
