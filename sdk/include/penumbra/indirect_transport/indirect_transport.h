// Indirect transport (module "indirect-transport"): bounce light from moving local lights over
// static geometry, by wavelet radiance transport (Kontkanen, Turquin, Holzschuch & Sillion, EGSR
// 2006; the thesis, sec. 3.3). Diffuse transport.
//
// The level's receivers (Static meshes with an IndirectReceiver) are cut into planar rectangular
// patches, each with a quadtree of 2^L x 2^L leaf texels and the orthonormal 2D Haar basis over it
// (per patch: one scaling function and three wavelets per quadtree node above the leaves, 4^L
// functions). Irradiance is the transported quantity: the direct transport operator T takes the
// irradiance E on every surface to the irradiance one bounce later, T E(x) = \int rho(y) E(y)
// G(x, y) V(x, y) dA_y with G = cos_x cos_y / (pi r^2), so the indirect irradiance of direct
// irradiance E_d is E_ind = G E_d with the global transport operator G = sum_{k>=1} T^k. Both are
// sparse matrices in the product of the receivers' and the senders' Haar bases (the standard
// operator decomposition: applying one needs no push-pull). The baker builds T by hierarchical
// refinement and G by a truncated Neumann series; each time a DynamicLight moves the system turns
// its direct irradiance at the leaves into indirect irradiance with one sparse product
// (indirect_transport_system.h). The renderer multiplies E_ind by albedo / pi. What the patches do
// not cover (moving objects, characters, static meshes without an IndirectReceiver) takes the same
// bounce light from bounce probes: a grid of points that saw the patches during the bake
// (TransportProbes).
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include <glm/vec3.hpp>

#include "penumbra/core/jobs.h"
#include "penumbra/core/pbake.h"
#include "penumbra/core/result.h"
#include "penumbra/lighting/fields.h"
#include "penumbra/lighting/settings.h"

namespace penumbra {

struct TransportData;

// On a Static mesh: it receives bounce light and passes it on. Its triangles are grouped into
// planar charts (coplanar, edge-connected triangles), each chart's bounding rectangle in its plane
// cut into patches of at most patch_size metres a side.
struct IndirectReceiver {
  // Metres; 0: kPatchSizeFraction x the diagonal of the receivers' bounds (scale-free).
  float patch_size = 0.0f;
};
inline constexpr float kPatchSizeFraction = 0.12f;
inline constexpr float kBounceProbeSpacingFraction = 0.04f;
inline constexpr std::uint32_t kMaxBounceProbes = 1u << 16;
inline constexpr std::uint32_t kBounceProbeRays = 256;  // rays per bounce probe

// On one entity of the scene: the transport's settings and, once baked, its operator.
struct IndirectTransport {
  // Oracle threshold: a link is refined while its error estimate (the sender's largest albedo x the
  // spread of form factors over the link's sample pairs, indirect_transport_baker.h; form factors
  // are dimensionless, so the threshold is scale-free) exceeds it.
  float refinement_threshold = 0.002f;
  std::uint32_t finest_level = 3;  // quadtree levels per patch: 2^L x 2^L leaf texels (0..6)
  // The Neumann series stops when the last term's Frobenius norm is below bounce_tolerance x the
  // sum's, or after max_bounces terms (reported).
  float bounce_tolerance = 1e-3f;
  std::uint32_t max_bounces = 64;
  // After each product, coefficients below drop_threshold x the largest coefficient of T are dropped.
  // On the maze at the medium preset (bench indirect-transport), 3e-4 against 1e-4: the global
  // operator 36 MB instead of 61 MB, computed in 3.1 s instead of 4.3 s, the error against the
  // path tracer 0.031 instead of 0.027.
  float drop_threshold = 3e-4f;
  // A directional (glossy) part per patch: not implemented; a bake with it on fails Unsupported.
  bool glossy = false;
  // Metres between bounce probes (TransportProbes); 0: kBounceProbeSpacingFraction x the diagonal
  // of the receivers' bounds (scale-free), raised where the grid would exceed kMaxBounceProbes.
  float probe_spacing = 0.0f;

  std::shared_ptr<const TransportData> data;  // set by the baker or attach_bake(); null until baked

