// Bakes in the background: the bake driver (bake_world, penumbra/bake/baker.h), or its estimate
// (bake/estimate.h), runs on a worker thread over a snapshot of the document's World, so the main thread keeps updating and drawing
// the live World; when the bake finishes, poll() (main thread) attaches the results to the
// document and they show up in the next frame.
//
// The snapshot keeps entity indices (and each entity's key, scene/entity_key.h, so the chunks name the document's entities) and copies what the
// bakers read: transforms, meshes, materials, lights, the Static tag, names, the hierarchy, skins
// and animators (their entity handles remapped to the snapshot's) and the lighting components
// being baked (all of them, or the selection's). A module whose baker reads another
// component adds it to the list in bake_controller.cpp.
#pragma once

#include <chrono>
#include <cstdint>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "document.h"
#include "penumbra/bake/baker.h"
#include "penumbra/bake/estimate.h"
#include "penumbra/core/jobs.h"

namespace penumbra::editor {

struct BakeRequest {
  std::vector<std::string> bakers;  // baker names; empty: every registered baker
  // Lighting entities to bake; empty: all. (Geometry is always the whole scene.)
  std::vector<Entity> entities;
  BakeSettings settings;
  unsigned threads = 0;        // worker pool size; 0: one per hardware thread
  bool low_priority = true;    // nice the bake threads so the UI thread wins the CPU
  // Estimate the bake instead (bake/estimate.h): BakeStatus::estimate has it; nothing is attached.
  bool estimate = false;
  // Set every lighting component of the snapshot to this preset first (ComponentPreset::apply):
  // what the scene would cost at that preset. The live World is not changed.
  std::optional<Preset> component_preset;
  // False: bake and report only (BakeStatus::report, bytes): nothing is attached or recorded.
  bool keep = true;
};

// The authoring components a selection bake can bake (their type names joined by " or "), for messages.
std::string bakeable_components();
// The bakers that bake entity `e`'s components: the modules whose authoring component (the one
// with presets, LightingModule::components) the entity has.
std::vector<std::string> bakers_for(World& world, Entity e);

struct BakeStage {
  std::string name;
  double fraction = 0.0;
};

struct BakeStatus {
  enum class State { Idle, Running, Done, Failed, Cancelled };
  State state = State::Idle;
  std::vector<BakeStage> stages;  // in the order the bake opened them
  int stage_count = 0;            // declared total
  double seconds = 0.0;           // wall time so far / of the finished bake
  std::uint64_t bytes = 0;        // bytes of the chunks (when done)
  BakeReport report;              // per baker time, bytes and description (when done)
  bool estimating = false;        // the request was an estimate
  bool kept = true;               // a bake's results were (to be) attached: BakeRequest::keep
  std::optional<BakeEstimate> estimate;  // an estimate's result (when done)
  std::string error;              // Failed / Cancelled, or the attach error
};
const char* to_string(BakeStatus::State state);

class BakeController {
 public:
  BakeController() = default;
  ~BakeController();  // cancels and joins a running bake
  BakeController(const BakeController&) = delete;
  BakeController& operator=(const BakeController&) = delete;

  // Snapshots `doc`'s World (main thread, ~1 ms for the built-in scenes) and starts the bake.
  // InvalidArgument when a bake is already running (cancel it or wait), an entity is stale, or no
  // baker is selected; NotFound for an unknown baker name.
  Status start(Document& doc, const BakeRequest& request);
  // Asks the running bake to stop (it ends with State::Cancelled at its next check).
  void cancel();
  bool running() const;
  // Main thread, once per frame: when the worker has finished, joins it and attaches the results
  // to `doc` (the document the bake started from; other documents are left alone) and records
  // what it was baked from in the document's bake tracker. Returns true in the call that
  // completed a bake (Done, Failed or Cancelled).
  bool poll(Document& doc);
  // Blocks until the worker finishes (poll() still attaches). For scripts and tests.
  void wait();
  // A copy of the current state; thread-safe.
  BakeStatus status() const;

 private:
  void join();

  mutable std::mutex mutex_;
  BakeStatus status_;
  std::thread worker_;
  std::unique_ptr<CancelToken> cancel_;
  std::optional<Result<BakeResult>> outcome_;  // written by the worker, taken by poll()
  std::optional<Result<BakeEstimate>> estimate_outcome_;  // likewise, for an estimate
  BakeTracker::Records inputs_;  // what the running bake read (main thread), kept when it is done
  const Document* document_ = nullptr;
  bool finished_ = false;  // the worker has stored its outcome
  std::chrono::steady_clock::time_point started_;
};

}  // namespace penumbra::editor
