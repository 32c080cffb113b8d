// The SDK's module list and the game-facing calls (see penumbra/runtime.h).
#include "penumbra/runtime.h"

#include <array>

#include "penumbra/core/log.h"
#include "penumbra/scene/animation.h"

namespace penumbra {

#define PENUMBRA_MODULE(id) const LightingModule& id##_module();
#include "modules.inc"
#undef PENUMBRA_MODULE

std::span<const LightingModule* const> lighting_modules() {
#define PENUMBRA_MODULE(id) &id##_module(),
  static const std::array modules = {
#include "modules.inc"
  };
#undef PENUMBRA_MODULE
  return modules;
}

const LightingModule* find_lighting_module(std::string_view name) {
  for (const LightingModule* m : lighting_modules())
    if (m->name == name) return m;
  return nullptr;
}

const LightingModule* lighting_module_for_chunk(std::uint32_t type) {
  for (const LightingModule* m : lighting_modules())
    if (m->owns(type)) return m;
  return nullptr;
}

void register_lighting(World& world) {
  register_scene_systems(world);
  for (const LightingModule* m : lighting_modules())
    if (m->register_runtime) m->register_runtime(world);
}

Status add_default_lighting(World& world, Preset preset, bool authored) {
  PENUMBRA_TRY(apply_authored_lighting(world));
  Status first;
  for (const LightingModule* m : lighting_modules())
    if (m->add_defaults)
      if (Status s = m->add_defaults(world, preset, authored); !s && first) first = s;
  world.update(0.0);
  return first;
}

Status attach_bake(World& world, const BakeFile& file) {
  if (file.find(kShardManifestChunk) != nullptr)
    return make_error(ErrorCode::InvalidInput, "the file is one part of a sharded bake, which holds work items, not "
                                               "lighting; merge the parts first ('penumbra merge part_*.pbake -o "
                                               "level.pbake') and load the merged file");
  const EntityKeys keys = EntityKeys::build(world);
  for (const BakeChunk& chunk : file.chunks) {
    const LightingModule* m = lighting_module_for_chunk(chunk.type);
    if (m == nullptr || m->attach == nullptr) {
      log(LogLevel::Warning, "attach_bake: chunk '" + fourcc_to_string(chunk.type) + "' (" + chunk.label +
                                 ") belongs to no linked lighting module; skipped");
      continue;
    }
    PENUMBRA_TRY(m->attach(world, chunk, keys));
  }
  return {};
}

}  // namespace penumbra
