// Irradiance probe grid (P3): precomputed lighting (direct + indirect, or indirect only) for dynamic
// objects and the indirect term of a renderer, after
// Kontkanen & Laine 2006, "Sampling Precomputed Volumetric Lighting" (JGT 11(3); the thesis,
// section 3.2).
//
// A grid of nodes x_i over a box stores per node the SH irradiance (RGB, L1 or L2). At runtime a
// receiver at x with normal n gets E(x, n) = sum_i B_i(x) E_i(n), the plain trilinear
// interpolation of the node expansions evaluated at n. The bake (probe_grid_baker.h) chooses E_i by
// point sampling (the classic irradiance volume) or by the paper's supersampling over each node's
// tent B_i restricted to the domain of interest; the runtime is the same for both.
//
// The leak guard (IrradianceProbeGrid::leak_guard, our addition; on by default). No choice of node
// values lets a trilinear field jump inside a cell, so at a thin wall with open space on both sides
// every mode leaks (the bench's step model puts the floor at ~0.6x point sampling's leak). With the
// guard the bake also stores, per node, how far it sees along the grid's six axis directions (its
// reach, 6 bytes), and the lookup drops the cell corners that a surface hides from the receiver:
// corner o is hidden when, along some axis, the receiver lies farther from o than o's reach in that
// direction. The lookup then evaluates the same trilinear basis at the visible corners' weighted
// mean (probe_lookup_fraction), which is exact when a wall hides a whole face of the cell and costs
// the shader 8 unfiltered fetches more and no extra SH fetch. The bake averages each node's samples
// over the part of its tent that the node sees, and the fit fits the guarded basis. A node inside a
// thick solid (a block's interior near a face) is left open on every side, so the paper's
// in-domain average extrapolates the light outside into it; a node inside a solid thinner than a
// cell (a wall) stays hidden. The reach looks along the axes only, so a receiver on a thick solid's
// face (and on any face oblique to the grid) could still blend in the nodes inside the solid. A
// receiver on the level's static geometry (ProbeReceiver::Static), the geometry the grid was baked
// from, therefore also drops the corners that lie in the solid under it: those with out-of-domain
// samples (validity < 1) more than kProbePlaneSlack cells behind its tangent plane
// (probe_node_inside_surface), and its reach test looks from farther off the surface
// (kProbeStaticNormalBias, probe_lookup_fraction). On the Cornell box's turned blocks the fronts
// went from 1.50x and 1.10x the reference to 1.02x and 0.97x (penumbra bench image-accuracy, with
// the medium preset's noise target). A moving receiver (ProbeReceiver::Moving: a ProbeLit object,
// a point in free space) keeps the reach alone: its tangent plane does not bound a solid, and the
// rule cost the probe-grid bench's free-space receivers near the Cornell blocks a 1.5x larger
// leak. When the rule would leave no corner, the reach's corners alone decide.
//
// This header holds the authoring component (IrradianceProbeGrid), the receiver component
// (ProbeLit), the baked data (ProbeGridData) and its PRBG chunk, the grid's geometry
// (ProbeGridLayout), the CPU evaluation and the GPU texture layout. Units: metres; irradiance in W/m^2 per RGB channel.
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include <glm/mat4x4.hpp>
#include <glm/vec3.hpp>
#include <glm/vec4.hpp>

#include "penumbra/core/pbake.h"
#include "penumbra/core/result.h"
#include "penumbra/core/sh.h"
#include "penumbra/lighting/fields.h"
#include "penumbra/lighting/settings.h"
#include "penumbra/scene/components.h"

