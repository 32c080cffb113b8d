// The base colour textures of a World's meshes, for the surfaces the offline renderer's camera rays
// hit: the albedo at a primary hit is base_color x the texture (bilinear, repeat, sRGB decoded
// before filtering, as the real-time renderer's sampler), so texture detail survives irradiance
// filtering (the filter blurs irradiance, then the albedo multiplies it). Paths past the first hit
// keep the RayScene's mean albedo per surface, as the bakes do.
#pragma once

#include <cstdint>
#include <memory>
#include <unordered_map>

#include <glm/vec3.hpp>

#include "penumbra/bake/ray_scene.h"
#include "penumbra/ecs/world.h"
#include "penumbra/scene/components.h"

namespace penumbra {

class SurfaceTextures {
 public:
  // The textured meshes of the World (Mesh with uvs + Material with a base colour texture).
  // Holds shared references to the meshes and textures, not to the World. Cost: O(entities).
  static SurfaceTextures gather(World& world);

  // The albedo at `hit` (a RayScene hit of the World gathered): textured where the entity is,
  // else hit.material.albedo. Thread-safe. O(1).
  glm::vec3 albedo(const Hit& hit) const;

  std::size_t textured_entities() const { return entries_.size(); }

 private:
  struct Entry {
    std::shared_ptr<const MeshData> mesh;
    std::shared_ptr<const Texture> texture;
    glm::vec3 base{1.0f};
  };
  std::unordered_map<std::uint32_t, Entry> entries_;  // by entity index
};

}  // namespace penumbra
