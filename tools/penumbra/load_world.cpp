#include "load_world.h"

#include "penumbra/bakers.h"
#include "penumbra/runtime.h"
#include "penumbra/import/gltf.h"

namespace penumbra::cli {

void register_modules(World& world) {
  register_lighting(world);
  register_bakers(world);
}

Status load_world(World& world, std::string_view scene, Preset preset) {
  register_modules(world);
  auto loaded = load_scene(world, scene);
  if (!loaded) return loaded.error();
  world.update(0.0);
  // The built-in scenes (made by the scene layer, below the lighting modules) get every module's
  // default components; glTF scenes only those a module adds to content it was not authored for
  // (LightingModule::add_defaults with authored = true).
  return add_default_lighting(world, preset, !scene.starts_with("builtin:"));
}

}  // namespace penumbra::cli
