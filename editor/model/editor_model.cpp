// The editor's model (editor_model.h).
#include "editor_model.h"

namespace penumbra::editor {

Status EditorModel::open(std::string_view source, Preset preset) {
  auto doc = Document::open(source, preset);
  if (!doc) return doc.error();
  bakes_.cancel();
  bakes_.wait();
  if (document_) bakes_.poll(*document_);  // collect (and drop) the cancelled bake's outcome
  document_ = std::move(*doc);
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

bool EditorModel::poll() { return document_ && bakes_.poll(*document_); }

std::vector<BakeState> EditorModel::bake_states() {
  if (!document_) return {};
  return document_->bake_tracker().states(document_->world(), bake_settings);
}

}  // namespace penumbra::editor
