// The World's environment (scene/components.h, Environment).
#include "penumbra/scene/components.h"

namespace penumbra {

glm::vec3 environment_radiance(World& world) {
  const std::vector<Entity> skies = world.view<const Environment>().sorted_entities();
  return skies.empty() ? glm::vec3(0.0f) : world.get<Environment>(skies.front()).radiance;
}

}  // namespace penumbra
