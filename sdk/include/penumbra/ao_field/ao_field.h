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
// A second representation, the 3D grid of Malmer et al. 2007 ("Fast precomputed ambient
// occlusion for proximity shadows", JGT 12(2)), stores the raw solid angle and average occluded
// direction at the vertices of a grid around the caster (no fit, so also right inside the hull and
// in concavities, for more memory) and feeds the same cap occlusion after a trilinear lookup.
//
// This header holds the authoring component (AOFieldCaster), the receiver component
// (AOFieldReceiver), the baked data (AOFieldData), the closed form, the CPU evaluation and the
// combination rules. The bake is in ao_field_baker.h, the runtime system in ao_field_system.h,
// the GPU layout in ao_field_gpu.h. Units: the caster's local (mesh) units; a field follows its
// entity's rotation, translation and uniform scale (AO is scale-invariant).
#pragma once

#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include <glm/mat4x4.hpp>
#include <glm/vec3.hpp>
#include <glm/ext/vector_double3.hpp>

#include "penumbra/core/pbake.h"
#include "penumbra/core/result.h"
#include "penumbra/lighting/fields.h"
#include "penumbra/lighting/settings.h"
#include "penumbra/scene/components.h"

namespace penumbra {

struct AOFieldData;

// How a field stores what the caster subtends.
enum class AOFieldRepresentation : std::uint32_t {
  // Kontkanen & Laine 2005: a cube map of fitted Omega(r) = 1 / (a r^2 + b r + c), the hull
  // distance r0 and C0 (7 floats per texel). Small; close outside the hull of convex casters;
  // inside the hull a blend.
  RadialFit = 0,
  // Malmer et al. 2007: Omega and Omega x Upsilon at the vertices of a grid_size^3 grid over the
  // cube of half-size r_far around the centre (4 floats per vertex), trilinear. Larger; no fit and
  // no hull, so concave casters are right inside their hull too; weakest within one cell of the
  // caster's surface. Not meaningful inside the caster's solid (never a receiver of its own).
  Grid = 1,
};
const char* to_string(AOFieldRepresentation representation);  // "radial-fit", "grid"

// Authoring component on a rigid entity with a Mesh: casts ambient-occlusion contact shadows.
struct AOFieldCaster {
  AOFieldRepresentation representation = AOFieldRepresentation::RadialFit;
  std::uint32_t resolution = 16;       // cube-map texels per face edge (1..256)
  std::uint32_t radial_samples = 32;   // radii per texel between the hull and the falloff (3..1024)
  std::uint32_t rays_per_sample = 256; // rays per radius (or grid vertex) measuring Omega and Upsilon (>= 16)
  // Radial fit: each texel is sampled along supersample x supersample directions spread over the
  // texel (the cube map built at supersample x the resolution), whose samples are averaged per
  // radius before the fit (filtered down); rays_per_sample are split among them (1..4).
  std::uint32_t supersample = 2;
  // Grid: vertices per axis (4..128). The grid is warped, x = r_far u |u| for u in [-1, 1] per
  // axis, so that vertices crowd near the caster where the field changes fastest.
  std::uint32_t grid_size = 32;
  // Falloff distance r_far from the centre, in the mesh's local units; 0 derives 6 x the bounding
  // radius (the distance from the bounds' centre to the farthest vertex). Must exceed the
  // bounding radius when set.
  float falloff_distance = 0.0f;
  // The occlusion fades linearly to 0 between fade_start x r_far and r_far (0 < fade_start < 1).
  float fade_start = 0.8f;
  // Radial fit: inside the hull the occlusion blends from its hull value towards
  // inside_occlusion at the centre, as A0 + (A_hull - A0) (r / r0)^inside_exponent
  // (inside_occlusion in [0, 1], the exponent > 0). A grid uses inside_occlusion at the centre
  // point only.
  float inside_occlusion = 1.0f;
  float inside_exponent = 2.0f;

  // The baked data (set by the baker or attach_bake(), penumbra/runtime.h); null until baked.
  std::shared_ptr<const AOFieldData> data;

