// The probe-grid baker: per node irradiance SH by point sampling or by the supersampling of
// Kontkanen & Laine 2006 (section 3.2 of the thesis), with the domain of interest, validity and
// fill of invalid nodes, and the baker's registration (the PRBG chunk: probe_grid.h).
//
// Incident radiance at a sample point y (the estimator, documented once here):
//   - lights (directional, point, spot, rect) by next-event estimation from y: each unoccluded
//     light adds its irradiance-at-normal-incidence times Y(l) (a delta in direction l; rect
//     lights by a scrambled Sobol' net over the rect), so direct light is exact in direction;
//   - every other direction by `rays_per_sample` stratified rays over the sphere: a ray hitting a
//     surface brings its emission (front side, or both when double sided) plus albedo / pi times
//     the surface's irradiance, estimated with `hit_samples` paths of the bake integrator
//     (irradiance() with bounces - 1 bounces; none when bounces == 0); a ray leaving the scene
//     brings nothing (the SDK has no sky).
//   - LightingContent::Indirect drops the lights at y and the emission of the hits, keeping
//     albedo / pi x irradiance at each hit: the light that reflected at least once.
// The radiance expansion is the Monte Carlo projection of these samples; the node keeps its
// cosine convolution (irradiance). Point mode does this once at the node with all the node's rays;
// supersampled mode draws S points from the node's tent B_i (per axis y = x_i + h (xi1 + xi2 - 1),
// xi from a scrambled Sobol' net), drops the points outside the domain of interest, and averages.
// Nodes with no in-domain point are filled by iterative dilation from valid neighbours (they
// cannot influence an in-domain receiver anyway). Fitted mode draws its points from tents folded
// into the grid's box on boundary nodes (the fit measures the error only where receivers are, so
// no ray is spent outside the box), keeps every in-domain point of every node and solves for the
// node values that minimise the squared reconstruction error over them (least squares, weighted
// to the uniform measure, pulled towards the nodes' averages where support is thin; probe_fit.h).
#pragma once

#include <cstdint>
#include <span>
#include <string_view>

#include "penumbra/bake/integrators.h"
#include "penumbra/core/pbake.h"
#include "penumbra/bake/ray_scene.h"
#include "penumbra/core/jobs.h"
#include "penumbra/core/memory.h"
#include "penumbra/ecs/world.h"
#include "penumbra/probe_grid/probe_grid.h"

namespace penumbra {

// Bakes one grid. Validates it first (probe_grid_layout), reserves the node arrays in `budget`
// before allocating (OutOfBudget names the grid and suggests a larger spacing), traces each node's
// reach first when the leak guard is on (6 rays per node), and reports three progress stages,
// "probe samples", "probe fill" and "probe fit" (empty unless Fitted). Node n
// draws from Rng::stream(seed, n) and the fit sums in a fixed order: bit-identical results at any
// thread count. Fails with Cancelled when the host cancels, and with
// InvalidInput when no node has an in-domain sample (every probe is inside geometry; the message
// says to move or enlarge the grid). Cost: nodes x S x rays_per_sample x (1 + hit cost) rays;
// Fitted adds at most 100 sparse iterations (27 x nodes x coefficients x 3 each) and keeps
// nodes x S x (coefficients x 12 + 13) bytes of samples.
// Thread-safe for distinct `jobs`.
Result<ProbeGridData> bake_probe_grid(const IrradianceProbeGrid& grid, const glm::mat4& world_matrix,
                                      const RayScene& scene, std::span<const WorldLight> lights, std::uint64_t seed,
                                      JobContext& jobs, MemoryBudget& budget, std::string_view context = "probe grid");

// Registers the "probe-grid" baker: one PRBG chunk per IrradianceProbeGrid entity with a
// WorldTransform, in entity order, keyed by its entity key; the baked data is also attached to the
// components.
void register_probe_grid_baker(World& world);

}  // namespace penumbra