namespace penumbra {

enum class ProbeShOrder : std::uint8_t { L1 = 1, L2 = 2 };     // 4 or 9 coefficients per channel
// How the bake chooses node values (the runtime is the same for all three):
//   Point: the lighting at the node (the classic irradiance volume).
//   Supersampled: the tent-weighted average over the node's support in the domain of interest
//     (Kontkanen & Laine 2006).
//   Fitted: the least-squares values that minimise the trilinear reconstruction error over the
//     domain of interest inside the box, from tent samples like Supersampled's (folded into the
//     box at its faces): a sharper reconstruction at thin walls; see sdk/src/probe_grid/probe_fit.h.
//   No mode makes a plain trilinear field jump inside a cell: at a thin wall with open space on both
//   sides the leak stays above ~0.6x point sampling's (the probe-grid bench's step model); the leak
//   guard (header) is what removes it.
enum class ProbeSampling : std::uint8_t { Point, Supersampled, Fitted };
const char* to_string(ProbeShOrder order);    // "L1", "L2"
const char* to_string(ProbeSampling sampling);  // "point", "supersampled", "fitted"

// Number of SH coefficients per colour channel of an order (4 or 9).
constexpr int sh_coefficients(ProbeShOrder order) {
  return order == ProbeShOrder::L1 ? kSHCoefficientsL1 : kSHCoefficientsL2;
}

// The most a node's rays per sample point may grow to reach IrradianceProbeGrid::noise.
inline constexpr std::uint32_t kProbeMaxRayFactor = 8;
// `bounces` value meaning "every bounce" (Russian roulette at ray hits, as the reference).
inline constexpr std::uint32_t kProbeAllBounces = ~0u;

struct ProbeGridData;

// Authoring component: a probe grid over a box. Zero/empty fields mean "derive" (see each).
struct IrradianceProbeGrid {
  // World-space box. Empty (the default): the unit cube [-0.5, 0.5]^3 through the entity's
  // WorldTransform (so the Transform's scale is the box size, and the grid may be rotated).
  Aabb box;
  // Nodes per axis (each >= 2). (0, 0, 0): derived from the spacing as ceil(size / spacing) + 1.
  glm::uvec3 resolution{0u};
  // Metres between nodes when `resolution` is zero. 0: follows the box's scale, `cells` cells
  // across its smallest side, and at most kMaxDerivedCells along any side.
  float spacing = 0.0f;
  std::uint32_t cells = 6;

  ProbeShOrder sh_order = ProbeShOrder::L2;
  ProbeSampling sampling = ProbeSampling::Supersampled;
  // Supersampled and Fitted: S points per node from the node's tent, `rays_per_sample` rays each.
  // Point: all S x rays_per_sample rays at the node itself (the same ray budget).
  std::uint32_t samples_per_node = 32;
  std::uint32_t rays_per_sample = 16;
  // Light bounces before reaching a node: 0 = direct light and emitters seen from the node; k =
  // surfaces hit by the node's rays are lit with k - 1 bounces; kProbeAllBounces = all. Used when
  // `truncation` is 0.
  std::uint32_t bounces = 2;
  // When > 0 the bounce count follows the scene instead: the fewest k with rho_max^k <=
  // truncation (probe_bounces), which bounds the fraction of the indirect light that stopping
  // after k bounces leaves out (each bounce keeps at most rho_max of the last). 0: `bounces` as
  // given; the presets set a truncation.
  float truncation = 0.0f;
  std::uint32_t hit_samples = 2;  // irradiance paths at each ray hit (>= 2)
  // When > 0, a node whose estimate is noisier than this traces its sample points again with 2,
  // 4 or 8 x rays_per_sample (at most kProbeMaxRayFactor): the fewest that bring the estimated
  // relative standard error of its irradiance (the mean over its sample points of the radiance's
  // constant term, channel-averaged) to `noise`. The error is estimated from the two halves of each
  // point's rays (a pair of randomised quasi-Monte Carlo estimates, whose difference over-states
  // the error of their mean rather than under-states it). Nodes decide alone, so the bake stays
  // deterministic at any thread and shard count. A refined node pays for its first pass too:
  // 1 + factor times its rays. 0: every node rays_per_sample (so does rays_per_sample 1, which
  // gives no estimate). The presets set it.
  float noise = 0.0f;
  // What the nodes store (lighting/settings.h, LightingContent). Indirect (the default, and every
  // preset's): only light that reflected at least once (no lights' direct light, no emission seen
  // straight from the node), for a renderer that draws direct light itself with shadow maps, as the
  // SDK's does; an All grid there counts direct light twice and smears its shadows over the node
  // spacing. All: direct + indirect, for a renderer that draws no dynamic direct light on
  // probe-lit objects (the grid is their whole lighting).
  LightingContent lighting = LightingContent::Indirect;
  // Domain of interest: a sample point is outside when more than this fraction of its rays first
  // hits a back face (0 for watertight scenes; 0.05-0.5 for open geometry).
  float back_face_threshold = 0.1f;
  // Deringing at bake: Lanczos window width applied to the stored expansion (0: none). Evaluation
  // clamps at zero either way.
  float deringing_window = 0.0f;
  // Leak guard (header): store each node's reach and skip hidden corners at lookup. Off: the
  // paper's plain trilinear runtime (and its leaks through thin walls).
  bool leak_guard = true;

