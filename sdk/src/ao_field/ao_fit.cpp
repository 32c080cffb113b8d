// The per-texel fits of the ao-field bake (see ao_fit.h): Kontkanen & Laine 2005, section 3.1
// (least-squares fit of the solid-angle model with a positive denominator, and of C0).
#include "ao_fit.h"

#include <algorithm>
#include <cmath>

#include <glm/geometric.hpp>

namespace penumbra {

namespace {

constexpr int kFitIterations = 30;
constexpr double kC0Pull = 0.05;     // relative weight of the pull of C0 towards the origin
constexpr double kC0MaxAlong = 0.5;  // C0 . w at most this fraction of rho0

// Solves the 3x3 system m x = rhs by Gaussian elimination with partial pivoting; false when singular.
bool solve3(std::array<std::array<double, 3>, 3> m, std::array<double, 3> rhs, std::array<double, 3>& x) {
  for (int col = 0; col < 3; ++col) {
    int pivot = col;
    for (int r = col + 1; r < 3; ++r)
      if (std::abs(m[static_cast<std::size_t>(r)][static_cast<std::size_t>(col)]) >
          std::abs(m[static_cast<std::size_t>(pivot)][static_cast<std::size_t>(col)]))
        pivot = r;
    const auto c = static_cast<std::size_t>(col), p = static_cast<std::size_t>(pivot);
    if (!(std::abs(m[p][c]) > 1e-300)) return false;
    std::swap(m[c], m[p]);
    std::swap(rhs[c], rhs[p]);
    for (std::size_t r = c + 1; r < 3; ++r) {
      const double f = m[r][c] / m[c][c];
      for (std::size_t k = c; k < 3; ++k) m[r][k] -= f * m[c][k];
      rhs[r] -= f * rhs[c];
    }
  }
  for (int r = 2; r >= 0; --r) {
    const auto i = static_cast<std::size_t>(r);
    double v = rhs[i];
    for (std::size_t k = i + 1; k < 3; ++k) v -= m[i][k] * x[k];
    x[i] = v / m[i][i];
    if (!std::isfinite(x[i])) return false;
  }
  return true;
}

double denominator(const AOOmegaFit& p, double rho) { return (p[0] * rho + p[1]) * rho + p[2]; }

}  // namespace

bool ao_denominator_positive(const AOOmegaFit& p, double lo, double hi) {
  if (!(std::isfinite(p[0]) && std::isfinite(p[1]) && std::isfinite(p[2]))) return false;
  if (!(denominator(p, lo) >= kAOMinDenominator) || !(denominator(p, hi) >= kAOMinDenominator)) return false;
  if (p[0] > 0.0) {
    const double v = -p[1] / (2.0 * p[0]);
    if (v > lo && v < hi && !(denominator(p, v) >= kAOMinDenominator)) return false;
  }
  return true;
}

namespace {

double squared_error(const AOOmegaFit& p, const std::vector<AORadialSample>& samples) {
  double e = 0.0;
  for (const AORadialSample& s : samples) {
    const double d = 1.0 / denominator(p, s.rho) - s.omega;
    e += d * d;
  }
  return e;
}

}  // namespace

bool fit_ao_omega(const std::vector<AORadialSample>& samples, double lo, double hi, AOOmegaFit& p) {
  // Linear least squares on D(rho_k) Omega_k = 1 (samples that see the caster).
  std::array<std::array<double, 3>, 3> m{};
  AOOmegaFit rhs{};
  int seen = 0;
  for (const AORadialSample& s : samples) {
    if (!(s.omega > 0.0)) continue;
    ++seen;
    const AOOmegaFit x{s.omega * s.rho * s.rho, s.omega * s.rho, s.omega};
    for (std::size_t i = 0; i < 3; ++i) {
      rhs[i] += x[i];
      for (std::size_t j = 0; j < 3; ++j) m[i][j] += x[i] * x[j];
    }
  }
  if (seen == 0) {
    p = {0.0, 0.0, kAOEmptyDenominator};
    return true;
  }
  bool clamped = false;
  if (seen < 3 || !solve3(m, rhs, p) || !ao_denominator_positive(p, lo, hi)) {
    // The clamp: D = a rho^2 + c with a, c >= 0 (positive wherever one of them is), from the
    // same linear equations: the 2x2 solve when both come out non-negative, else the better of
    // a alone and c alone.
    clamped = true;
    const double saa = m[0][0], sac = m[0][2], scc = m[2][2], ra = rhs[0], rc = rhs[2];
    const double det = saa * scc - sac * sac;
    double a = det > 0.0 ? (ra * scc - rc * sac) / det : -1.0;
    double c = det > 0.0 ? (saa * rc - sac * ra) / det : -1.0;
    if (!(a >= 0.0 && c >= 0.0 && a + c > 0.0)) {
      const double a_only = saa > 0.0 ? ra / saa : 0.0, c_only = scc > 0.0 ? rc / scc : 0.0;
      // Residual sum of (D Omega - 1)^2 of each one-term fit: n - r^2 / s.
      const double err_a = saa > 0.0 ? -ra * ra / saa : 0.0, err_c = scc > 0.0 ? -rc * rc / scc : 0.0;
      a = err_a < err_c ? a_only : 0.0;
      c = err_a < err_c ? 0.0 : c_only;
    }
    // D is smallest at lo: lift c so that the solid angle there stays within the sphere.
    p = {a, 0.0, std::max(c, kAOMinDenominator - a * lo * lo)};
    if (!ao_denominator_positive(p, lo, hi)) {
      p = {0.0, 0.0, kAOEmptyDenominator};
      return true;
    }
  }
  // Levenberg-Marquardt on sum (1 / D - Omega)^2, accepting only steps that keep D positive.
  double error = squared_error(p, samples);
  double lambda = 1e-3;
  for (int it = 0; it < kFitIterations; ++it) {
    std::array<std::array<double, 3>, 3> jtj{};
    AOOmegaFit jte{};
    for (const AORadialSample& s : samples) {
      const double d = denominator(p, s.rho);
      const double e = 1.0 / d - s.omega;
      const double g = -1.0 / (d * d);
      const AOOmegaFit grad{g * s.rho * s.rho, g * s.rho, g};
      for (std::size_t i = 0; i < 3; ++i) {
        jte[i] += grad[i] * e;
        for (std::size_t j = 0; j < 3; ++j) jtj[i][j] += grad[i] * grad[j];
      }
    }
    bool accepted = false;
    for (int attempt = 0; attempt < 8 && !accepted; ++attempt) {
      auto damped = jtj;
      for (std::size_t i = 0; i < 3; ++i) damped[i][i] += lambda * std::max(jtj[i][i], 1e-300);
      AOOmegaFit step{};
      if (solve3(damped, {-jte[0], -jte[1], -jte[2]}, step)) {
        const AOOmegaFit next{p[0] + step[0], p[1] + step[1], p[2] + step[2]};
        if (ao_denominator_positive(next, lo, hi)) {
          const double next_error = squared_error(next, samples);
          if (next_error < error) {
            accepted = true;
            p = next;
            lambda = std::max(lambda * 0.3, 1e-9);
            if (error - next_error < 1e-12 * error) it = kFitIterations;  // converged
            error = next_error;
            continue;
          }
        }
      }
      lambda *= 10.0;
    }
    if (!accepted) break;
  }
  return clamped;
}

glm::dvec3 fit_ao_c0(const std::vector<AORadialSample>& samples, glm::dvec3 w, double rho0) {
  std::array<std::array<double, 3>, 3> m{};
  AOOmegaFit rhs{};
  double total = 0.0;
  for (const AORadialSample& s : samples) {
    if (!(s.omega > 0.0)) continue;
    total += s.omega;
    const glm::dvec3 pk = s.rho * w;
    for (std::size_t i = 0; i < 3; ++i) {
      for (std::size_t j = 0; j < 3; ++j) {
        const double proj = (i == j ? 1.0 : 0.0) - s.upsilon[static_cast<int>(i)] * s.upsilon[static_cast<int>(j)];
        m[i][j] += s.omega * proj;
        rhs[i] += s.omega * proj * pk[static_cast<int>(j)];
      }
    }
  }
  if (total == 0.0) return glm::dvec3(0.0);
  for (std::size_t i = 0; i < 3; ++i) m[i][i] += kC0Pull * total;
  AOOmegaFit x{};
  if (!solve3(m, rhs, x)) return glm::dvec3(0.0);
  glm::dvec3 c0(x[0], x[1], x[2]);
  // Keep C0 behind the hull as seen along w, so that C0 - r w points towards the caster for every
  // r >= r0 (nearly parallel lines leave the position along w to the noise).
  const double along = glm::dot(c0, w);
  if (along > kC0MaxAlong * rho0) c0 -= (along - kC0MaxAlong * rho0) * w;
  return c0;
}


}  // namespace penumbra
