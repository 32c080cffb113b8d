// A lighting module's descriptor: the one thing each technique exports (`<module>_module()`, declared
// in its system header). The SDK's list of modules is sdk/src/runtime/modules.inc; games use it
// through penumbra/runtime.h (register_lighting, attach_bake) and tools through penumbra/bakers.h.
//
// What a module provides, and where (every module folder has the same files):
//   <module>.h          component(s) and their field lists (<module>_fields.cpp), baked data, CPU
//                       evaluation, the chunk's reader and writer (<module>_chunk.cpp)
//   <module>_system.h   runtime system, default components, the descriptor
//   <module>_baker.h    the offline bake (Embree) and register_<module>_baker()
//   <module>_gpu.h      GPU layout shared with the shaders (modules with GPU data)
#pragma once

#include <cstdint>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "penumbra/core/pbake.h"
#include "penumbra/core/result.h"
#include "penumbra/ecs/world.h"
#include "penumbra/lighting/fields.h"
#include "penumbra/lighting/settings.h"
#include "penumbra/scene/entity_key.h"

namespace penumbra {

struct LightingModule {
  // The one name of the technique: its baker, `penumbra bake --only`, `penumbra bench`, the editor
  // panel and the prefix of its chunk labels ("probe-grid").
  std::string_view name;
  std::string_view description;  // one line for `penumbra bake --help`
  // The chunk types (fourcc) it writes and attaches.
  std::span<const std::uint32_t> chunk_types;
  // Its components' field lists (fields.h), authoring components first.
  std::span<const ComponentInfo* const> components;
  // Registers its systems with a World (once per World; register_lighting calls it).
  void (*register_runtime)(World& world) = nullptr;
  // The key of the entity one of its chunks belongs to; empty for a chunk of the whole scene. What
  // a host that keeps chunks (the editor) replaces a re-baked entity's chunk by.
  std::string (*chunk_key)(const BakeChunk& chunk) = nullptr;
  // Attaches one chunk of one of its types to the entity its key names (`keys`), replacing what the
  // component held (World::patch, so systems and the renderer notice). InvalidInput for a corrupt
  // chunk, NotFound naming the key when no entity of this World has it or it lacks the component.
  Status (*attach)(World& world, const BakeChunk& chunk, const EntityKeys& keys) = nullptr;
  // Reads one of its chunks with every check its reader makes, attaching nothing: what
  // `penumbra info` reports a file's invalid chunks by. InvalidInput / Unsupported as the reader.
  Status (*check)(const BakeChunk& chunk) = nullptr;
  // Lines about one of its chunks for `penumbra info` and bake reports.
  std::vector<std::string> (*describe)(const BakeChunk& chunk) = nullptr;
  // Gives a scene the module's default components with the preset's settings: `authored` is true
  // for an imported scene (a glTF file), which gets only what every such scene needs (pose-AO
  // settings on skinned meshes), false for the built-in scenes, made without lighting components,
  // which get a probe grid and AO-field casters too. Null: the module adds none.
  Status (*add_defaults)(World& world, Preset preset, bool authored) = nullptr;
  // Why its bake gives no chunk for this World: what it bakes and what the scene has instead, in
  // one sentence (the tools' message when a bake comes out empty). Null: the tools say only that
  // it found nothing. Cost: one pass over the entities.
  std::string (*explain_empty)(World& world) = nullptr;

  bool owns(std::uint32_t chunk_type) const;
};

// The entity that a chunk's key names, which must have component C (an attach function's first
// step). NotFound naming `context`, the key and `component` when no entity has the key or it lacks
// the component (re-bake the scene); InvalidInput when the key is ambiguous.
template <class C>
Result<Entity> keyed_owner(const World& world, const EntityKeys& keys, std::string_view key, std::string_view context,
                           std::string_view component) {
  auto e = keys.find(key, context);
  if (!e) return e.error();
  if (!world.has<C>(*e))
    return make_error(ErrorCode::NotFound, std::string(context) + ": entity '" + std::string(key) + "' has no " +
                                               std::string(component) + " in this World; re-bake the scene");
  return *e;
}

// chunk_key for chunks whose payload starts with the entity's key (ByteWriter::write_string); empty
// when the payload is too short to hold one.
std::string leading_chunk_key(const BakeChunk& chunk);

// LightingModule::check from a chunk reader (Result<Data> Read(const BakeChunk&)).
template <auto Read>
Status check_with(const BakeChunk& chunk) {
  auto data = Read(chunk);
  if (!data) return data.error();
  return {};
}

// "<module name>:<entity key>": a chunk's label, for people and for telling one entity's chunk from
// another's (the key itself is in the payload). A label longer than kPbakeMaxLabel bytes keeps the
// key's tail: "<module name>:~<last bytes of the key>".
std::string chunk_label(std::string_view module_name, std::string_view key);

}  // namespace penumbra
