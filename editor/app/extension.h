// A lighting module's part of the editor: what the inspector says about its components, its
// controls in the View panel, its overlays in the viewport, its hierarchy tag and the bench behind
// its error-vs-cost plot. Each module registers one from its own folder
// (sdk/src/<module>/<module>_editor.cpp, compiled into the editor through the module list) with
// one line, PENUMBRA_EDITOR_EXTENSION({...}); the panels and the viewport loop over them and name
// no technique. Main thread only.
#pragma once

#include <span>
#include <string>

#include <glm/vec2.hpp>

#include "penumbra/ecs/world.h"
#include "penumbra/render/renderer.h"

struct ImDrawList;

namespace penumbra::editor {

// The bench behind a component's error-vs-cost plot: its name (and default CSV
// bench-results/<bench>.csv), the error column, and the CSV column and value of the component's
// current mode, to mark its rows.
struct CostPlotSource {
  std::string bench, y_column, mark_column, mark_value;
};

// What a View-panel control and an overlay see this frame.
struct ViewContext {
  World& world;
  Entity selection;
  const CameraView& camera;  // this frame's
  glm::vec2 size;            // the viewport, pixels (zero for the View panel's controls)
  std::string& message;      // the status bar (errors and notices)
};

struct EditorExtension {
  std::string module;  // LightingModule::name
  std::string tag;     // shown in the hierarchy after entities it applies to, in brackets
  bool (*applies)(World& world, Entity e);  // the entity has the module's authoring component (required)
  // Inspector lines under the entity's fields: its baked data, its runtime outputs (called for every
  // selected entity; it shows nothing when the entity has none of the module's components).
  void (*inspector)(World& world, Entity e) = nullptr;
  void (*view_options)(ViewContext& view) = nullptr;        // View panel controls
  void (*draw_overlay)(ViewContext& view, ImDrawList* draw_list) = nullptr;
  CostPlotSource (*cost_plot)(World& world, Entity e) = nullptr;  // for an entity it applies to
};

// Every registered extension, in the order of the module list.
std::span<const EditorExtension> editor_extensions();
// Used by PENUMBRA_EDITOR_EXTENSION; returns true.
bool register_editor_extension(EditorExtension extension);

#define PENUMBRA_EDITOR_EXTENSION_CAT2(a, b) a##b
#define PENUMBRA_EDITOR_EXTENSION_CAT(a, b) PENUMBRA_EDITOR_EXTENSION_CAT2(a, b)
#define PENUMBRA_EDITOR_EXTENSION(...)                                                             \
  static const bool PENUMBRA_EDITOR_EXTENSION_CAT(penumbra_editor_extension_, __LINE__) =          \
      ::penumbra::editor::register_editor_extension(::penumbra::editor::EditorExtension __VA_ARGS__)

}  // namespace penumbra::editor
