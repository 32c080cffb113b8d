// Ambient occlusion fields (P2): contact shadows of ambient light cast by a rigid, moving object,
// after Kontkanen & Laine 2005, "Ambient Occlusion Fields" (I3D; the thesis, section 4.1).
//
// Around a caster's centre, for each cube-map direction w, the field models the solid angle
// Omega(r) the caster subtends from the point r w and the average direction Upsilon(r) towards it:
//   Omega(w, r) = 1 / (a r^2 + b r + c),   Upsilon(w, r) = normalize(C0(w) - r w),
// valid outside the convex hull (r >= r0(w), the hull's distance). A receiver at x with normal n
// sees the caster as a spherical cap of solid angle Omega around Upsilon, whose occlusion of the
// cosine-weighted hemisphere has a closed form (cap_occlusion). Inside the hull the value blends
// towards a constant; beyond the falloff distance it is zero. Several casters combine by
// 1 - A = prod (1 - A_i).
//
// This header holds the authoring component (AOFieldCaster), the receiver component
// (AOFieldReceiver), the baked data (AOFieldData), the closed form and the CPU evaluation. The
// bake is in ao_field_baker.h. Units: the caster's local (mesh) units; a field follows its
// entity's rotation, translation and uniform scale (AO is scale-invariant).
#pragma once

#include <cstdint>
#include <memory>
#include <span>
#include <string_view>
#include <vector>

#include <glm/mat4x4.hpp>
#include <glm/vec3.hpp>

#include "penumbra/bake/baker.h"
#include "penumbra/core/result.h"

namespace penumbra {

struct AOFieldData;

// Authoring component on a rigid entity with a Mesh: casts ambient-occlusion contact shadows.
struct AOFieldCaster {
  std::uint32_t resolution = 16;       // cube-map texels per face edge (1..256)
  std::uint32_t radial_samples = 32;   // radii per texel between the hull and the falloff (3..1024)
  std::uint32_t rays_per_sample = 256; // rays per radius that measure Omega and Upsilon (>= 16)
  // Falloff distance r_far from the centre, in the mesh's local units; 0 derives 6 x the bounding
  // radius (the distance from the bounds' centre to the farthest vertex). Must exceed the
  // bounding radius when set.
  float falloff_distance = 0.0f;
  // The occlusion fades linearly to 0 between fade_start x r_far and r_far (0 < fade_start < 1).
  float fade_start = 0.8f;
  // Inside the hull the occlusion blends from its hull value towards inside_occlusion at the
  // centre, as A0 + (A_hull - A0) (r / r0)^inside_exponent (inside_occlusion in [0, 1], the
  // exponent > 0).
  float inside_occlusion = 1.0f;
  float inside_exponent = 2.0f;

  // The baked data (set by the baker or attach_ao_fields()); null until baked.
  std::shared_ptr<const AOFieldData> data;