  // Draft: level 2, threshold 0.02; medium: level 3, 0.002; high: level 4, 0.001.
  static IndirectTransport preset(Preset preset);
};

// The indirect irradiance at every leaf texel (W/m^2 per channel), patch after patch, leaf (i, j)
// of a patch at i + j 2^L: written by the indirect-transport system on the IndirectTransport
// entity whenever a dynamic light changed.
struct IndirectLightmap {
  std::vector<glm::vec3> irradiance;
  std::vector<glm::vec3> direct;  // the direct irradiance it came from (for tools and tests)
  // Per bounce probe (TransportProbes), six irradiances (W/m^2), towards +x, -x, +y, -y, +z, -z.
  std::vector<glm::vec3> probes;
  std::uint64_t updated_tick = 0;
  std::uint32_t kept_coefficients = 0;  // significant direct coefficients multiplied in the update
};

const ComponentInfo& indirect_receiver_info();
const ComponentInfo& indirect_transport_info();
const ComponentInfo& dynamic_light_info();

// One patch: the rectangle origin + s edge_u + t edge_v (s, t in [0, 1]) of the receiver `key`,
// facing `normal` (edge_u x edge_v), with one albedo. Leaf (i, j) covers s in [i, i+1) / 2^level,
// t in [j, j+1) / 2^level; coverage[i + j 2^level] is the fraction of the leaf inside the mesh's
// triangles (0: a hole of the chart, no light sent or received).
struct TransportPatch {
  std::string key;
  glm::vec3 origin{0.0f}, edge_u{1.0f, 0.0f, 0.0f}, edge_v{0.0f, 1.0f, 0.0f}, normal{0.0f, 0.0f, 1.0f};
  glm::vec3 albedo{0.0f};
  std::uint32_t level = 0;
  std::vector<float> coverage;
  std::uint32_t first = 0;  // index of its first leaf (and Haar coefficient) in the whole scene

  std::uint32_t side() const { return 1u << level; }
  std::uint32_t leaves() const { return side() * side(); }
  float area() const;       // |edge_u x edge_v|
  float leaf_area() const;  // area() / leaves()
  glm::vec3 leaf_centre(std::uint32_t i, std::uint32_t j) const;
};

// A sparse matrix over the scene's Haar coefficients, RGB values, compressed by column: column j
// (a sender coefficient) holds rows row[begin[j] .. begin[j+1]) with values value[...].
struct SparseTransport {
  std::uint32_t size = 0;
  std::vector<std::uint64_t> begin{0};
  std::vector<std::uint32_t> row;
  std::vector<glm::vec3> value;

  std::uint64_t nonzeros() const { return row.size(); }
  std::uint64_t bytes() const;
  double frobenius() const;  // sqrt of the sum of squares over all channels
};

// Bounce probes: the patches' light at the nodes of a regular grid over the receivers' bounds, for
// the surfaces the lightmap does not cover. A probe sees the patches' cells (per patch, the
// quadtree nodes of level min(level, kBounceProbeCellLevel)) through the directions its bake rays
// found them in; an entry's weight towards axis direction a (+x, -x, +y, -y, +z, -z) is
// w_a = (4 pi / rays) x sum over the rays that hit the cell's front of max(0, dot(ray, a)), so the
// probe's irradiance towards a is sum w_a L_cell, L_cell the cell's mean radiance (albedo / pi x
// its direct plus indirect irradiance): exact up to the ray sampling. A probe whose rays meet the
// inside of a closed solid (the back of a single-sided surface) on more than
// kBounceProbeClosedFraction of them is closed: it holds no entries and lookups skip it. Each probe
// also keeps its reach towards the six axis directions: the free fraction (0..1) of the step to its
// neighbour, up to the first surface; a lookup skips a probe the point lies beyond a surface from
// (below a floor, behind a wall), as the probe grid's leak guard does.
struct BounceProbeEntry {
  std::uint32_t cell = 0;
  std::array<float, 6> weight{};
};
inline constexpr std::uint32_t kBounceProbeCellLevel = 2;
inline constexpr float kBounceProbeClosedFraction = 0.1f;
struct TransportProbes {
  glm::vec3 origin{0.0f};       // node (0, 0, 0); node (i, j, k) at origin + spacing (i, j, k)
  float spacing = 0.0f;         // metres; 0 with no nodes: no probes
  glm::uvec3 count{0u};         // nodes per axis
  std::uint32_t rays = 0;       // rays each probe traced
  std::vector<std::uint8_t> open;    // per node (x fastest, then y, then z): 1 open, 0 closed
  std::vector<std::array<float, 6>> reach;  // per node, towards +x, -x, +y, -y, +z, -z
  std::vector<std::uint32_t> begin;  // node n's entries: [begin[n], begin[n + 1]); nodes() + 1 values
  std::vector<BounceProbeEntry> entries;

