// What the editor's UI and its scripts act on: the open document and the background bakes. The
// Bake panel's buttons and the script's `bake` action call the same functions here.
// Main thread only.
#pragma once

#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "bake_controller.h"
#include "document.h"

namespace penumbra::editor {

class EditorModel {
 public:
  // Opens a scene, replacing the document (a running bake is cancelled first), and sets the next
  // bake's preset to `preset`. On failure the previous document (and preset) stays.
  Status open(std::string_view source, Preset preset = Preset::Medium);
  Document* document() { return document_.get(); }
  BakeController& bakes() { return bakes_; }

  // Starts a background bake of the named bakers (all when empty) over the whole scene.
  Status bake(std::vector<std::string> bakers);
  // Starts a background bake of the selected entity's lighting components only.
  Status bake_selection();
  // Starts a background estimate (bake/estimate.h) of baking the whole scene with bake_settings:
  // time and bytes per module and per component, from samples of the bake, in a fraction of its
  // time. InvalidArgument while a bake runs.
  Status estimate();
  // Estimates with every lighting component (and the bake) at draft, medium and high, one after
  // another: what each preset would cost for this scene (the plot panel's "this scene" plot).
  // `exact`: bakes each instead (on the snapshot, keeping nothing): its time and bytes measured,
  // at the whole bakes' cost. `presets`: which, in that order.
  Status estimate_presets(bool exact = false,
                          std::vector<Preset> presets = {Preset::Draft, Preset::Medium, Preset::High});
  // The latest finished estimate(), while the scene and settings it estimated are unchanged (its
  // bake input hash equals `current_input_hash`); nullptr otherwise.
  const BakeEstimate* estimate_for(std::uint64_t current_input_hash) const {
    return held(current_, current_input_hash);
  }
  // Whether an estimate() finished since the scene was opened (held or not).
  bool estimated() const { return current_.estimate.has_value(); }
  // The same for estimate_presets()'s estimate at `preset` (`current_input_hash`: input_hash(preset)).
  const BakeEstimate* preset_estimate(Preset preset, std::uint64_t current_input_hash) const {
    return held(presets_[static_cast<int>(preset)], current_input_hash);
  }
  // Whether that one was measured by a whole bake (estimate_presets(true)), not extrapolated.
  bool preset_exact(Preset preset) const { return presets_[static_cast<int>(preset)].exact; }
  // The input hash a whole-scene bake with bake_settings (at `preset`) would have now. Cost:
  // hashes the scene.
  std::uint64_t input_hash() { return input_hash(bake_settings.preset); }
  std::uint64_t input_hash(Preset preset);

  // Once per frame: attaches a finished bake's results. True when one finished in this call.
  bool poll();
  // The bake state of each lighting component of the document (bake_state.h) against the next
  // bake's settings; empty without a document. Cost: hashes the scene (BakeTracker::states).
  std::vector<BakeState> bake_states();

  // Auto-bake (the Bake panel's checkbox, the script's `auto-bake on`): once per frame with the
  // time in seconds, after poll(). When no bake runs and the components that are never baked or
  // out of date (bake_states) have stayed the same for auto_bake_delay seconds, bakes them: their
  // modules over their entities, or over the whole scene when a module-wide state is among them.
  // A bake that fails is not started again until those states change. Returns the started bake's
  // error, if starting failed. Cost: bake_states at most four times a second.
  Status auto_bake_tick(double now);
  bool auto_bake = false;
  double auto_bake_delay = 1.0;
  // What auto-bake is doing, for the Bake panel: "" when off.
  const std::string& auto_bake_status() const { return auto_status_; }

  BakeSettings bake_settings;  // preset and seed of the next bake
  unsigned bake_threads = 0;   // 0: one per hardware thread

 private:
  std::unique_ptr<Document> document_;
  BakeController bakes_;
  struct HeldEstimate {
    std::optional<BakeEstimate> estimate;
    std::uint64_t input_hash = 0;  // of the scene when it started
    bool exact = false;            // from a whole bake's report
  };
  static const BakeEstimate* held(const HeldEstimate& e, std::uint64_t hash) {
    return e.estimate && e.input_hash == hash ? &*e.estimate : nullptr;
  }
  // Starts the estimate queued first: at its preset, with the components at it too when `presets`.
  Status start_estimate();
  HeldEstimate current_;     // estimate()
  HeldEstimate presets_[3];  // estimate_presets(), by Preset
  std::vector<Preset> estimate_queue_;  // front: the one running
  bool queue_presets_ = false;          // the queue is estimate_presets()'s
  bool queue_exact_ = false;            // ... with whole bakes
  std::uint64_t pending_estimate_hash_ = 0;
  // Auto-bake: the stale components' signature, since when it has been the same, when the states
  // were last read, and the signature of the last bake that failed.
  std::string auto_signature_, auto_failed_;
  double auto_since_ = 0.0, auto_checked_ = -1.0;
  bool auto_started_ = false;
  std::string auto_status_;
};

}  // namespace penumbra::editor
