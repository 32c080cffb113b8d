// Least-squares probe node values (see probe_fit.h): assembly of the 27-point normal matrix and
// Jacobi-preconditioned conjugate gradients (Hestenes & Stiefel 1952; Saad, "Iterative Methods for
// Sparse Linear Systems", 2nd ed., algorithm 9.1), several right-hand sides sharing the matrix.
#include "probe_fit.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <functional>
#include <vector>

namespace penumbra {

namespace {

constexpr std::size_t kStencil = 27;  // (dx, dy, dz) in {-1, 0, 1}^3 -> (dz + 1) 9 + (dy + 1) 3 + dx + 1
constexpr std::size_t kCentre = 13;
constexpr std::size_t kBlock = 256;   // rows per parallel chunk and per partial sum (fixed: determinism)

struct Grid {
  glm::ivec3 res;
  std::size_t index(glm::ivec3 q) const {
    return (static_cast<std::size_t>(q.z) * static_cast<std::size_t>(res.y) + static_cast<std::size_t>(q.y)) *
               static_cast<std::size_t>(res.x) +
           static_cast<std::size_t>(q.x);
  }
  glm::ivec3 node(std::size_t n) const {
    const std::size_t rx = static_cast<std::size_t>(res.x), ry = static_cast<std::size_t>(res.y);
    return glm::ivec3(static_cast<int>(n % rx), static_cast<int>((n / rx) % ry), static_cast<int>(n / (rx * ry)));
  }
  bool contains(glm::ivec3 q) const {
    return q.x >= 0 && q.y >= 0 && q.z >= 0 && q.x < res.x && q.y < res.y && q.z < res.z;
  }
};

std::size_t stencil_index(glm::ivec3 d) {
  return static_cast<std::size_t>((d.z + 1) * 9 + (d.y + 1) * 3 + (d.x + 1));
}

// The cell holding grid point u (inside the box) and its eight trilinear weights, corner
// o = (bit 0, bit 1, bit 2) of the corner index.
struct Cell {
  glm::ivec3 base;
  std::array<double, 8> weight;
};

// `lookup` (the leak guard's fraction in that cell), when given, replaces u's own fraction.
Cell cell_of(glm::vec3 u, const Grid& g, const glm::vec3* lookup) {
  Cell c;
  c.base = glm::ivec3(probe_fit_cell(u, glm::uvec3(g.res)));
  glm::dvec3 f = lookup ? glm::dvec3(*lookup) : glm::dvec3(u) - glm::dvec3(c.base);
  for (int k = 0; k < 8; ++k)
    c.weight[static_cast<std::size_t>(k)] =
        ((k & 1) ? f.x : 1.0 - f.x) * ((k & 2) ? f.y : 1.0 - f.y) * ((k & 4) ? f.z : 1.0 - f.z);
  return c;
}

bool inside_box(glm::vec3 u, const Grid& g) {
  for (int a = 0; a < 3; ++a)
    if (!(u[a] >= 0.0f && u[a] <= static_cast<float>(g.res[a] - 1))) return false;  // also rejects NaN
  return true;
}

// y = A x for the rows of one block, A = G (stencil, regulariser on the diagonal).
void multiply_rows(const Grid& g, const std::vector<double>& stencil, std::size_t columns, const std::vector<double>& x,
                   std::vector<double>& y, std::size_t begin, std::size_t end) {
  for (std::size_t n = begin; n < end; ++n) {
    double* out = &y[n * columns];
    std::fill(out, out + columns, 0.0);
    const glm::ivec3 p = g.node(n);
    for (std::size_t s = 0; s < kStencil; ++s) {
      const double a = stencil[n * kStencil + s];
      if (a == 0.0) continue;
      const glm::ivec3 d(static_cast<int>(s % 3) - 1, static_cast<int>((s / 3) % 3) - 1, static_cast<int>(s / 9) - 1);
      const double* in = &x[g.index(p + d) * columns];
      for (std::size_t k = 0; k < columns; ++k) out[k] += a * in[k];
    }
  }
}

}  // namespace

glm::uvec3 probe_fit_cell(glm::vec3 u, glm::uvec3 res) {
  glm::uvec3 base;
  for (int a = 0; a < 3; ++a)
    base[a] = static_cast<unsigned>(std::clamp(static_cast<int>(std::floor(u[a])), 0, static_cast<int>(res[a]) - 2));
  return base;
}

double probe_fit_weight(glm::vec3 u, glm::uvec3 res) {
  double w = 1.0;
  for (int a = 0; a < 3; ++a) {
    const double x = static_cast<double>(u[a]), last = static_cast<double>(res[a] - 1u);
    w /= 1.0 + std::max(0.0, 1.0 - x) + std::max(0.0, 1.0 - (last - x));
  }
  return w;
}

std::uint64_t probe_fit_bytes(std::size_t nodes, std::size_t columns) {
  // Stencil + diagonal, five CG vectors (x, r, z, p, q), block partial sums.
  const std::uint64_t n = nodes;
  return n * (kStencil + 1) * sizeof(double) + 5 * n * columns * sizeof(double) +
         ((n + kBlock - 1) / kBlock) * columns * sizeof(double);
}

Result<ProbeFitReport> fit_probe_nodes(const ProbeFitInput& input, std::span<float> nodes,
                                       const ProbeFitSettings& settings, JobContext& jobs) {
  const Grid g{glm::ivec3(input.resolution)};
  const std::size_t count = static_cast<std::size_t>(g.res.x) * static_cast<std::size_t>(g.res.y) *
                            static_cast<std::size_t>(g.res.z);
  const std::size_t S = input.samples_per_node, K = input.columns;
  const std::size_t blocks = (count + kBlock - 1) / kBlock;
  const std::uint64_t units = std::uint64_t{count} * (2 + 3 * std::uint64_t{settings.max_iterations});
  std::uint64_t done = 0;
  jobs.begin_stage("probe fit", units);
  const auto run = [&](const std::function<void(std::size_t, std::size_t)>& fn) {
    done += count;
    return jobs.parallel_for(count, kBlock, fn);
  };

  // Step 1: assemble G (27-point stencil per row) and the right-hand sides B^T L, row by row.
  // Row n sums the samples of its 27 neighbours in ascending node order, the only samples that
  // can fall in its support; G[n][m] and G[m][n] add the same products in the same order, so G is
  // exactly symmetric.
  std::vector<double> stencil(count * kStencil, 0.0), diagonal(count, 0.0);
  std::vector<double> x(count * K), r(count * K, 0.0), z(count * K), p(count * K), q(count * K);
  const double lambda = static_cast<double>(settings.regularization) * static_cast<double>(S) * (8.0 / 27.0);
  Status st = run([&](std::size_t begin, std::size_t end) {
    for (std::size_t n = begin; n < end; ++n) {
      const glm::ivec3 self = g.node(n);
      double* row = &stencil[n * kStencil];
      double* rhs = &r[n * K];  // r holds b until step 2
      for (int dz = -1; dz <= 1; ++dz)
        for (int dy = -1; dy <= 1; ++dy)
          for (int dx = -1; dx <= 1; ++dx) {
            const glm::ivec3 m = self + glm::ivec3(dx, dy, dz);
            if (!g.contains(m)) continue;
            const std::size_t first = g.index(m) * S;
            for (std::size_t s = first; s < first + S; ++s) {
              if (!input.in_domain[s] || !inside_box(input.positions[s], g)) continue;
              const Cell c = cell_of(input.positions[s], g, input.lookup.empty() ? nullptr : &input.lookup[s]);
              const glm::ivec3 o = self - c.base;
              if (o.x < 0 || o.y < 0 || o.z < 0 || o.x > 1 || o.y > 1 || o.z > 1) continue;
              const double bn = c.weight[static_cast<std::size_t>(o.x | (o.y << 1) | (o.z << 2))];
              if (bn == 0.0) continue;
              // w (B_n B_m): the same product for G[n][m] and G[m][n] (exact symmetry).
              const double w = probe_fit_weight(input.positions[s], input.resolution);
              for (int k = 0; k < 8; ++k) {
                const glm::ivec3 j = c.base + glm::ivec3(k & 1, (k >> 1) & 1, (k >> 2) & 1);
                row[stencil_index(j - self)] += w * (bn * c.weight[static_cast<std::size_t>(k)]);
              }
              const float* v = &input.values[s * K];
              for (std::size_t k = 0; k < K; ++k) rhs[k] += w * bn * static_cast<double>(v[k]);
            }
          }
      // Tikhonov pull towards the targets: lambda on the diagonal, lambda a on the right.
      row[kCentre] += lambda;
      diagonal[n] = row[kCentre];
      for (std::size_t k = 0; k < K; ++k) {
        x[n * K + k] = static_cast<double>(nodes[n * K + k]);
        rhs[k] += lambda * x[n * K + k];
      }
    }
  });
  if (!st) return st.error();

  // Step 2: initial residual r = b - A x at the warm start x = a, z = M^-1 r, p = z; per column
  // ||b||_M^2 (the convergence scale) and r.z, summed per block, then over blocks in order.
  std::vector<double> partial(blocks * K * 2, 0.0);
  st = run([&](std::size_t begin, std::size_t end) {
    multiply_rows(g, stencil, K, x, q, begin, end);
    double* bb = &partial[(begin / kBlock) * K * 2];
    double* rz = bb + K;
    for (std::size_t n = begin; n < end; ++n)
      for (std::size_t k = 0; k < K; ++k) {
        const std::size_t i = n * K + k;
        bb[k] += r[i] * r[i] / diagonal[n];
        r[i] -= q[i];
        z[i] = r[i] / diagonal[n];
        p[i] = z[i];
        rz[k] += r[i] * z[i];
      }
  });
  if (!st) return st.error();
  std::vector<double> scale(K, 0.0), rz(K, 0.0), alpha(K, 0.0), beta(K, 0.0);
  for (std::size_t b = 0; b < blocks; ++b)
    for (std::size_t k = 0; k < K; ++k) {
      scale[k] += partial[b * K * 2 + k];
      rz[k] += partial[b * K * 2 + K + k];
    }
  const double tol2 = static_cast<double>(settings.tolerance) * static_cast<double>(settings.tolerance);
  std::vector<std::uint8_t> active(K);
  for (std::size_t k = 0; k < K; ++k) active[k] = rz[k] > tol2 * scale[k] ? 1 : 0;

  // Step 3: CG iterations, every column advancing with its own alpha, beta until it converges.
  ProbeFitReport report;
  for (std::uint32_t it = 0; it < settings.max_iterations; ++it) {
    if (std::none_of(active.begin(), active.end(), [](std::uint8_t a) { return a != 0; })) break;
    if (jobs.cancelled()) return make_error(ErrorCode::Cancelled, "cancelled by the host during stage 'probe fit'");
    ++report.iterations;
    // q = A p and p.q.
    std::fill(partial.begin(), partial.end(), 0.0);
    st = run([&](std::size_t begin, std::size_t end) {
      multiply_rows(g, stencil, K, p, q, begin, end);
      double* pq = &partial[(begin / kBlock) * K * 2];
      for (std::size_t n = begin; n < end; ++n)
        for (std::size_t k = 0; k < K; ++k) pq[k] += p[n * K + k] * q[n * K + k];
    });
    if (!st) return st.error();
    for (std::size_t k = 0; k < K; ++k) {
      double pq = 0.0;
      for (std::size_t b = 0; b < blocks; ++b) pq += partial[b * K * 2 + k];
      if (!(pq > 0.0)) active[k] = 0;  // p = 0: the column is solved exactly
      alpha[k] = active[k] ? rz[k] / pq : 0.0;
    }
    // x += alpha p, r -= alpha q, z = M^-1 r and the new r.z.
    std::fill(partial.begin(), partial.end(), 0.0);
    st = run([&](std::size_t begin, std::size_t end) {
      double* rz_new = &partial[(begin / kBlock) * K * 2];
      for (std::size_t n = begin; n < end; ++n)
        for (std::size_t k = 0; k < K; ++k) {
          if (!active[k]) continue;
          const std::size_t i = n * K + k;
          x[i] += alpha[k] * p[i];
          r[i] -= alpha[k] * q[i];
          z[i] = r[i] / diagonal[n];
          rz_new[k] += r[i] * z[i];
        }
    });
    if (!st) return st.error();
    for (std::size_t k = 0; k < K; ++k) {
      if (!active[k]) continue;
      double next = 0.0;
      for (std::size_t b = 0; b < blocks; ++b) next += partial[b * K * 2 + k];
      beta[k] = next / rz[k];
      rz[k] = next;
      if (next <= tol2 * scale[k]) active[k] = 0;
    }
    // p = z + beta p.
    st = run([&](std::size_t begin, std::size_t end) {
      for (std::size_t n = begin; n < end; ++n)
        for (std::size_t k = 0; k < K; ++k)
          if (active[k]) p[n * K + k] = z[n * K + k] + beta[k] * p[n * K + k];
    });
    if (!st) return st.error();
  }
  jobs.advance(units - std::min(units, done));  // close the stage when CG stopped early

  for (std::size_t k = 0; k < K; ++k)
    if (scale[k] > 0.0) report.worst_residual = std::max(report.worst_residual, std::sqrt(std::max(0.0, rz[k]) / scale[k]));
  for (std::size_t i = 0; i < count * K; ++i) nodes[i] = static_cast<float>(x[i]);
  return report;
}

}  // namespace penumbra