  // Quality presets: draft 8x8 per face, 16 radii, 64 rays; medium 16x16, 32 radii, 256 rays;
  // high 32x32, 48 radii, 512 rays.
  static AOFieldCaster preset(Preset preset);
};

// Receiver component: an entity whose origin receives the occlusion of nearby casters, written by
// the ao-field system (ao_field_system.h). Per-pixel shadows on static surfaces need the
// renderer's pass, which this module does not provide yet.
struct AOFieldReceiver {
  glm::vec3 normal{0.0f, 1.0f, 0.0f};  // local-space normal of the receiving point
  float occlusion = 0.0f;              // combined occlusion in [0, 1] (0: open)
  std::uint64_t updated_tick = 0;
};

// Checks a caster's settings and its entity's world matrix. Errors (InvalidArgument) name
// `context` (e.g. "ao field 'crate'"), the field and the fix: resolution, radial samples or rays
// out of range, a non-finite or negative falloff, fade_start outside (0, 1), inside settings out
// of range, a singular or non-finite matrix, and a non-uniform scale (the field would be
// distorted: bake the scale into the mesh instead). Cost: O(1). Thread-safe.
Status validate_ao_field_caster(const AOFieldCaster& caster, const glm::mat4& world_matrix,
                                std::string_view context);

// One cube-map texel of a field: the fit of Omega (a, b, c), the hull distance r0 and C0.
struct AOFieldTexel {
  float a = 0.0f, b = 0.0f, c = 1.0f;
  float r0 = 0.0f;
  glm::vec3 c0{0.0f};
};

// Baked field of one caster, in the caster's local frame.
struct AOFieldData {
  std::uint32_t entity_index = 0;  // Entity::index of the caster at bake time
  std::uint32_t resolution = 0;    // texels per face edge
  glm::vec3 centre{0.0f};          // field origin in the mesh frame
  float bounding_radius = 0.0f;    // farthest vertex from the centre
  float r_far = 0.0f;              // falloff distance
  float fade_start = 0.8f;
  float inside_occlusion = 1.0f;
  float inside_exponent = 2.0f;
  // Texel (face f, row v, column u) is texels[(f * resolution + v) * resolution + u]; faces in
  // the order +X, -X, +Y, -Y, +Z, -Z (cube_direction()).
  std::vector<AOFieldTexel> texels;
  // Bake diagnostic: texels whose linear fit of the denominator was not positive over [r0, r_far]
  // and that were fitted instead with non-negative inverse-square and constant terms (the clamp).
  std::uint32_t clamped_fits = 0;

  std::uint64_t bytes() const;  // runtime payload: 7 floats per texel
};

// The unit direction through the centre of texel (u, v) of face `face` at `resolution` texels per
// edge (s, t in (-1, 1) across the face). Cost: O(1).
glm::vec3 cube_direction(std::uint32_t face, float s, float t);

// The occluded fraction of the cosine-weighted hemisphere around a normal n,
//   A = (1 / pi) * integral over the cap of max(0, n . w) dw,
// for a spherical cap of solid angle omega in [0, 4 pi] whose axis makes the angle beta with n
// (cos_beta = cos(beta)). Closed form (docs/algorithms.md, P2): with cos(alpha) = 1 - omega / 2pi
// and s = sin^2(alpha): the cap above the horizon gives s cos(beta), below it 0, across it the
// partial formula; omega > 2 pi uses A(alpha, beta) = 1 - A(pi - alpha, pi - beta). Inputs are
// clamped to their ranges; the result is in [0, 1]. Cost: ~55 ns (acos, atan, sqrt in double).
// Thread-safe.
float cap_occlusion(float omega, float cos_beta);

// cap_occlusion from a 129 x 129 table (omega x cos(beta), built on first use, 66 KB) with
// bilinear interpolation: what evaluate() uses. Largest difference from the closed form: 6.5e-4
// (ao_field_test measures it). Cost: ~5 ns. Thread-safe.
float cap_occlusion_table(float omega, float cos_beta);

// The occlusion a caster's field casts at world point x with unit world normal n, given the
// caster entity's current world matrix (rotation, translation, uniform scale): 0 beyond r_far,
// the cap occlusion (table) of the fitted Omega and Upsilon (bilinear texel lookup within a
// face) outside the hull, blended towards inside_occlusion inside it. Result in [0, 1]. Cost: one
// 4x4 inverse plus evaluate_local, which the ao-field bench measures at ~50 ns on random
// receivers. Thread-safe.
float evaluate(const AOFieldData& field, const glm::mat4& caster_world, glm::vec3 x, glm::vec3 n);
// The same with x and n already in the caster's mesh frame (n unit length).
float evaluate_local(const AOFieldData& field, glm::vec3 x, glm::vec3 n);

// The field's convex-hull distance r0 along direction w (mesh frame, any non-zero length),
// bilinearly interpolated like evaluate_local: a point c + r w with r >= r0 is outside the hull.
// 0 for an empty field. Cost: ~15 ns. Thread-safe.
float hull_distance(const AOFieldData& field, glm::vec3 w);

// Several casters at one receiver: 1 - prod (1 - A_i), each A_i clamped to [0, 1] (Kontkanen &
// Laine's multiplicative rule). Never underflows below 0 or exceeds 1. Cost: O(count).
float combine_occlusion(std::span<const float> occlusions);

}  // namespace penumbra
