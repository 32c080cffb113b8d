// What the editor's UI and its scripts act on: the open document and the background bakes. The
// Bake panel's buttons and the script's `bake` action call the same functions here.
// Main thread only.
#pragma once

#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "bake_controller.h"
#include "document.h"

namespace penumbra::editor {

class EditorModel {
 public:
  // Opens a scene, replacing the document (a running bake is cancelled first). On failure the
  // previous document stays open.
  Status open(std::string_view source, Preset preset = Preset::Medium);
  Document* document() { return document_.get(); }
  BakeController& bakes() { return bakes_; }

  // Starts a background bake of the named bakers (all when empty) over the whole scene.
  Status bake(std::vector<std::string> bakers);
  // Starts a background bake of the selected entity's lighting components only.
  Status bake_selection();
  // Once per frame: attaches a finished bake's results. True when one finished in this call.
  bool poll();
  // The bake state of each lighting component of the document (bake_state.h) against the next
  // bake's settings; empty without a document. Cost: hashes the scene (BakeTracker::states).
  std::vector<BakeState> bake_states();

  BakeSettings bake_settings;  // preset and seed of the next bake
  unsigned bake_threads = 0;   // 0: one per hardware thread

 private:
  std::unique_ptr<Document> document_;
  BakeController bakes_;
};

}  // namespace penumbra::editor