  // Runtime blending: where grids overlap the higher priority wins, fading out over
  // `blend_distance` metres (0: one node spacing) inside its border.
  int priority = 0;
  float blend_distance = 0.0f;

  // The baked data (set by the baker or attach_bake(), penumbra/runtime.h); null until baked.
  std::shared_ptr<const ProbeGridData> data;

  // Quality presets, by error rather than by counts: draft S=8, 16 rays, truncation 20 %, 3 cells
  // across the box's smallest side, supersampled; medium S=32, 16 rays, truncation 5 %, 6 cells,
  // fitted; high S=64, 32 rays, truncation 1 %, 12 cells, fitted (fitted had 0.7-0.9x the
  // supersampled RMSE on every probe-grid bench row, for a fixed solve cost).
  static IrradianceProbeGrid preset(Preset preset);
};

// Cells along any side of a derived spacing (IrradianceProbeGrid::spacing 0), at most.
inline constexpr std::uint32_t kMaxDerivedCells = 96;
// Bounces derived from a truncation, at most (rho_max near 1 would ask for very many).
inline constexpr std::uint32_t kMaxDerivedBounces = 32;

// The bounce count a grid bakes with: `bounces` when truncation is 0; else the fewest k >= 1 with
// max_albedo^k <= truncation (max_albedo: the brightest albedo channel of the geometry baked,
// RayScene::max_albedo), at most kMaxDerivedBounces. O(1).
std::uint32_t probe_bounces(const IrradianceProbeGrid& grid, float max_albedo);

// Receiver component: an entity (character, moving prop) lit by the probe grids. Written by the
// probe-grid system when the entity moved or a grid changed.
struct ProbeLit {
  SH9rgb irradiance;            // irradiance SH at `position` (zero when no grid covers it)
  ProbeShOrder order = ProbeShOrder::L2;  // how many coefficients are meaningful
  bool covered = false;         // some grid covers the entity's position
  std::uint64_t updated_tick = 0;  // the World tick of the last update
  glm::vec3 position{0.0f};     // world point the lighting was taken at (probe_lit_position)
};

// E(n) of a receiver, >= 0 per channel. Cost: ~40 flops.
glm::vec3 probe_lit_irradiance(const ProbeLit& lit, glm::vec3 n);

// The geometry of a grid: node (i, j, k) sits at grid_to_world * ((i, j, k) / (resolution - 1)).
struct ProbeGridLayout {
  glm::uvec3 resolution{2u};
  glm::mat4 grid_to_world{1.0f};  // affine: [0, 1]^3 -> the box
  glm::mat4 world_to_grid{1.0f};
  glm::vec3 spacing{1.0f};        // metres between neighbouring nodes, per grid axis

