// RayScene: the World's geometry in Embree 3 BVHs, for every baker's ray queries.
//
// Layout. Static entities (Static + Mesh + WorldTransform) are baked into world space as one
// triangle geometry. Movable entities (Mesh + WorldTransform, not Static, no Skin) are instances of
// one sub-scene per distinct MeshData; update() copies their WorldTransforms. Skinned entities
// (Mesh + Skin + SkinPose + WorldTransform) are their own triangle geometry, skinned on the CPU
// (skin_positions) and refitted by update().
//
// Validity. Debian's Embree aborts the process on an invalid ray, so every query entry validates
// its rays first: a ray with a non-finite or huge origin, a zero or non-finite direction, a
// negative tnear or tnear > tfar is never sent to Embree; it counts as "no hit" and is added to
// invalid_ray_count(). Geometry is validated at build: triangles with a non-finite vertex or zero
// area are dropped and counted (a warning is logged naming the entity).
//
// Thread safety: queries are const and may run concurrently from any number of threads; build()
// and update() must not run concurrently with queries.
#pragma once

#include <cstddef>
#include <cstdint>
#include <limits>
#include <memory>
#include <span>

#include <glm/vec2.hpp>
#include <glm/vec3.hpp>

#include "penumbra/core/result.h"
#include "penumbra/ecs/world.h"

namespace penumbra {

struct RaySceneOptions {
  // Threads Embree uses to build BVHs; 0: one per hardware thread.
  unsigned build_threads = 0;
  // Embree build quality of the static BVH (Medium is the best time/quality trade-off for bakes;
  // High spends about 2x the build time for a few percent faster traversal).
  enum class Quality : std::uint8_t { Low, Medium, High };
  Quality quality = Quality::Medium;
  // Include movable and skinned meshes (false: static geometry only, as most bakers want).
  bool include_dynamic = true;
};

// A ray segment origin + t * direction, t in [tnear, tfar]. direction need not be unit length
// (t is then in units of |direction|).
struct Ray {
  glm::vec3 origin{0.0f};
  float tnear = 0.0f;
  glm::vec3 direction{0.0f, 0.0f, 1.0f};
  float tfar = std::numeric_limits<float>::infinity();
};

// True when Embree may be given the ray: finite origin with |components| <= 1e18, finite non-zero
// direction, 0 <= tnear <= tfar (tfar may be +inf). O(1).
bool ray_is_valid(const Ray& ray);

// The Lambertian surface a ray hit, flattened from the entity's Material.
struct SurfaceMaterial {
  glm::vec3 albedo{1.0f};    // base_color.rgb x the texture's average linear colour
  glm::vec3 emissive{0.0f};  // emitted radiance, W/(m^2 sr)
  bool double_sided = false;
};

struct Hit {
  float t = 0.0f;               // ray parameter of the hit
  Entity entity;                // the entity whose mesh was hit
  std::uint32_t primitive = 0;  // triangle index in the entity's MeshData
  glm::vec2 barycentrics{0.0f}; // (u, v): hit = (1-u-v) p0 + u p1 + v p2 of that triangle
  glm::vec3 normal{0.0f};       // geometric normal in world space, unit, front side (CCW)
  bool back_face = false;       // the ray arrived from behind: dot(normal, direction) > 0
  SurfaceMaterial material;
};

class RayScene {
 public:
  // Builds the BVHs from the World's entities (see the layout above). Fails with InvalidInput when
  // a mesh violates the MeshData invariants beyond what dropping triangles repairs (indices out of
  // range), with Internal when Embree reports an error (its message included). Entities without
  // WorldTransform are skipped: run the transform system first. The World is only read (it is
  // taken by reference because World's views are non-const).
  // Cost: O(triangles log triangles) on Embree's threads.
  static Result<RayScene> build(World& world, const RaySceneOptions& options = {});

  RayScene(RayScene&&) noexcept;
  RayScene& operator=(RayScene&&) noexcept;
  ~RayScene();

  // Moves instances to their current WorldTransform and re-skins skinned meshes from their
  // SkinPose (refit), then recommits. Static geometry is untouched. Entities destroyed since
  // build() are hidden. Cost: O(skinned vertices + instances).
  Status update(World& world);

  // Closest hit along the ray; false when nothing is hit or the ray is invalid.
  bool intersect(const Ray& ray, Hit& hit) const;
  // Any hit in [tnear, tfar]; false when nothing is hit or the ray is invalid.
  bool occluded(const Ray& ray) const;

  // Packet queries (rtcOccluded16 / rtcIntersect16, 16 rays at a time) for throughput.
  // Preconditions: out.size() == rays.size(). occluded: out[i] = 1 when ray i is blocked.
  // intersect: hit_mask[i] = 1 and hits[i] filled when ray i hit something.
  void occluded(std::span<const Ray> rays, std::span<std::uint8_t> out) const;
  void intersect(std::span<const Ray> rays, std::span<Hit> hits, std::span<std::uint8_t> hit_mask) const;

  // A ray offset that keeps a ray leaving a surface at `position` from re-hitting that surface:
  // 2e-5 |position|_max + 1e-5 (metres), i.e. well above Embree's hit-point error at that magnitude.
  float ray_epsilon(glm::vec3 position) const;

  std::size_t triangle_count() const;        // after dropping invalid triangles
  std::size_t dropped_triangle_count() const;  // non-finite or zero-area triangles dropped at build
  std::uint64_t invalid_ray_count() const;   // rays rejected by the validator so far (thread-safe)
  std::uint64_t bvh_bytes() const;           // bytes Embree holds now (memory monitor)
  glm::vec3 bounds_min() const;
  glm::vec3 bounds_max() const;
  // What a ray that hits nothing sees toward `direction` (normalised): the World's environment at
  // build() (world_environment, scene/components.h; its map, if any, is shared, not copied). O(1).
  glm::vec3 sky(glm::vec3 direction) const;
  // The largest albedo channel of any surface it holds (0 when empty): what bounds how much light
  // survives each bounce. Cost: O(parts).
  float max_albedo() const;

 private:
  struct Impl;
  explicit RayScene(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

}  // namespace penumbra
