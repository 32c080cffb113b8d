// The open document (document.h).
#include "document.h"

#include <algorithm>
#include <charconv>
#include <cstdio>

#include "load_world.h"
#include "penumbra/core/file.h"
#include "penumbra/import/gltf.h"
#include "penumbra/ecs/transform.h"
#include "penumbra/runtime.h"
#include "penumbra/scene/components.h"

namespace penumbra::editor {

Result<std::unique_ptr<Document>> Document::open(std::string_view source, Preset preset) {
  std::unique_ptr<Document> doc(new Document);
  doc->source_ = std::string(source);
  if (Status s = cli::load_world(doc->world_, source, preset); !s)
    return Error{s.error().code, "open " + std::string(source) + ": " + s.error().message};
  doc->notice_ = cli::add_viewing_light(doc->world_, source);
  return doc;
}

Result<Entity> Document::find(std::string_view ref) {
  if (ref.starts_with("#")) {
    std::uint32_t index = 0;
    const auto [end, ec] = std::from_chars(ref.data() + 1, ref.data() + ref.size(), index);
    const Entity e = ec == std::errc() && end == ref.data() + ref.size() ? world_.find_entity(index) : Entity::null();
    if (!e) return make_error(ErrorCode::NotFound, "no entity " + std::string(ref) + "; use #INDEX of a live entity");
    return e;
  }
  std::string names;
  int listed = 0;
  for (Entity e : world_.view<Name>().sorted_entities()) {
    const std::string& n = world_.get<Name>(e).value;
    if (n == ref) return e;
    if (listed < 12 && names.find("'" + n + "'") == std::string::npos) {
      names += (names.empty() ? "'" : ", '") + n + "'";
      ++listed;
    }
  }
  return make_error(ErrorCode::NotFound,
                    "no entity named '" + std::string(ref) + "' in " + source_ + "; names include " + names);
}

bool Document::undo_edit() {
  const bool done = undo_.undo(world_);
  if (undo_.restored()) select(undo_.restored());
  return done;
}

bool Document::redo_edit() {
  const bool done = undo_.redo(world_);
  if (undo_.restored()) select(undo_.restored());
  return done;
}

Result<Entity> Document::create_entity(std::string_view kind, const std::string& name, Entity parent,
                                       glm::vec3 translation) {
  const std::string what = "create " + std::string(kind);
  if (std::find(std::begin(kEntityKinds), std::end(kEntityKinds), kind) == std::end(kEntityKinds)) {
    std::string kinds;
    for (std::string_view k : kEntityKinds) kinds += (kinds.empty() ? "" : ", ") + std::string(k);
    return make_error(ErrorCode::InvalidArgument, what + ": not a kind of entity; use one of " + kinds);
  }
  if (name.empty()) return make_error(ErrorCode::InvalidArgument, what + ": give the entity a name");
  if (parent && !world_.alive(parent))
    return make_error(ErrorCode::InvalidArgument, what + ": the parent no longer exists; select another");
  if (!parent) world_.each<GltfScene>([&](Entity root, GltfScene&) { parent = root; });  // saved with the file
  const Entity e = world_.create();
  world_.add<Name>(e, name);
  Transform t;
  t.translation = translation;
  world_.add<Transform>(e, t);
  if (kind != "empty") {
    Light light;
    light.type = kind == "point-light"   ? Light::Type::Point
                 : kind == "spot-light"  ? Light::Type::Spot
                 : kind == "rect-light"  ? Light::Type::Rect
                                         : Light::Type::Directional;
    world_.add<Light>(e, light);
  }
  if (parent) set_parent(world_, e, parent);
  undo_.created(e, what + " '" + name + "'");
  select(e);
  return e;
}

Result<Entity> Document::duplicate(Entity e) {
  if (!world_.alive(e)) return make_error(ErrorCode::InvalidArgument, "duplicate: the entity no longer exists; select another");
  const Entity copy = copy_subtree(world_, e, copy_name(world_, e)).front().second;
  undo_.created(copy, "duplicate '" + label(e) + "'");
  select(copy);
  return copy;
}

Status Document::delete_entity(Entity e) {
  if (!world_.alive(e)) return make_error(ErrorCode::InvalidArgument, "delete: the entity no longer exists; select another");
  // A skin needs every joint: a joint goes only with the meshes it deforms.
  const std::vector<Entity> doomed = subtree_of(world_, e);
  const auto in_subtree = [&](Entity x) { return std::find(doomed.begin(), doomed.end(), x) != doomed.end(); };
  Status refused;
  world_.each<Skin>([&](Entity mesh, Skin& skin) {
    if (!refused.ok() || in_subtree(mesh)) return;
    for (Entity joint : skin.joints)
      if (in_subtree(joint)) {
        std::string message = "delete: '";
        message += label(joint) + "' is a joint of the skin of '" + label(mesh) +
                   "', which needs every joint; delete the character (the entity above both) instead";
        refused = make_error(ErrorCode::InvalidArgument, message);
        return;
      }
  });
  PENUMBRA_TRY(refused);
  PENUMBRA_TRY(undo_.delete_subtree(world_, e));
  if (!world_.alive(selection_)) selection_ = Entity::null();
  return {};
}

std::string Document::label(Entity e) {
  if (const Name* n = world_.try_get<Name>(e); n && !n->value.empty()) return n->value;
  std::string out = "#";
  out += std::to_string(e.index);
  return out;
}

Status Document::attach(BakeFile file) {
  PENUMBRA_TRY(attach_bake(world_, file));
  // Keep the chunks: replace those of the same type and entity key (a scene-wide chunk, by type).
  const auto key_of = [](const BakeChunk& c) {
    const LightingModule* m = lighting_module_for_chunk(c.type);
    return m != nullptr && m->chunk_key ? m->chunk_key(c) : c.label;
  };
  for (BakeChunk& chunk : file.chunks) {
    bool replaced = false;
    const std::string key = key_of(chunk);
    for (BakeChunk& kept : baked_.chunks)
      if (kept.type == chunk.type && key_of(kept) == key) {
        kept = std::move(chunk);
        replaced = true;
        break;
      }
    if (!replaced) baked_.chunks.push_back(std::move(chunk));
  }
  baked_.input_hash = file.input_hash;
  baked_.sdk_version = file.sdk_version;
  return {};
}

Status Document::open_bake(const std::filesystem::path& path) {
  auto file = read_bake_file(path);
  if (!file) return file.error();
  if (Status s = attach_bake(world_, *file); !s) return Error{s.error().code, path.string() + ": " + s.error().message};
  bake_tracker_.loaded(world_, *file, path.filename().string());
  baked_ = std::move(*file);
  return {};
}

Status Document::save_bake(const std::filesystem::path& path) const {
  if (baked_.chunks.empty())
    return make_error(ErrorCode::InvalidArgument,
                      "save " + path.string() + ": nothing is baked yet; bake or open a .pbake first");
  BakeFile out = baked_;
  out.format_version = kPbakeFormatVersion;
  out.sdk_version.clear();  // written as this SDK's
  return write_bake_file(path, out);
}

Status Document::save_gltf(const std::filesystem::path& path) {
  if (source_.starts_with("builtin:"))
    return make_error(ErrorCode::InvalidArgument, "save as glTF: " + source_ +
                                                      " is a built-in scene, not a glTF file; save its edits as a "
                                                      "script, or open a glTF to save into");
  auto edits = gltf_edits(world_);
  if (!edits) return Error{edits.error().code, "save as glTF: " + edits.error().message};
  return penumbra::save_gltf(source_, path, *edits);
}

Status Document::save_edits(const std::filesystem::path& path) {
  std::string text = "# Penumbra editor edits: replay with penumbra-editor --script " + path.filename().string() + "\n";
  text += "open " + source_ + "\n";
  for (std::size_t i = 0; i < undo_.position(); ++i)
    if (undo_.entry(i).subtree != Edit::Subtree::None)
      return make_error(ErrorCode::InvalidArgument,
                        "save edits: '" + undo_.entry(i).label +
                            "' changed which entities exist, which an edit script does not replay (its #INDEX "
                            "references would shift); save the scene as glTF instead, or undo it first");
  for (std::size_t i = 0; i < undo_.position(); ++i) {
    const Edit& edit = undo_.entry(i);
    if (!world_.alive(edit.entity)) continue;
    if (edit.component)
      text += std::string(edit.added ? "add #" : "remove #") + std::to_string(edit.entity.index) + " " +
              std::string(edit.component->name) + "\n";
    for (const FieldChange& c : edit.changes)
      text += "set #" + std::to_string(edit.entity.index) + " " + c.field->component + "." + c.field->name + " " +
              format_field_value(*c.field, c.after) + "\n";
  }
  return write_file_atomically(path, text);
}

}  // namespace penumbra::editor
