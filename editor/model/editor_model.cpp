// The editor's model (editor_model.h).
#include "editor_model.h"

#include <algorithm>

namespace penumbra::editor {

Status EditorModel::open(std::string_view source, Preset preset) {
  auto doc = Document::open(source, preset);
  if (!doc) return doc.error();
  bakes_.cancel();
  bakes_.wait();
  if (document_) bakes_.poll(*document_);  // collect (and drop) the cancelled bake's outcome
  document_ = std::move(*doc);
  current_ = {};
  for (HeldEstimate& e : presets_) e = {};
  estimate_queue_.clear();
  bake_settings.preset = preset;  // the next bake at the preset the scene's components start from
  return {};
}

Status EditorModel::bake(std::vector<std::string> bakers) {
  if (!document_) return make_error(ErrorCode::InvalidArgument, "bake: no scene is open; open one first");
  BakeRequest request;
  request.bakers = std::move(bakers);
  request.settings = bake_settings;
  request.threads = bake_threads;
  return bakes_.start(*document_, request);
}

Status EditorModel::bake_selection() {
  if (!document_) return make_error(ErrorCode::InvalidArgument, "bake: no scene is open; open one first");
  const Entity e = document_->selection();
  if (!document_->world().alive(e))
    return make_error(ErrorCode::InvalidArgument,
                      "bake selection: nothing is selected; select an entity with " + bakeable_components());
  BakeRequest request;
  request.bakers = bakers_for(document_->world(), e);
  request.entities = {e};
  request.settings = bake_settings;
  request.threads = bake_threads;
  return bakes_.start(*document_, request);
}

Status EditorModel::estimate() {
  estimate_queue_ = {bake_settings.preset};
  queue_presets_ = queue_exact_ = false;
  return start_estimate();
}

Status EditorModel::estimate_presets(bool exact, std::vector<Preset> presets) {
  if (presets.empty()) return make_error(ErrorCode::InvalidArgument, "estimate: no preset named");
  estimate_queue_ = std::move(presets);
  queue_presets_ = true;
  queue_exact_ = exact;
  return start_estimate();
}

Status EditorModel::start_estimate() {
  if (!document_) {
    estimate_queue_.clear();
    return make_error(ErrorCode::InvalidArgument, "estimate: no scene is open; open one first");
  }
  BakeRequest request;
  request.settings = bake_settings;
  request.settings.preset = estimate_queue_.front();
  request.threads = bake_threads;
  request.estimate = !queue_exact_;
  request.keep = false;
  if (queue_presets_) request.component_preset = request.settings.preset;
  pending_estimate_hash_ = input_hash(request.settings.preset);
  Status started = bakes_.start(*document_, request);
  if (!started) estimate_queue_.clear();
  return started;
}

std::uint64_t EditorModel::input_hash(Preset preset) {
  BakeSettings settings = bake_settings;
  settings.preset = preset;
  return document_ ? bake_input_hash(document_->world(), {}, settings) : 0;
}

bool EditorModel::poll() {
  if (!document_ || !bakes_.poll(*document_)) return false;
  const BakeStatus status = bakes_.status();
  if ((status.estimating || !status.kept) && !estimate_queue_.empty()) {
    const Preset preset = estimate_queue_.front();
    estimate_queue_.erase(estimate_queue_.begin());
    std::optional<BakeEstimate> measured = status.estimate;
    if (!status.estimating && status.state == BakeStatus::State::Done) {
      // A whole bake's report, in the estimate's terms.
      measured.emplace();
      measured->ray_scene_seconds = status.report.ray_scene_seconds;
      for (const BakeReport::Item& item : status.report.items)
        measured->items.push_back({item.baker, item.seconds, 0.0, item.bytes, item.seconds});
    }
    if (measured) {
      (queue_presets_ ? presets_[static_cast<int>(preset)] : current_) = {measured, pending_estimate_hash_,
                                                                          !status.estimating};
      if (!estimate_queue_.empty()) (void)start_estimate();  // the next preset; a failure ends the queue
    } else {
      estimate_queue_.clear();  // failed or cancelled: the rest is not started
    }
  }
  return true;
}

Status EditorModel::auto_bake_tick(double now) {
  if (!auto_bake || !document_) {
    auto_status_.clear();
    auto_signature_.clear();
    return {};
  }
  if (bakes_.running()) {
    auto_status_ = auto_started_ ? "auto-bake: baking what changed" : "auto-bake: waiting for the bake to end";
    return {};
  }
  if (auto_started_) {  // the auto-bake just ended (poll() attached it)
    auto_started_ = false;
    if (bakes_.status().state != BakeStatus::State::Done) auto_failed_ = auto_signature_;
    auto_checked_ = -1.0;  // read the states again now
  }
  if (auto_checked_ >= 0.0 && now - auto_checked_ < 0.25) return {};
  auto_checked_ = now;
  // The stale components, as a signature of what they are, why, and what their bake would read.
  std::vector<std::string> modules;
  std::vector<Entity> entities;
  bool whole_scene = false;
  std::string signature;
  for (const BakeState& s : bake_states()) {
    if (s.freshness != Freshness::NeverBaked && s.freshness != Freshness::OutOfDate) continue;
    signature += s.module + "#" + std::to_string(s.entity.index) + ":" + s.why + "\n";
    if (std::find(modules.begin(), modules.end(), s.module) == modules.end()) modules.push_back(s.module);
    if (s.entity) entities.push_back(s.entity);
    else whole_scene = true;
  }
  // What those modules would read: a change that leaves the reasons' words alone (a second scale
  // edit) is still a change.
  if (!signature.empty())
    signature += std::to_string(bake_input_hash(document_->world(), modules, bake_settings));
  if (signature != auto_signature_) {
    auto_signature_ = signature;
    auto_since_ = now;
  }
  if (signature.empty()) {
    auto_status_ = "auto-bake: everything is up to date";
    return {};
  }
  if (signature == auto_failed_) {
    auto_status_ = "auto-bake: the last bake of these changes failed; change something or bake by hand";
    return {};
  }
  if (now - auto_since_ < auto_bake_delay) {
    auto_status_ = "auto-bake: waiting for the edits to settle";
    return {};
  }
  BakeRequest request;
  request.bakers = std::move(modules);
  if (!whole_scene) request.entities = std::move(entities);
  request.settings = bake_settings;
  request.threads = bake_threads;
  if (Status s = bakes_.start(*document_, request); !s) {
    auto_failed_ = signature;
    return s;
  }
  auto_started_ = true;
  auto_status_ = "auto-bake: baking what changed";
  return {};
}

std::vector<BakeState> EditorModel::bake_states() {
  if (!document_) return {};
  return document_->bake_tracker().states(document_->world(), bake_settings);
}

}  // namespace penumbra::editor
