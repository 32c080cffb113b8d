// Internal to the ao_field module: the per-texel fits of the bake (ao_field_baker.h, steps 3 and
// 4), separate so that they can be tested on synthetic data. All lengths are in units of the
// caster's bounding radius (rho = r / R), which keeps the normal equations well conditioned at any
// mesh scale.
#pragma once

#include <array>
#include <vector>

#include <glm/vec3.hpp>

namespace penumbra {

// One sampled radius of a texel: rho, the measured solid angle and the unit average occluded
// direction (any unit vector when omega is 0).
struct AORadialSample {
  double rho = 0.0;
  double omega = 0.0;
  glm::dvec3 upsilon{0.0};
};

// a, b, c of the denominator D(rho) = a rho^2 + b rho + c.
using AOOmegaFit = std::array<double, 3>;

// The denominator of the empty fit (a direction that never sees the caster): Omega ~ 1e-30.
inline constexpr double kAOEmptyDenominator = 1e30;

// The smallest denominator a fit may take: Omega = 1 / D never exceeds the whole sphere, 4 pi.
// (A bare D > 0 could round to 0 or below in the runtime's floats.)
inline constexpr double kAOMinDenominator = 0.25 / 3.14159265358979323846;

// True when the coefficients are finite and D >= kAOMinDenominator on all of [lo, hi] (both ends
// and the vertex of the parabola when it lies inside). O(1).
bool ao_denominator_positive(const AOOmegaFit& p, double lo, double hi);

// Fits Omega(rho) = 1 / D(rho) on [lo, hi]: linear least squares on D(rho_k) Omega_k = 1, then up
// to 30 Levenberg-Marquardt steps on sum (1 / D - Omega_k)^2 accepted only when D stays positive
// on [lo, hi]. When the linear fit is not positive there (or has fewer than 3 samples that see the
// caster), starts instead from the clamp: D = a rho^2 + c with a, c >= 0 (the 2x2 least squares,
// or the better single term), and returns true. No sample with omega > 0: the empty fit, true.
// The result is always at least kAOMinDenominator on [lo, hi]. Deterministic; cost O(samples x 30 x 8).
bool fit_ao_omega(const std::vector<AORadialSample>& samples, double lo, double hi, AOOmegaFit& p);

// C0 for direction w (unit): the point nearest, in least squares weighted by omega_k, to the lines
// through rho_k w along upsilon_k, with a pull of 5% of the weight towards the origin (the origin
// is inside the hull; the pull settles what nearly parallel lines leave open); then its component
// along w is limited to 0.5 rho0, so that C0 - rho w points towards the caster for rho >= rho0.
// Zero when no sample sees the caster. O(samples).
glm::dvec3 fit_ao_c0(const std::vector<AORadialSample>& samples, glm::dvec3 w, double rho0);

}  // namespace penumbra
