// The ambient-occlusion field baker (P2, Kontkanen & Laine 2005, section 3.1): per cube-map texel
// the convex-hull distance r0, the caster's true solid angle and average occluded direction at
// log-spaced radii from the hull to the falloff distance (ray traced against the caster alone),
// the fit of Omega(r) = 1 / (a r^2 + b r + c) with a positive denominator, and the fit of C0; the
// baker registration (the AOFC chunk: ao_field.h).
//
// Steps, per texel direction w (field origin: the area-weighted centroid of the surface, which
// lies inside the convex hull):
//   1. r0(w) = min over support directions u with u.w > 0 of h(u) / (u.w), h the support function
//      of the vertices; u runs over 1024 Fibonacci directions plus the triangle normals (the first
//      65,536): exact for convex meshes, otherwise the boundary of a polytope slightly larger
//      than the hull, so r >= r0 is always outside the hull.
//   2. At radii r_k = r_lo (r_far / r_lo)^(k / (K - 1)) (denser near the hull; r_lo just outside
//      the hull along all of the texel's supersample directions, at least 1% of the bounding
//      radius), `rays_per_sample` rays give Omega_k = 4 pi hits / rays and Upsilon_k =
//      normalize(sum of hit directions). The rays start in turn from the points r_k d of the
//      supersample x supersample directions d spread over the texel (the cube map built at the
//      higher resolution and box-filtered down before the fit). Ray directions: one set of
//      Owen-scrambled Sobol' points per bake, turned by a uniformly random rotation per sample.
//   3. a, b, c by linear least squares on (a r^2 + b r + c) Omega_k = 1, then Levenberg-Marquardt
//      steps on sum (1 / D(r_k) - Omega_k)^2 that are accepted only when D stays >= 1 / (4 pi)
//      (Omega within the sphere) on [r0, r_far]. A linear fit that does not is replaced by the
//      best fit with non-negative a and c and b = 0 (counted in AOFieldData::clamped_fits).
//   4. C0: the point nearest (in least squares, weighted by Omega_k) to the lines through r_k w
//      along Upsilon_k, with a small pull towards the origin for parallel lines.
//
// The Grid representation (Malmer et al. 2007) instead ray traces Omega and Upsilon the same way
// at every vertex of the warped grid that a point within r_far interpolates from; vertices inside
// the caster's solid (every ray hits) are then extrapolated from outside, layer by layer, so that
// points just outside the surface do not interpolate towards "4 pi in no direction".
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "penumbra/ao_field/ao_field.h"
#include "penumbra/core/pbake.h"
#include "penumbra/core/jobs.h"
#include "penumbra/core/memory.h"
#include "penumbra/ecs/world.h"
#include "penumbra/scene/components.h"

namespace penumbra {

// Bakes the field of `mesh` (in its local frame) with `caster`'s settings. Validates the
// settings (validate_ao_field_caster with an identity matrix) and the mesh (InvalidInput when it
// has no triangle or no extent), reserves the texel (or grid) arrays in `budget`, builds a RayScene of the
// mesh alone, and reports one progress stage, "ao field". Texel (or grid vertex) i draws from
// Rng::stream(seed, i): bit-identical results at any thread count. Fails with Cancelled when the
// host cancels. Cost, radial fit: 6 x resolution^2 x radial_samples x rays_per_sample occlusion
// rays plus 6 x resolution^2 x (1 + supersample^2) x (1024 + triangles) support look-ups; grid:
// up to grid_size^3 x rays_per_sample rays. Thread-safe for distinct `jobs`.
Result<AOFieldData> bake_ao_field(const AOFieldCaster& caster, const MeshData& mesh, std::uint64_t seed,
                                  JobContext& jobs, MemoryBudget& budget, std::string_view context = "ao field");

// Registers the "ao-field" baker: one AOFC chunk per entity with AOFieldCaster, Mesh and
// WorldTransform (entity order, keyed by entity key), each baked in its mesh frame after validating
// the entity's world matrix (non-uniform scale is rejected naming the entity; entities sharing a
// MeshData and settings are baked once, the first in entity order); the data is also attached to
// the components.
void register_ao_field_baker(World& world);

}  // namespace penumbra