  std::size_t node_count() const {
    return std::size_t{resolution.x} * resolution.y * resolution.z;
  }
  std::size_t node_index(glm::uvec3 ijk) const { return (std::size_t{ijk.z} * resolution.y + ijk.y) * resolution.x + ijk.x; }
  glm::vec3 node_position(glm::uvec3 ijk) const;
};

// Limit on nodes per grid (about 2 GiB of L2 data): larger requests are refused before planning.
inline constexpr std::uint64_t kMaxProbeNodes = std::uint64_t{1} << 24;

// Validates `grid` and computes its layout. `world_matrix` is the entity's WorldTransform (used
// when grid.box is empty). Errors (InvalidArgument) name `context` (e.g. "probe grid 'hall'"),
// the field and the fix: a resolution below 2 on an axis ("a 1x1x1 grid"), a non-finite or
// non-positive spacing, an empty/degenerate/non-finite box or transform, more than kMaxProbeNodes
// nodes, zero samples or rays, hit_samples < 2, a threshold outside [0, 1], a negative window, a
// lighting value that is neither All nor Indirect.
// Cost: O(1). Thread-safe.
Result<ProbeGridLayout> probe_grid_layout(const IrradianceProbeGrid& grid, const glm::mat4& world_matrix,
                                          std::string_view context);

// Baked data of one grid: per node the irradiance SH (cosine-convolved, RGB) and the coverage.
struct ProbeGridData {
  std::string key;  // the grid entity's stable key (scene/entity_key.h)
  ProbeGridLayout layout;
  ProbeShOrder sh_order = ProbeShOrder::L2;
  ProbeSampling sampling = ProbeSampling::Supersampled;
  LightingContent lighting = LightingContent::All;  // what the coefficients hold
  std::uint32_t bounces = 0;  // the bounces baked (kProbeAllBounces: all), as probe_bounces chose them
  // The noise target (IrradianceProbeGrid::noise; 0: none) and its refinement: the nodes that
  // traced more rays and the mean over all nodes of their rays per sample point / rays_per_sample
  // (1: none refined).
  float noise = 0.0f;
  std::uint32_t refined_nodes = 0;
  float ray_factor = 1.0f;
  // Node n's coefficient c is coefficients[n * sh_coefficients(sh_order) + c] (RGB).
  std::vector<glm::vec3> coefficients;
  // In-domain coverage per node in [0, 1]: the fraction of its samples in the domain of interest
  // and, with the leak guard, seen by the node (point mode: 1 or 0 for the node itself).
  std::vector<float> validity;
  // 1 where the node had no in-domain sample and was filled from its neighbours.
  std::vector<std::uint8_t> filled;
  // Leak guard (empty when off): node n's reach along +x, -x, +y, -y, +z, -z of the grid at
  // reach[6 n + d], the distance to the first surface in units of that axis's spacing, 0..1 as
  // 0..255 (255: nothing within one spacing).
  std::vector<std::uint8_t> reach;

