#include "load_world.h"

#include <glm/gtc/quaternion.hpp>

#include "penumbra/bakers.h"
#include "penumbra/ecs/transform.h"
#include "penumbra/runtime.h"
#include "penumbra/import/environment.h"
#include "penumbra/import/gltf.h"
#include "penumbra/scene/components.h"

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

std::string add_viewing_light(World& world, std::string_view scene) {
  if (world.view<const Light>().count() > 0) return {};
  Light sun;
  sun.type = Light::Type::Directional;
  sun.intensity = 3.0f;
  // Down and away from a camera in front (+Z) and above: the lit sides face the framing camera.
  const glm::vec3 direction = glm::normalize(glm::vec3(-0.3f, -1.0f, -0.6f));
  Transform t;
  t.rotation = glm::quatLookAt(direction, glm::vec3(0.0f, 0.0f, -1.0f));
  const Entity e = world.create();
  world.add<Name>(e, Name{"default light"});
  world.add<Transform>(e, t);
  world.add<Light>(e, sun);
  return std::string(scene) + " has no lights: added a directional 'default light' (3 W/m^2 from above) to view it";
}

Status set_sky_map(World& world, const std::string& path, float scale) {
  auto map = load_environment_map(path);
  if (!map) return map.error();
  const std::vector<Entity> skies = world.view<const Environment>().sorted_entities();
  const Entity e = skies.empty() ? world.create() : skies.front();
  if (skies.empty()) world.add<Name>(e, Name{"sky"});
  Environment sky;
  sky.map = path;
  sky.map_data = std::move(*map);
  sky.map_scale = scale;
  world.add<Environment>(e, std::move(sky));
  return {};
}

}  // namespace penumbra::cli