  std::size_t nodes() const { return std::size_t{count.x} * count.y * count.z; }
  std::uint64_t bytes() const;  // the per-probe lists
};

// Whether one probe's record holds only what a bake writes: a flag of 0 or 1, reaches in [0, 1],
// entries with a cell below `cells` and weights in [0, 4 pi]. The chunk reader and the baker's
// merge of parts check every probe with it. O(entries).
bool bounce_probe_in_range(std::uint8_t open, const std::array<float, 6>& reach,
                           std::span<const BounceProbeEntry> entries, std::uint32_t cells);

// The baked transport of a scene.
struct TransportData {
  std::vector<TransportPatch> patches;
  SparseTransport global;  // G, in the patches' orthonormal Haar bases
  TransportProbes probes;
  // What the bake did (reported by `penumbra info` and the bench).
  float refinement_threshold = 0.0f;
  std::uint32_t finest_level = 0;
  std::uint64_t links = 0;              // links of the hierarchical direct operator
  std::uint64_t direct_nonzeros = 0;    // coefficients of T in the Haar bases
  // Neumann terms summed and the last one's size against the sum: |T^terms|_F / |G|_F, or with
  // no light moving (moving_lights false) the fixed lights' |T^terms E| / |sum of T^k E| over the
  // leaves; below the tolerance when converged.
  std::uint32_t terms = 0;
  float last_term_ratio = 0.0f;
  bool converged = false;
  // The fixed lights' part (DynamicLight::moves false), baked: their direct and indirect irradiance
  // per leaf (W/m^2) and the bounce probes' six irradiances per node (IndirectLightmap::probes),
  // all empty when the bake had no fixed light. The runtime adds the moving lights' part to them.
  std::vector<glm::vec3> fixed_direct, fixed_indirect, fixed_probes;
  // Whether `global` and the probes' entries are kept for moving lights: false when the enabled
  // DynamicLights at bake time were all fixed (one at least); both are then empty and the lightmap
  // and the probes are the fixed part alone.
  bool moving_lights = true;

