#include "cli.h"
#include "penumbra/bake/vertex_ao.h"
#include "penumbra/scene/animation.h"
#include "penumbra/scene/builtin.h"

namespace penumbra::cli {

Status load_world(World& world, std::string_view scene) {
  // Every module the tool links registers its systems and bakers.
  register_scene_systems(world);
  register_vertex_ao(world);

  auto loaded = load_scene(world, scene);
  if (!loaded) return loaded.error();
  world.update(0.0);
  return {};
}

}  // namespace penumbra::cli
