// The indirect-transport bake (Kontkanen et al. 2006): patches from the receivers, the direct
// transport operator T by hierarchical refinement, the global operator G by a truncated Neumann
// series, one WRTO chunk. Fixed lights (DynamicLight::moves false) have their light carried
// through G at bake time; when no light moves, G is not built: the series is summed for their
// light alone, one product of T with a vector per term (TransportData::fixed_indirect).
//
// Refinement (per receiver patch, so a shard bakes some receivers): every pair of patches that face
// each other starts as one link between their roots. A link is evaluated at 2 x 2 points on each
// side, one per quadrant: the exact form factor from each receiver quadrant's centre to the sender
// node (Lambert's point-to-polygon formula, the node clipped to the point's half space: exact as
// the distance goes to zero at shared edges) times the fraction of 4 shadow rays from a jittered
// point of the quadrant to jittered sender points that arrive (16 rays). The oracle's error is the
// sender's largest albedo x the larger of 2 x the spread (max - min) of point form factor x pair
// visibility over the pairs (variation over the receiver and partial visibility) and the spread
// of the point-to-point kernel x the sender's area over the sender seen from one receiver point.
// A link where one node's plane cuts the other is always refined (its points may all fall on one
// side). While it exceeds the refinement threshold the larger of the two nodes (by area; the other
// at the finest level) is split into its four children. An accepted link keeps, per quadrant of
// the receiver node, that quadrant's value: the transfer from the sender node's mean irradiance to
// each quadrant's, so the kernel's change across the receiver node costs no further link.
//
// Bounce probes: a grid over the receivers' bounds; each node traces kBounceProbeRays rays and
// keeps, per patch cell it saw, the solid-angle weights that turn the cells' radiance into its
// irradiance towards the six axis directions (TransportProbes). Nodes are baked as elements after
// the patches.
//
// Standard decomposition: each link (receiver node r, sender node s) is the operator
// sum_c F_c rho_s 1_c 1_s^T / n_s on leaf values (c the quadrants of r, or r itself at a leaf),
// projected onto the receivers' and senders' orthonormal Haar bases, where the box of a node is the
// scaling function and its ancestors' wavelets; the projections of all links are summed into T
// (compressed by column).
#pragma once

#include <array>
#include <cstdint>
#include <span>
#include <string>
#include <unordered_map>
#include <vector>

#include "penumbra/bake/baker.h"
#include "penumbra/bake/ray_scene.h"
#include "penumbra/indirect_transport/indirect_transport.h"