  std::uint32_t leaf_count() const;  // the scene's leaves = Haar coefficients
  std::uint32_t cell_count() const;  // the bounce probes' cells (bounce_probe_cell_offsets)
  std::uint64_t bytes() const;
};

// The orthonormal 2D Haar transform of one patch's 2^level x 2^level leaf values (leaf (i, j) at
// i + j 2^level), in place and scaled by sqrt(leaf_area) so that the coefficients' sum of squares
// is the integral of the square over the patch. Layout: [0] the scaling coefficient, then three
// wavelets per quadtree node above the leaves, nodes level by level (node (l, i, j) at
// (4^l - 1) / 3 + i + j 2^l, its wavelets at 1 + 3 node + t: t = 0 splits along t (j), 1 along s
// (i), 2 the diagonal). haar_synthesise is its inverse. Cost: O(4^level).
void haar_analyse(std::span<glm::vec3> values, std::uint32_t level, float leaf_area);
void haar_synthesise(std::span<glm::vec3> values, std::uint32_t level, float leaf_area);

// What an update did.
struct TransportUpdate {
  std::uint32_t kept = 0;         // direct coefficients above the keep threshold
  std::uint64_t multiplies = 0;   // operator entries touched
};

// E_ind = G E_d on the CPU: Haar analysis of `direct` (one value per leaf, patch after patch),
// keeping the coefficients whose largest channel is at least keep_threshold x the largest, the
// sparse product with data.global, the inverse transform into `indirect`. Preconditions: both
// spans have data.leaf_count() entries; leaves outside their chart (coverage 0) should be 0 in
// `direct` and come out 0. Runs on `scheduler` when given (null: the calling thread), with the
// same bits at any thread count. Cost: O(leaves + entries of G in the kept columns): on the maze
// at the medium preset about 2 million multiply-adds.
TransportUpdate apply_transport(const TransportData& data, std::span<const glm::vec3> direct,
                                std::span<glm::vec3> indirect, float keep_threshold = 1e-4f,
                                TaskScheduler* scheduler = nullptr);

// The indirect irradiance at world point x with unit normal n from a lightmap (`irradiance`, one
// value per leaf, IndirectLightmap::irradiance): of the patches whose normal is within 60 degrees
// of n, whose plane holds x (within patch_plane_tolerance) and whose rectangle, widened by
// kTransportMargin of its size, contains x, the one nearest to x's plane (or, in patch order, the
// first whose plane is within kTransportPlaneSnap of its tolerance of x: the renderer's search
// stops there) gives the bilinear interpolation of its leaf texels (centres at (k + 0.5) / 2^level,
// clamped to the patch); none gives 0. The renderer's lookup is this one in GLSL
// (shaders/indirect_transport.glsl). Cost: O(patches).
glm::vec3 sample_indirect_irradiance(const TransportData& data, std::span<const glm::vec3> irradiance, glm::vec3 x,
                                     glm::vec3 n);
// The bounce probes' cells are numbered patch after patch, 4^min(level, kBounceProbeCellLevel)
// each, in the quadtree's row order (cell (i, j) of a patch at i + j 2^min(level,
// kBounceProbeCellLevel)): each patch's first cell, then the total. O(patches).
std::vector<std::uint32_t> bounce_probe_cell_offsets(std::span<const TransportPatch> patches);
// The index of the patch sample_indirect_irradiance reads at x, or -1 when none holds x.
int transport_patch_at(const TransportData& data, glm::vec3 x, glm::vec3 n);
// The bounce probes' irradiance: into `cubes` (six per probe, IndirectLightmap::probes) from the
// leaves' direct and indirect irradiance (one value per leaf each). Closed probes get 0.
// Preconditions: direct and indirect have data.leaf_count() entries, cubes 6 x probes.nodes().
// Probes run on `scheduler` when given (null: the calling thread), with the same bits at any
// thread count. Cost: O(leaves + probe entries); the maze's default bake, 0.18 M entries.
void bounce_probe_irradiance(const TransportData& data, std::span<const glm::vec3> direct,
                             std::span<const glm::vec3> indirect, std::span<glm::vec3> cubes,
                             TaskScheduler* scheduler = nullptr);

// The bounce probes' irradiance at world point x with unit normal n: the point moved
// kBounceProbeOffset x spacing along n, the trilinear weights of the eight nodes around it (the
// grid's edge nodes beyond its bounds) over the open ones that reach it (its offset from the node
// along each axis within the node's reach that way; when none does, over the open ones), each
// node's six irradiances blended by the squares of n's components (an ambient cube: exact for
// normals along the axes). 0 when no open node is around. The renderer's lookup is this one in
// GLSL (shaders/indirect_transport.glsl).
// Precondition: cubes has 6 x probes.nodes() entries. Cost: O(1).
glm::vec3 sample_bounce_probes(const TransportProbes& probes, std::span<const glm::vec3> cubes, glm::vec3 x,
                               glm::vec3 n);
inline constexpr float kBounceProbeOffset = 0.5f;

// The transport's bounce light at x with unit normal n, as the renderer's ambient pass adds it:
// the lightmap where a patch holds x (sample_indirect_irradiance), the bounce probes elsewhere
// (sample_bounce_probes). Precondition: `map` was updated for `data`. Cost: O(patches).
glm::vec3 sample_transport_irradiance(const TransportData& data, const IndirectLightmap& map, glm::vec3 x,
                                      glm::vec3 n);

// How far off a patch's plane a point may be and still be on it: 5% of the patch's size plus the
// float error of its position (the renderer's points come from its depth buffer).
float patch_plane_tolerance(const TransportPatch& patch);
inline constexpr float kTransportMargin = 0.01f;
inline constexpr float kTransportPlaneSnap = 0.01f;

inline constexpr std::uint32_t kTransportChunkType = fourcc("WRTO");
inline constexpr std::uint32_t kTransportChunkVersion = 3;

// The "WRTO" chunk: one per bake (label "indirect-transport:<transport entity key>"). The reader
// checks every size, index and value and names the chunk in its errors.
BakeChunk write_transport_chunk(const std::string& key, const TransportData& data);
struct TransportChunk {
  std::string key;
  TransportData data;
};
Result<TransportChunk> read_transport_chunk(const BakeChunk& chunk);

}  // namespace penumbra