  std::size_t node_count() const { return layout.node_count(); }
  SH9rgb node(std::size_t n) const;  // coefficients beyond the order are zero
  float valid_fraction() const;      // nodes with validity > 0 / all nodes
  std::uint64_t bytes() const;       // memory held by the arrays
  std::uint64_t bytes_per_node() const;  // runtime payload: coefficients (12 x 4 or 9 B) + reach (6 B)
};

// What a receiver of the grid's light stands on, for the leak guard's lookup (header).
enum class ProbeReceiver : std::uint8_t {
  Moving,  // a point in free space or a moving object's surface: the reach alone decides
  Static,  // the level's static geometry (the Static tag), which the bake saw: the solid under it is dropped too
};

// The leak guard's lookup (header): the fraction inside cell `base` (grid units, node base at
// `base`) at which the trilinear basis is evaluated for a receiver at fraction f of that cell.
// Corner o is hidden when, along some axis, the test point lies more than o's reach plus one
// quantisation step (kProbeReachSlack) from o, so a receiver on a surface is seen by the nodes on
// its side of it. The test point is f moved kProbeNormalBias cells along `normal_cells` (the
// receiver's normal in grid units; zero for a point in free space), which only decides for
// surfaces of no thickness, seen by the nodes on both sides. For a Static receiver with a normal,
// the corners in the solid under it are hidden too (probe_node_inside_surface), unless that hides
// every corner the reach leaves, and the test point moves kProbeStaticNormalBias cells instead:
// the solid rule handles the receiver's own solid, so the reach's axis test need not decide at the
// surface itself, where an oblique face hides the nodes in front of it from parts of it (bands
// across the Cornell blocks' fronts). The price: a static receiver facing another surface closer
// than that sees the nodes beyond it. For every receiver, a corner whose tent lies mostly out of
// the domain (validity below kProbeSolidValidity: it sits inside a solid, its value the fit's
// extrapolation) is hidden too while another corner stays in view. The fit (probe_fit.h) uses the
// lookup of a point in free space; were the nodes inside a solid in its basis, the nodes in front
// of the solid would be fitted to make up for them, and a static receiver, which drops them, would
// read those values (on the Cornell tall block's front: 0.956x the reference and 7.1 % median
// per-pixel error, against 0.998x and 4.7 % with the rule; penumbra bench image-accuracy). Returns
// f itself without reach data or when every corner is hidden. Cost: 8 x 6 compares. Thread-safe.
// The shader (probe_grid.glsl) does the same arithmetic; the bake's input hash holds these
// constants, since the fit depends on them.
inline constexpr float kProbeReachSlack = 1.0f / 255.0f;
inline constexpr float kProbeNormalBias = 0.01f;
inline constexpr float kProbeStaticNormalBias = 0.1f;  // cells
inline constexpr float kProbePlaneSlack = 0.15f;  // cells: a node this close to the plane still counts
inline constexpr float kProbeSolidValidity = 0.4f;  // below: most of the tent in solids (0.5 on a wall)
// Whether a node with reach bytes `reach` (6 of ProbeGridData::reach) sees the point `offset`
// cells from it: along every axis the offset is within the node's reach that way plus
// kProbeReachSlack. The one visibility test of the lookup and of the bake. Cost: 3 compares.
bool probe_node_sees(const std::uint8_t* reach, glm::vec3 offset);
// Whether a node with this validity lies in the solid under a static receiver: it has samples out
// of the domain (validity < 1: it sits in or against geometry) and lies more than
// kProbePlaneSlack cells behind the receiver's tangent plane (`height`: its signed distance from
// that plane in cells). Cost: 2 compares.
bool probe_node_inside_surface(float validity, float height);
glm::vec3 probe_lookup_fraction(const ProbeGridData& data, glm::uvec3 base, glm::vec3 f, glm::vec3 normal_cells,
                                ProbeReceiver receiver = ProbeReceiver::Moving);

// Interpolation of the node expansions at world point x (clamped into the box): trilinear, at the
// leak guard's lookup fraction when the grid has reach data, tested from the side `n` points to
// (zero: x is a free-space point, as for ProbeLit receivers) for a receiver of that kind. Cost: 8
// x coefficients multiply-adds. Thread-safe.
SH9rgb interpolate(const ProbeGridData& data, glm::vec3 x, glm::vec3 n = glm::vec3(0.0f),
                   ProbeReceiver receiver = ProbeReceiver::Moving);
// E(x, n) = the interpolated expansion (for a receiver on a surface with unit normal n) evaluated
// at n, never negative. The same math as the shader. Cost: about 60-200 ns (measured by the
// probe-grid bench). Thread-safe.
glm::vec3 evaluate(const ProbeGridData& data, glm::vec3 x, glm::vec3 n, ProbeReceiver receiver = ProbeReceiver::Moving);

// The "PRBG" chunk of one grid (label "probe-grid:<key>") and its reader. read() checks the
// version, sizes, resolution and that every value is finite, and names the chunk in its errors.
inline constexpr std::uint32_t kProbeGridChunkType = fourcc("PRBG");
inline constexpr std::uint32_t kProbeGridChunkVersion = 6;  // 6: the noise target's refinement
BakeChunk write_probe_grid_chunk(const ProbeGridData& data);
Result<ProbeGridData> read_probe_grid_chunk(const BakeChunk& chunk);
// Lines for `penumbra info`: grid size, order, mode, lighting, valid fraction, filled nodes, bytes.
std::vector<std::string> describe_probe_grid_chunk(const BakeChunk& chunk);

// The field lists (lighting/fields.h) of IrradianceProbeGrid and ProbeLit.
const ComponentInfo& irradiance_probe_grid_info();
const ComponentInfo& probe_lit_info();

}  // namespace penumbra
