// The open document: the World of one scene (a built-in or a glTF file) set up with every module,
// the selection, the undo stack and the baked data attached to it (.pbake in and out).
// Not thread-safe: the main thread owns it; bakes work on a snapshot (bake_controller.h).
#pragma once

#include <filesystem>
#include <memory>
#include <string>
#include <string_view>

#include <glm/vec3.hpp>

#include "penumbra/bake/baker.h"
#include "penumbra/core/pbake.h"
#include "bake_state.h"
#include "penumbra/ecs/world.h"
#include "undo.h"

namespace penumbra::editor {

class Document {
 public:
  // Loads `source` ("builtin:NAME" or a .gltf/.glb path) into a new World with every module's
  // systems and bakers (the tool's load_world; built-in scenes get every module's default
  // components with `preset`). A scene without lights gets the tool's "default light" (an entity
  // of the document like any other: shown, edited and baked) and notice() says so. Errors name
  // the source and say how to fix it.
  static Result<std::unique_ptr<Document>> open(std::string_view source, Preset preset = Preset::Medium);
  // What open() did that the user should know of ("" when nothing).
  const std::string& notice() const { return notice_; }

  World& world() { return world_; }
  const std::string& source() const { return source_; }
  UndoStack& undo() { return undo_; }

  // Undo and redo of the latest edit (undo()); a step that puts an entity back selects it.
  bool undo_edit();
  bool redo_edit();

  // Edits that change which entities exist, one undo entry each. The new entity is selected.
  // create_entity: `kind` is "empty" (a Transform and the Name), or "point-light", "spot-light",
  // "directional-light" or "rect-light" (with a Light of that type, white, at the Light's default
  // intensity); under `parent` (null: the glTF file's root entity, so that it is saved with the
  // file, or a root in a built-in scene), at `translation` in its frame.
  // InvalidArgument names the kinds, an empty name or a stale parent.
  Result<Entity> create_entity(std::string_view kind, const std::string& name, Entity parent,
                               glm::vec3 translation = glm::vec3(0.0f));
  static constexpr std::string_view kEntityKinds[] = {"empty", "point-light", "spot-light", "directional-light",
                                                      "rect-light"};
  // A copy of `e` and everything below it, next to it, named copy_name (subtree.h: copy_subtree).
  // InvalidArgument for a stale handle.
  Result<Entity> duplicate(Entity e);
  // Deletes `e` and everything below it (the selection is cleared when it was among them).
  // InvalidArgument for a stale handle, or a joint of a skin whose mesh is not among them.
  Status delete_entity(Entity e);

  Entity selection() const { return selection_; }
  void select(Entity e) { selection_ = world_.alive(e) ? e : Entity::null(); }

  // "NAME" (the first entity with that Name in index order) or "#INDEX". NotFound names the
  // reference and lists a few names.
  Result<Entity> find(std::string_view ref);
  // The entity's Name, or "#INDEX" when it has none.
  std::string label(Entity e);

  // Attaches a bake's chunks to the components they belong to (attach_bake) and
  // keeps them: chunks replace kept ones of the same type and entity key, the others stay (a bake of
  // the selection updates only its chunks). Errors name the chunk; nothing is kept then.
  Status attach(BakeFile file);
  // Reads and attaches a .pbake file (replacing what was kept).
  Status open_bake(const std::filesystem::path& path);
  // Writes what is kept, atomically. InvalidArgument when nothing was baked or loaded yet.
  Status save_bake(const std::filesystem::path& path) const;
  const BakeFile& baked() const { return baked_; }
  bool has_bake() const { return !baked_.chunks.empty(); }
  // What each lighting component was baked from (bake_state.h): the bake controller records its
  // bakes, open_bake() the files it reads.
  BakeTracker& bake_tracker() { return bake_tracker_; }

  // Writes a script that re-creates this document: `open SOURCE` then one `set` per field edit that
  // is applied (undo position), so a built-in scene's edits can be saved and replayed. Atomic.
  // InvalidArgument when an applied edit created, duplicated or deleted entities.
  Status save_edits(const std::filesystem::path& path);
  // Writes the scene back as the glTF it was opened from, with the nodes' transforms, lights and
  // lighting components (PENUMBRA_lighting), everything else as read (import/gltf.h: save_gltf;
  // the path takes the source's extension). Atomic. InvalidArgument for a built-in scene.
  Status save_gltf(const std::filesystem::path& path);

 private:
  Document() = default;

  World world_;
  std::string source_;
  std::string notice_;
  Entity selection_;
  UndoStack undo_;
  BakeFile baked_;
  BakeTracker bake_tracker_;
};

}  // namespace penumbra::editor