namespace penumbra {

// The receivers' patches: every Static mesh with an IndirectReceiver, in entity order; its
// triangles (world space) grouped into charts of coplanar (normals within 1 degree, on the plane
// within 1e-4 of its size), edge-connected triangles; each chart's bounding rectangle (along its
// longest edge) cut into patches of at most patch_size a side (0: kPatchSizeFraction x the
// receivers' diagonal), each at finest_level (fewer levels for a patch much smaller than that
// size, so texels stay about patch_size / 2^level wide). `warnings` gets one line per receiver
// whose triangles fall, in part or all, in charts under one texel (not parameterisable: curved,
// fragmented or small geometry; those triangles are left out), naming the mesh. InvalidInput
// naming the receiver when the patches would exceed 2^30 leaves in all.
Result<std::vector<TransportPatch>> build_transport_patches(World& world, const IndirectTransport& settings,
                                                            std::vector<std::string>& warnings);

// A link of the hierarchical direct operator: receiver node -> sender node (nodes numbered per
// patch (4^l - 1) / 3 + i + j 2^l) and the mean kernel (form factor) over each quadrant c of the
// receiver node, its child (2i + c % 2, 2j + c / 2); a leaf receiver uses form_factor[0] alone.
struct TransportLink {
  std::uint32_t receiver_node = 0;
  std::uint32_t sender_patch = 0;
  std::uint32_t sender_node = 0;
  std::array<float, 4> form_factor{};
};

// The links of receiver patch `receiver` by the refinement above. Deterministic (jitter from
// `seed` and the nodes' indices). `rays` gets the shadow rays traced. Thread-safe.
std::vector<TransportLink> refine_receiver(const RayScene& scene, const std::vector<TransportPatch>& patches,
                                           std::uint32_t receiver, float threshold, std::uint64_t seed,
                                           std::uint64_t& rays);

// T in the Haar bases from every receiver's links (links[r] those of patch r), receivers in
// parallel on `jobs`. O(links x levels^2 + receiver x linked sender coefficients).
SparseTransport direct_operator(const std::vector<TransportPatch>& patches,
                                const std::vector<std::vector<TransportLink>>& links, JobContext& jobs);

// The dense baseline (the approach the paper improves on): every leaf-to-leaf link, each evaluated
// with the same 16-ray estimator, projected onto the Haar bases; truncate_transport then keeps its
// largest coefficients. `rays` reports the shadow rays traced. Cost: O(leaves^2) links and
// leaves^2 x 12 bytes; InvalidInput when that would exceed `memory_limit` bytes.
struct DenseTransport {
  std::uint32_t size = 0;
  std::vector<glm::vec3> value;  // value[col * size + row]
  std::uint64_t bytes() const { return value.size() * sizeof(glm::vec3); }
};
Result<DenseTransport> dense_direct_operator(const RayScene& scene, const std::vector<TransportPatch>& patches,
                                             std::uint64_t seed, std::uint64_t memory_limit, JobContext& jobs,
                                             std::uint64_t& rays);
// The `keep` largest coefficients of `dense` (by max channel; ties at the cut all kept; 0: every
// nonzero one) as a sparse operator. O(size^2).
SparseTransport truncate_transport(const DenseTransport& dense, std::uint64_t keep);

// G = sum_{k=1..K} T^k: P_1 = T, P_{k+1} = T P_k, with coefficients below drop = drop_threshold x
// max|T| dropped from T and from every product, and no single product of two coefficients below
// kProductPrune x drop summed into one; stopping when |P_k|_F <= tolerance |G|_F (converged) or
// after max_terms terms. Cost: each term reads, per coefficient of P_k, the column of T it meets
// down to that cut (on the maze's medium operator, about half of its bake).
// A product left out is below 0.002 of the smallest coefficient a product keeps; the products of
// a column of T by a small coefficient of P_k are most of a term's work, and most fall below it.
inline constexpr float kProductPrune = 0.002f;
struct NeumannResult {
  SparseTransport global;
  std::uint32_t terms = 0;
  float last_term_ratio = 0.0f;
  bool converged = false;
};
Result<NeumannResult> neumann_series(const SparseTransport& direct, float tolerance, std::uint32_t max_terms,
                                     float drop_threshold, std::uint64_t memory_limit, JobContext& jobs);

// The bounce probes' grid (TransportProbes without entries) over the patches' bounds, with half a
// spacing to spare on every side: spacing `spacing` metres (0: kBounceProbeSpacingFraction x the
// bounds' diagonal), raised by steps of 1.25x until the grid has at most kMaxBounceProbes nodes. No
// patches or no finite size: an empty grid. O(patches).
TransportProbes bounce_probe_grid(const std::vector<TransportPatch>& patches, float spacing);

// What the bounce probes' rays look for: the patches, each receiver's patches by its entity index
// (TransportPatch::key is the entity's key) and each patch's first cell
// (bounce_probe_cell_offsets). Views `patches`, which must outlive it. O(entities + patches).
struct BounceProbeTargets {
  std::span<const TransportPatch> patches;
  std::unordered_map<std::uint32_t, std::vector<std::uint32_t>> patches_of;
  std::vector<std::uint32_t> first_cell;
};
BounceProbeTargets bounce_probe_targets(World& world, std::span<const TransportPatch> patches);

// What one bounce probe saw: `rays` directions (scrambled Sobol points on the sphere, from `seed`
// and the node's index) traced from `at` through `scene`; each hit on the front of a patch (found
// among the hit entity's patches) adds to that patch cell's weights (TransportProbes), hits on the
// back of single-sided surfaces count as inside a solid. Entries in cell order. Its reach: one ray
// along each axis direction, up to `spacing`. Thread-safe, deterministic.
struct BounceProbeSight {
  bool open = true;
  std::array<float, 6> reach{};
  std::vector<BounceProbeEntry> entries;
};
BounceProbeSight trace_bounce_probe(const RayScene& scene, const BounceProbeTargets& targets, glm::vec3 at,
                                    float spacing, std::uint32_t rays, std::uint64_t seed, std::uint64_t node);

// Adds the "indirect-transport" baker to world.resource<BakerRegistry>() (penumbra/bake/baker.h).
void register_indirect_transport_baker(World& world);

}  // namespace penumbra