  // Quality presets (radial fit): draft 8x8 per face, 16 radii, 64 rays; medium 16x16, 32 radii,
  // 256 rays; high 32x32, 48 radii, 512 rays; grid_size 16, 32 and 48 for a grid.
  static AOFieldCaster preset(Preset preset);
};

// Receiver component. Entity receivers (dynamic objects): the entity's origin receives the
// occlusion of nearby casters, written by the ao-field system (ao_field_system.h). Surface
// receivers (static geometry): the renderer's per-pixel pass evaluates the fields on the
// entity's surface from the GPU layout (ao_field_gpu.h); the system leaves them alone.
struct AOFieldReceiver {
  enum class Mode : std::uint32_t { Entity, Surface };
  glm::vec3 normal{0.0f, 1.0f, 0.0f};  // local-space normal of the receiving point (Entity mode)
  float occlusion = 0.0f;              // combined occlusion in [0, 1] (0: open); Entity mode
  std::uint64_t updated_tick = 0;
  Mode mode = Mode::Entity;
};

// A field's origin in the mesh frame, the area-weighted centroid of the surface (inside the convex
// hull), and its bounding radius, the distance from it to the farthest vertex: what the bake
// derives, and what a view of a caster not yet baked shows. False when no triangle has a non-zero
// area (the centre is then the bounds' centre). Cost: O(triangles + vertices). Thread-safe.
bool ao_field_origin(const MeshData& mesh, glm::dvec3& centre, double& radius);

// Checks a caster's settings and its entity's world matrix. Errors (InvalidArgument) name
// `context` (e.g. "ao field 'crate'"), the field and the fix: resolution, radial samples or rays
// out of range, a non-finite or negative falloff, fade_start outside (0, 1), inside settings out
// of range, an unknown representation, supersample or grid_size out of range, a singular or
// non-finite matrix, and a non-uniform scale or shear (the field would be distorted: bake the
// scale into the mesh instead). Cost: O(1). Thread-safe.
Status validate_ao_field_caster(const AOFieldCaster& caster, const glm::mat4& world_matrix,
                                std::string_view context);

// One cube-map texel of a field: the fit of Omega (a, b, c), the hull distance r0 and C0.
struct AOFieldTexel {
  float a = 0.0f, b = 0.0f, c = 1.0f;
  float r0 = 0.0f;
  glm::vec3 c0{0.0f};
};

// One grid vertex of a Grid field: the solid angle Omega the caster subtends there and
// Omega x Upsilon (Upsilon: the unit average occluded direction). Interpolating the product keeps
// the direction of the larger caps.
struct AOFieldGridNode {
  float omega = 0.0f;
  glm::vec3 weighted_direction{0.0f};
};

// Baked field of one caster, in the caster's local frame.
struct AOFieldData {
  std::string key;                 // the caster entity's stable key (scene/entity_key.h)
  AOFieldRepresentation representation = AOFieldRepresentation::RadialFit;
  std::uint32_t resolution = 0;    // texels per face edge (RadialFit; 0 for a Grid)
  std::uint32_t grid_size = 0;     // vertices per axis (Grid; 0 for a RadialFit)
  glm::vec3 centre{0.0f};          // field origin in the mesh frame
  float bounding_radius = 0.0f;    // farthest vertex from the centre
  float r_far = 0.0f;              // falloff distance
  float fade_start = 0.8f;
  float inside_occlusion = 1.0f;
  float inside_exponent = 2.0f;
  // Texel (face f, row v, column u) is texels[(f * resolution + v) * resolution + u]; faces in
  // the order +X, -X, +Y, -Y, +Z, -Z (cube_direction()).
  // RadialFit only.
  std::vector<AOFieldTexel> texels;
  // Grid only: vertex (i, j, k) along (x, y, z) is nodes[(k * grid_size + j) * grid_size + i], at
  // centre + r_far (g(u_i), g(u_j), g(u_k)) with u_i = 2 i / (grid_size - 1) - 1, g(u) = u |u|.
  std::vector<AOFieldGridNode> nodes;
  // Bake diagnostic: texels whose linear fit of the denominator was not positive over [r0, r_far]
  // and that were fitted instead with non-negative inverse-square and constant terms (the clamp).
  std::uint32_t clamped_fits = 0;

