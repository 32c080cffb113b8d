// Least-squares node values for the probe grid's fitted mode (internal to the probe_grid module;
// the public entry is bake_probe_grid with ProbeSampling::Fitted).
//
// Kontkanen & Laine 2006 set each node to the tent-weighted average of the lighting over its
// support in the domain of interest. That average is a quasi-interpolant: where the lighting jumps
// (a thin wall between a lit and a shadowed side) it blurs the jump over two cells, so receivers
// next to the wall still see the other side. The runtime reconstruction is f(x) = sum_i c_i B_i(x)
// (trilinear tents), so the better-founded choice is the c that minimises the reconstruction error
// itself over the domain of interest D:
//
//   min_c  sum_s w_s (sum_i c_i B_i(y_s) - L(y_s))^2  +  lambda sum_i (c_i - a_i)^2
//
// (with the leak guard, B_i(y_s) is the basis at the sample's lookup fraction, the reconstruction
// the runtime actually performs),
// over sample points y_s in D (the supersampled mode's own tent samples), one column per SH
// coefficient and colour channel, a_i the supersampled average. The normal equations
// (G + lambda I) c = B^T L + lambda a share one sparse SPD matrix G = sum_s w_s B(y_s) B(y_s)^T
// with a 27-point stencil, solved by Jacobi-preconditioned conjugate gradients warm-started at a.
//
// Weights: node i draws S points from its tent pdf B_i (grid units, integral 1), folded into the
// box on a boundary node's outer side (probe_baker.cpp), so the union of all nodes' samples has
// the density S prod_a (1 + B_first(u_a) + B_last(u_a)): S in the interior (the tents are a
// partition of unity), up to 2S per axis in the boundary cells, where the folded halves land.
// probe_fit_weight() is its inverse relative to the interior, so sum_s w_s (...)^2 estimates the
// uniform measure over D inside the box up to a constant; samples outside the box are dropped
// (receivers are clamped into it).
// Regularisation: lambda = mu S (2/3)^3, mu times the diagonal of a node whose whole support is in
// D ((2/3)^3 = integral of B_i^2). It keeps nodes with little or no in-domain support well posed
// (a node with none gets exactly its target a_i) and limits the fit's noise: the eigenvalues of G
// run from S (smooth modes) down to S / 27 (the node checkerboard, which the samples' Monte Carlo
// noise drives); mu = 0.1 puts lambda near S / 27, halving that mode while leaving smooth ones
// nearly pure least squares. (On the probe-grid bench mu from 0.03 to 0.3 changes the RMSE by a
// few percent; below 0.1 the furnace test's corner nodes go noisy.)
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>

#include <glm/vec3.hpp>

#include "penumbra/core/jobs.h"
#include "penumbra/core/result.h"

namespace penumbra {

struct ProbeFitSettings {
  float regularization = 0.1f;    // mu above: weight of the pull towards the targets
  float tolerance = 1e-4f;        // stop a column at ||r||_M < tolerance x ||b||_M (M: Jacobi)
  std::uint32_t max_iterations = 100;
};

struct ProbeFitInput {
  glm::uvec3 resolution{2u};
  std::uint32_t samples_per_node = 0;  // S
  std::size_t columns = 0;             // values per sample and per node (SH coefficients x 3)
  // Sample k of node n is index n * S + k: its position in grid units (node (i, j, k) at (i, j, k)),
  // whether it is in the domain of interest, and its `columns` values at (n * S + k) * columns.
  std::span<const glm::vec3> positions;
  std::span<const std::uint8_t> in_domain;
  std::span<const float> values;
  // Leak guard (probe_grid.h): sample s's lookup fraction in its cell (probe_fit_cell), where the
  // runtime evaluates the trilinear basis for it (probe_lookup_fraction). Empty: the sample's own
  // fraction, the plain trilinear basis.
  std::span<const glm::vec3> lookup;
};

// The cell (its lowest node) that holds grid point u inside the box: floor(u) clamped so the
// cell's far nodes exist. Cost: O(1). Thread-safe.
glm::uvec3 probe_fit_cell(glm::vec3 u, glm::uvec3 res);

struct ProbeFitReport {
  std::uint32_t iterations = 0;   // CG iterations run (the most over the columns)
  double worst_residual = 0.0;    // largest final ||r||_M / ||b||_M over the columns
};

// Weight w_s of a sample at grid point u (inside the box) of a grid with `res` nodes per axis:
// prod_a 1 / (1 + B_first(u_a) + B_last(u_a)), 1 in interior cells. Cost: O(1). Thread-safe.
double probe_fit_weight(glm::vec3 u, glm::uvec3 res);

// Bytes the fit allocates for `nodes` nodes and `columns` columns (stencil matrix, CG vectors).
std::uint64_t probe_fit_bytes(std::size_t nodes, std::size_t columns);

// Solves the fit. `nodes` holds the targets a (nodes x columns, node-major) on entry and the
// fitted values on return. Runs one "probe fit" progress stage; fails with Cancelled when the host
// cancels. Deterministic: rows are independent and every reduction is summed over fixed blocks in
// a fixed order, so the result is bit-identical at any thread count. Cost: 27 x samples x columns
// to assemble, 27 x nodes x columns per iteration.
Result<ProbeFitReport> fit_probe_nodes(const ProbeFitInput& input, std::span<float> nodes,
                                       const ProbeFitSettings& settings, JobContext& jobs);

}  // namespace penumbra
