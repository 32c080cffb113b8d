// The per-texel fits on synthetic data: exact recovery of the model, the sphere's closed-form
// solid angle, data whose linear fit crosses zero (the clamp), empty data, and C0 of crossing lines.
#include "ao_fit.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <numbers>
#include <vector>

#include <glm/geometric.hpp>

namespace penumbra {
namespace {

constexpr double kPi = std::numbers::pi;

std::vector<AORadialSample> samples_of(double lo, double hi, int count, double (*omega)(double)) {
  std::vector<AORadialSample> out;
  for (int k = 0; k < count; ++k) {
    const double rho = lo * std::pow(hi / lo, double(k) / double(count - 1));
    out.push_back({rho, omega(rho), glm::dvec3(-1, 0, 0)});
  }
  return out;
}

TEST(AOFit, RecoversTheModelExactly) {
  const auto s = samples_of(1.0, 6.0, 24, [](double r) { return 1.0 / (0.3 * r * r + 0.2 * r - 0.1); });
  AOOmegaFit p{};
  EXPECT_FALSE(fit_ao_omega(s, 1.0, 6.0, p));
  EXPECT_NEAR(p[0], 0.3, 1e-6);
  EXPECT_NEAR(p[1], 0.2, 1e-6);
  EXPECT_NEAR(p[2], -0.1, 1e-6);
}

TEST(AOFit, SphereSolidAngleCloseToTheClosedForm) {
  // A unit sphere seen from distance rho subtends 2 pi (1 - sqrt(1 - 1 / rho^2)).
  const auto omega = [](double r) { return 2.0 * kPi * (1.0 - std::sqrt(1.0 - 1.0 / (r * r))); };
  const auto s = samples_of(1.001, 6.0, 32, omega);
  AOOmegaFit p{};
  EXPECT_FALSE(fit_ao_omega(s, 1.001, 6.0, p));
  EXPECT_TRUE(ao_denominator_positive(p, 1.001, 6.0));
  double near = 0.0, rest = 0.0;
  for (double r = 1.001; r <= 6.0; r += 0.01) {
    const double e = std::abs(1.0 / ((p[0] * r + p[1]) * r + p[2]) - omega(r));
    (r < 1.1 ? near : rest) = std::max(r < 1.1 ? near : rest, e);
  }
  std::printf("sphere fit: max |error| %.4f sr for rho < 1.1, %.4f sr beyond\n", near, rest);
  // The model has no square-root edge at the hull, so the error there is largest.
  EXPECT_LT(near, 0.05 * 2.0 * kPi);  // measured 0.296 sr
  EXPECT_LT(rest, 0.03 * 2.0 * kPi);  // measured 0.157 sr (2.5% of 2 pi)
}

TEST(AOFit, ALinearFitThatCrossesZeroFallsBackToTheClamp) {
  // |1 / D| for a D that changes sign inside [0.5, 6]: no positive model fits, the clamp must.
  const auto s = samples_of(0.5, 6.0, 24, [](double r) { return std::abs(1.0 / (-(r - 1.0) * (r - 5.0) + 0.05)); });
  AOOmegaFit p{};
  EXPECT_TRUE(fit_ao_omega(s, 0.5, 6.0, p));
  EXPECT_TRUE(ao_denominator_positive(p, 0.5, 6.0));
  EXPECT_GE(p[0], 0.0);
  EXPECT_GE(p[2], 0.0);
}

TEST(AOFit, EmptyAndSparseData) {
  std::vector<AORadialSample> none = samples_of(1.0, 6.0, 8, [](double) { return 0.0; });
  AOOmegaFit p{};
  EXPECT_TRUE(fit_ao_omega(none, 1.0, 6.0, p));
  EXPECT_LT(1.0 / ((p[0] * 2.0 + p[1]) * 2.0 + p[2]), 1e-20);
  EXPECT_EQ(fit_ao_c0(none, glm::dvec3(1, 0, 0), 1.0), glm::dvec3(0.0));
  // Only two radii see the caster: too few for three coefficients; still positive.
  std::vector<AORadialSample> two = none;
  two[0].omega = 3.0;
  two[1].omega = 2.0;
  EXPECT_TRUE(fit_ao_omega(two, 1.0, 6.0, p));
  EXPECT_TRUE(ao_denominator_positive(p, 1.0, 6.0));
}

TEST(AOFit, C0IsWhereTheLinesCross) {
  // Lines from rho_k w towards a point P: C0 = P, up to the 5% pull towards the origin.
  const glm::dvec3 w(1, 0, 0), target(0.2, 0.5, -0.3);
  std::vector<AORadialSample> s;
  for (int k = 0; k < 16; ++k) {
    const double rho = 1.0 + 0.3 * k;
    s.push_back({rho, 1.0, glm::normalize(target - rho * w)});
  }
  EXPECT_LT(glm::distance(fit_ao_c0(s, w, 1.0), target), 0.06);  // measured 0.049: the pull
  // Parallel lines (a sphere: every Upsilon is -w): C0 stays behind the hull along w.
  for (auto& x : s) x.upsilon = -w;
  s[3].upsilon = glm::normalize(glm::dvec3(-1, 1e-3, 0));  // noise
  const glm::dvec3 c0 = fit_ao_c0(s, w, 1.0);
  EXPECT_LE(glm::dot(c0, w), 0.5 + 1e-12);
  for (const auto& x : s) EXPECT_LT(glm::dot(glm::normalize(c0 - x.rho * w), w), -0.9);
}

}  // namespace
}  // namespace penumbra