  // Runtime payload: 7 floats per texel, 4 per grid vertex.
  std::uint64_t bytes() const;
  // True when the arrays match the representation and its size (what evaluation needs).
  bool valid() const;
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

// The table behind cap_occlusion_table: (kCapTableIntervals + 1)^2 values, value (i, j) at
// [i * (kCapTableIntervals + 1) + j] is cap_occlusion(4 pi i / K, -1 + 2 j / K). For the GPU
// layout (ao_field_gpu.h). Thread-safe.
inline constexpr int kCapTableIntervals = 128;
std::span<const float> cap_occlusion_table_values();

// The occlusion a caster's field casts at world point x with unit world normal n, given the
// caster entity's current world matrix (rotation, translation, uniform scale). Result in [0, 1];
// 0 for a field that is not valid(). Cost: one 4x4 inverse plus evaluate_local. Thread-safe.
float evaluate(const AOFieldData& field, const glm::mat4& caster_world, glm::vec3 x, glm::vec3 n);

// The same with x and n already in the caster's mesh frame (n unit length). The steps, in this
// order (the GPU pass of ao_field_gpu.h repeats them), with p = x - centre, r = |p|:
//   1. r >= r_far: 0. r == 0: inside_occlusion.
//   2. RadialFit: the face and (s, t) of p (cube_direction's inverse: major axis m of p, s and t
//      the axes (m+1)%3 and (m+2)%3 of p over |p_m|); texel coordinates u = (s+1)/2 res - 1/2 and
//      v = (t+1)/2 res - 1/2 clamped to [0, res-1]; a, b, c, r0, C0 bilinear from the four texels
//      of that face. rc = max(r, r0); Omega = 1 / (a rc^2 + b rc + c) (0 when that is not
//      positive, at most 4 pi); Upsilon = normalize(C0 - rc p / r) (-p / r when zero).
//      Grid: per axis u = sign(p) sqrt(|p| / r_far), g = (u + 1)/2 (grid_size - 1) clamped to
//      [0, grid_size - 1]; Omega and Omega Upsilon trilinear from the 8 vertices around g;
//      Upsilon = normalize(Omega Upsilon) (-p / r when zero).
//   3. A = cap_occlusion_table(Omega, n . Upsilon).
//   4. RadialFit with r < r0: A = A0 + (A - A0) (r / r0)^inside_exponent, A0 = inside_occlusion.
//   5. A x clamp((r_far - r) / ((1 - fade_start) r_far), 0, 1), then clamped to [0, 1].
// Cost (one core, the ao-field bench): ~40-55 ns; accumulate_open is the fast path. Thread-safe.
float evaluate_local(const AOFieldData& field, glm::vec3 x, glm::vec3 n);

// The loop the ao-field system runs per caster: for each receiver i (world point x[i], unit world
// normal n[i]), open[i] *= 1 - A_i, with A_i the caster's occlusion there (evaluate_local after
// world_to_local, the inverse of the caster's world matrix; the normal is renormalised; a zero or
// non-finite normal leaves open[i] alone). Processes min of the three lengths. On CPUs with AVX2,
// Grid fields and RadialFit fields with inside_exponent 2 go eight receivers at a time through the
// same steps in the same float operations (bit-identical to one at a time; ao_field_grid_test
// checks it). Cost (one core, the ao-field bench's eval_ns): ~15-30 ns per receiver with AVX2,
// ~40-90 ns one at a time. Thread-safe for distinct `open`.
void accumulate_open(const AOFieldData& field, const glm::mat4& world_to_local, std::span<const glm::vec3> x,
                     std::span<const glm::vec3> n, std::span<float> open);

// The field's convex-hull distance r0 along direction w (mesh frame, any non-zero length),
// bilinearly interpolated like evaluate_local: a point c + r w with r >= r0 is outside the hull.
// 0 for a Grid field (it keeps no hull) and for an empty one. Cost: ~15 ns. Thread-safe.
float hull_distance(const AOFieldData& field, glm::vec3 w);

// Several casters at one receiver: 1 - prod (1 - A_i), each A_i clamped to [0, 1] (Kontkanen &
// Laine's multiplicative rule; what the ao-field system uses). Never underflows below 0 or
// exceeds 1. Cost: O(count).
float combine_occlusion(std::span<const float> occlusions);

// What one caster subtends at a receiver: the occlusion evaluate() returns, and the cap behind it
// (its solid angle before the fade and the inside blend, and its unit axis Upsilon in world space;
// omega 0 and a zero axis when the caster subtends nothing there).
struct AOFieldCap {
  float occlusion = 0.0f;
  float omega = 0.0f;
  glm::vec3 axis{0.0f};
};
// evaluate() with the cap. Cost: evaluate's plus a few flops. Thread-safe.
AOFieldCap evaluate_cap(const AOFieldData& field, const glm::mat4& caster_world, glm::vec3 x, glm::vec3 n);

// The cap-overlap rule, an alternative to the multiplicative rule for casters seen in similar
// directions: inclusion-exclusion to pairs, A = sum A_i - sum_{i<j} f_ij min(A_i, A_j), with f_ij
// the fraction of the smaller cap inside the larger estimated from the caps' angular radii
// alpha = acos(1 - omega / 2 pi) and the angle gamma between their axes (0 apart, 1 nested, a
// linear ramp in between), clamped to [max A_i, 1]. Exact for disjoint caps (the cosine-weighted
// measure adds up) and for nested ones (the larger alone), where the multiplicative rule is too
// light and too dark. The ao-field bench measures both against the ray-traced union. Cost:
// O(count^2) acos. Thread-safe.
float combine_caps(std::span<const AOFieldCap> caps);

// The "AOFC" chunk of one field (label "ao-field:<key>") and its reader; read() checks the
// version, sizes and that every value is finite and in range, naming the chunk in its errors.
inline constexpr std::uint32_t kAOFieldChunkType = fourcc("AOFC");
inline constexpr std::uint32_t kAOFieldChunkVersion = 3;  // 3: keyed by the caster's entity key
BakeChunk write_ao_field_chunk(const AOFieldData& data);
Result<AOFieldData> read_ao_field_chunk(const BakeChunk& chunk);
// The chunk's layout of a field's description (representation, sizes, centre, radii, fade and
// inside settings; no key, arrays or diagnostics), which the bake's work groups reuse. The reader
// checks nothing but the bytes left: the caller validates.
void write_ao_field_description(ByteWriter& w, const AOFieldData& data);
Status read_ao_field_description(ByteReader& r, AOFieldData& data);
// Lines for `penumbra info`: resolution, radii, bytes, clamped fits.
std::vector<std::string> describe_ao_field_chunk(const BakeChunk& chunk);

// The field lists (lighting/fields.h) of AOFieldCaster and AOFieldReceiver.
const ComponentInfo& ao_field_caster_info();
const ComponentInfo& ao_field_receiver_info();

}  // namespace penumbra
