// The runtime half of indirect transport: direct light from the dynamic lights at the leaf texels,
// the update that turns it into indirect light (IndirectLightmap), the system that runs it only
// when a dynamic light changed, default components and the module descriptor.
#pragma once

#include <cstdint>
#include <memory>
#include <span>
#include <vector>

#include <glm/vec3.hpp>

#include "penumbra/ecs/world.h"
#include "penumbra/indirect_transport/indirect_transport.h"
#include "penumbra/lighting/module.h"
#include "penumbra/scene/components.h"

namespace penumbra {

// A dynamic light in world space (Light + WorldTransform, as the bakers see lights).
struct RuntimeLight {
  Light light;
  glm::vec3 position{0.0f};
  glm::vec3 direction{0.0f, 0.0f, -1.0f};  // unit, where the light goes (local -Z)
  glm::vec3 half_x{0.5f, 0.0f, 0.0f}, half_y{0.0f, 0.5f, 0.0f};  // rect half-size vectors
};

// Which DynamicLights dynamic_lights() returns: those that move (DynamicLight::moves) or the fixed.
enum class LightMotion { Moving, Fixed };

// The enabled DynamicLight point, spot and rect lights with a WorldTransform whose `moves` matches
// `motion`, in entity order. InvalidInput naming the light ("light 'lantern' (entity 7)") when its
// position, direction, size or intensity is not finite, or a rect has zero area: fix its Transform
// or Light. O(lights).
Result<std::vector<RuntimeLight>> dynamic_lights(World& world, LightMotion motion = LightMotion::Moving);

// The static geometry that shadows the dynamic lights at runtime: every Static mesh's triangles in
// world space in a bounding volume hierarchy (median splits, 4 triangles per leaf). Built in
// O(n log n); queries are const and thread-safe.
class TransportOccluders {
 public:
  static TransportOccluders build(World& world);
  // True when a triangle crosses the open segment from `from` to `to`. O(log n) on average.
  bool occluded(glm::vec3 from, glm::vec3 to) const;
  std::size_t triangle_count() const { return triangles_.size(); }

 private:
  struct Triangle {
    glm::vec3 a, e1, e2;
  };
  struct Node {
    glm::vec3 lo, hi;
    std::uint32_t first = 0, count = 0;  // leaf: triangles [first, first + count); inner: count 0, left child first
  };
  void build_node(std::uint32_t node, std::vector<glm::vec3>& centres, std::uint32_t first, std::uint32_t count);
  std::vector<Triangle> triangles_;
  std::vector<Node> nodes_;
};

// The mean direct irradiance (W/m^2 per channel) of every leaf texel of `data` from `lights`:
// point and spot lights by the leaf's exact solid angle seen from the light (I Omega / A, finite
// for a light touching the wall), the spot cone and range window at the leaf's centre; rect lights
// as 4 x 4 point sources over their area; one shadow ray per leaf and light, to the light's centre,
// when `occluders` is given. Leaves outside their chart get 0. Runs on `scheduler` when given
// (null: the calling thread). Cost: O(leaves x lights x log n).
void direct_irradiance(const TransportData& data, std::span<const RuntimeLight> lights,
                       const TransportOccluders* occluders, std::span<glm::vec3> out,
                       TaskScheduler* scheduler = nullptr);

// One update: when the first IndirectTransport entity with data (in entity order) has no
// IndirectLightmap yet, or its data, or any enabled moving DynamicLight (its Light, WorldTransform
// or DynamicLight) changed since the previous update, recomputes its IndirectLightmap (written
// with World::patch) on two threads of its own: the bake's fixed part (TransportData::
// fixed_direct, fixed_indirect, fixed_probes) plus the moving lights' through the operator.
// Moving lights of a bake that kept no operator (TransportData::moving_lights false) are left
// out, with a warning logged once per bake: re-bake. Fixed lights are not followed: moving one
// leaves the lightmap as baked.
// Returns true when it recomputed, false when nothing changed or nothing is baked; InvalidInput
// from dynamic_lights (the lightmap is then left as it was). Cost: nothing but a hash of the
// moving lights when none changed.
Result<bool> update_indirect_transport(World& world);

// Registers system "indirect-transport" in Phase::Lighting (reads Light, WorldTransform,
// DynamicLight, IndirectTransport; writes IndirectLightmap), calling update_indirect_transport and
// logging a rejected light once per change.
void register_indirect_transport_system(World& world);

// Gives a built-in scene its transport when it has a receiver and a local light: every Static
// mesh made of at most six face directions (floors, walls, boxes; curved meshes are left out)
// becomes an IndirectReceiver, every point, spot and rect light (moving or fixed: the lightmap
// holds their bounce per texel, where the probe grid's cells are too coarse) a DynamicLight (a
// rect light that no clip animates is fixed, `moves` false: a window or a panel; point and spot
// lights move: lanterns, torches), and the scene's root (the first receiver's topmost ancestor)
// gets IndirectTransport::preset(preset). Returns the number of receivers (0: nothing added).
// O(triangles).
std::size_t add_default_indirect_transport(World& world, Preset preset);

const LightingModule& indirect_transport_module();

}  // namespace penumbra
