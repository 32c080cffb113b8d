// The editor's Dear ImGui panels: plain functions over the model and the UI state (the caller's
// loop stays in control). Each panel is one window at a fixed default place in a 1280x720 layout.
#pragma once

#include <deque>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "camera_control.h"
#include "editor_model.h"
#include "extension.h"
#include "gizmo.h"
#include "reference_map.h"
#include "viewport.h"
#include "penumbra/render/renderer.h"

namespace penumbra::editor {

// Frame times of the last few seconds, split by whether a bake was running.
struct FrameTimes {
  static constexpr std::size_t kWarmUp = 10;  // first frames: shader compilation (lavapipe JITs), uploads
  std::size_t frames = 0;
  std::vector<double> idle_ms, baking_ms;  // every frame after the warm-up
  std::vector<double> wait_ms, record_ms, present_ms;  // the viewport's parts of each frame (viewport.h)
  std::deque<float> recent_ms;             // the last 240 frames, for the plot
  void add(double ms, bool baking, const ViewportTimes& parts);
};
// Median and 95th percentile of `ms` (0 when empty).
struct FrameSummary {
  double median = 0.0, p95 = 0.0, max = 0.0;
  std::size_t frames = 0;
};
FrameSummary summarise(std::vector<double> ms);

// Error against cost of one technique's presets, from a bench CSV (bench/*.csv).
struct CostPlot {
  std::string path;                // the CSV read
  std::string x_label, y_label;    // column names
  std::vector<std::string> labels; // row labels (first columns)
  std::vector<float> x, y;
  std::vector<bool> marked;        // rows whose `mark_column` holds `mark_value`
  std::string error;               // why there is no plot
};
// Reads the columns named `x_column` and `y_column` of a bench CSV; rows with non-numbers skipped.
// Rows whose column `mark_column` equals `mark_value` are marked (the selected component's mode).
CostPlot read_cost_plot(const std::string& path, const std::string& x_column, const std::string& y_column,
                        const std::string& mark_column = {}, const std::string& mark_value = {});
// The open scene's cost at each preset whose estimate holds (EditorModel::preset_estimate): per
// module with known bytes, a point (seconds, chunk bytes) labelled "module preset (estimated)" or
// "(baked)", the bake setting's preset marked. `error` says what to do when there is none.
CostPlot scene_cost_plot(const EditorModel& model, const std::uint64_t (&preset_hashes)[3]);

// The bench behind the selected entity's lighting component (the first editor extension that
// applies to it; the first extension's, unmarked, for any other selection): extension.h.
CostPlotSource cost_plot_source(World& world, Entity selected);

struct UiState {
  CameraControl camera;
  RenderSettings render;
  bool show_ui = true;
  float render_scale = 1.0f;  // of the 3D view (Viewport::set_render_scale)
  // While a bake runs the viewport yields the cores to it: at most this many frames per second,
  // the 3D view at most this scale (0 frames per second: no limit).
  int bake_fps = 4;
  float bake_render_scale = 0.25f;
  FrameTimes frames;
  FrameStats renderer_stats;
  std::vector<ViewInfo> views;  // the renderer's debug views (Renderer::views)
  std::string message;  // the last error or notice, shown in the status bar
  std::string field_error;  // the last inspector edit's error (cleared by the next edit that succeeds)
  char scene_path[512] = "builtin:courtyard";
  char bake_path[512] = "scene.pbake";
  char edits_path[512] = "edits.txt";
  char gltf_path[512] = "scene.glb";  // Save scene as glTF: set to the opened file (saving over it)
  std::optional<Preset> add_preset = Preset::Medium;  // what an added component starts from
  char bench_path[512] = "";  // the plot's CSV: bench-results/<bench>.csv, where `penumbra bench` writes by default
  std::string plot_source;  // the bench and mode the plot shows (the selection's; see plot_panel)
  CostPlot plot;
  CameraView camera_now;  // this frame's camera (what the View panel's controls see)
  GizmoMode gizmo_mode = GizmoMode::Move;  // the selection's gizmo (View panel; the script's `gizmo`)
  // The lighting components' bake state (EditorModel::bake_states), refreshed four times a second:
  // it hashes the scene.
  std::vector<BakeState> bake_states;
  double bake_states_time = -1.0;
  std::uint64_t input_hash = 0;  // of a whole-scene bake now (EditorModel::input_hash), refreshed with them
  std::uint64_t preset_hashes[3] = {0, 0, 0};  // the same at each preset, for the plot of this scene
  bool plot_scene = false;  // the plot panel shows this scene's estimated presets, not a bench's CSV
  const Document* bake_states_document = nullptr;
  // A scene the menus asked to open. Opening replaces the Document, so the main loop does it
  // between frames (take_open_request), never while panels hold references into the old one.
  std::string open_request;
  // A create, duplicate or delete the panels asked for: done once every panel is drawn, since
  // they walk the hierarchy it changes.
  std::function<void(Document&)> entity_request;
  // The lit view against the offline reference (reference_map.h): the View panel asks for it, the
  // main loop renders the real-time image and starts the job (it holds the renderer), the overlay
  // shows the map until cleared.
  int reference_spp = 64;
  bool reference_requested = false;
  ReferenceMapJob reference_job;
  std::optional<ErrorMap> reference_map;
  // The window size the panels were last laid out for, and whether this frame lays them out again.
  glm::vec2 laid_out_for{0.0f};
  bool relayout = true;
};

// Every panel, the menu bar and the status bar.
void draw_panels(EditorModel& model, UiState& ui);

}  // namespace penumbra::editor
