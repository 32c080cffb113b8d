#include "load_world.h"
#include "penumbra/ao_field/ao_field_baker.h"
#include "penumbra/bake/vertex_ao.h"
#include "penumbra/pose_ao/pose_ao_system.h"
#include "penumbra/probe_grid/probe_system.h"
#include "penumbra/scene/animation.h"
#include "penumbra/scene/builtin.h"

namespace penumbra::cli {

void register_modules(World& world) {
  // Every module the tool links registers its systems and bakers.
  register_scene_systems(world);
  register_vertex_ao(world);
  register_probe_grid(world);
  register_ao_field(world);
  register_pose_ao(world);
}

Status load_world(World& world, std::string_view scene, Preset preset) {
  register_modules(world);
  auto loaded = load_scene(world, scene);
  if (!loaded) return loaded.error();
  world.update(0.0);
  // Every skinned mesh (built-in or glTF) gets pose-AO settings unless it brings its own.
  add_default_pose_ao(world, preset);
  // The built-in scenes (made by the scene layer, below the lighting modules) get a probe grid over
  // their static geometry; glTF scenes bring their own lighting components.
  if (scene.starts_with("builtin:")) {
    auto grid = add_default_probe_grid(world, preset);
    if (!grid) return grid.error();
    add_default_ao_field_casters(world, preset);  // the movable crates cast AO fields
    world.update(0.0);
  }
  return {};
}

}  // namespace penumbra::cli
