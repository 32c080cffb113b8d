// The spherical-cap closed form against numerical integration, settings validation, the cube-map
// parameterisation and the combination rule.
#include "penumbra/ao_field/ao_field.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <numbers>
#include <vector>

#include <glm/geometric.hpp>
#include <glm/gtc/matrix_transform.hpp>

#include "penumbra/core/random.h"

namespace penumbra {
namespace {

constexpr double kPi = std::numbers::pi;

double adaptive_simpson(const std::function<double(double)>& f, double a, double b, double fa, double fm, double fb,
                        double whole, double eps, int depth) {
  const double m = 0.5 * (a + b), lm = 0.5 * (a + m), rm = 0.5 * (m + b);
  const double flm = f(lm), frm = f(rm);
  const double left = (m - a) / 6.0 * (fa + 4.0 * flm + fm), right = (b - m) / 6.0 * (fm + 4.0 * frm + fb);
  if (depth <= 0 || std::abs(left + right - whole) <= 15.0 * eps) return left + right + (left + right - whole) / 15.0;
  return adaptive_simpson(f, a, m, fa, flm, fm, left, 0.5 * eps, depth - 1) +
         adaptive_simpson(f, m, b, fm, frm, fb, right, 0.5 * eps, depth - 1);
}

// (1/pi) * integral over the cap of max(0, n.w) dw by quadrature, independent of the closed form:
// with u = sin^2(theta) (theta the angle to n), cos(theta) sin(theta) dtheta = du / 2, and for each
// theta the cap covers the azimuths where cos(theta) cos(beta) + sin(theta) sin(beta) cos(phi) >=
// cos(alpha), a measure m(theta) in closed form. So A = (1 / 2pi) * integral_0^1 m du.
double cap_occlusion_quadrature(double omega, double beta) {
  const double cos_alpha = 1.0 - omega / (2.0 * kPi);
  const double cb = std::cos(beta), sb = std::sin(beta);
  const auto m = [&](double u) {
    const double st = std::sqrt(u), ct = std::sqrt(1.0 - u);
    const double lhs = cos_alpha - ct * cb;  // need st * sb * cos(phi) >= lhs
    const double k = st * sb;
    if (k <= 1e-300) return lhs <= 0.0 ? 2.0 * kPi : 0.0;
    const double c = lhs / k;
    if (c >= 1.0) return 0.0;
    if (c <= -1.0) return 2.0 * kPi;
    return 2.0 * std::acos(c);
  };
  const double fa = m(0.0), fm = m(0.5), fb = m(1.0);
  const double whole = (fa + 4.0 * fm + fb) / 6.0;
  return adaptive_simpson(m, 0.0, 1.0, fa, fm, fb, whole, 1e-10, 40) / (2.0 * kPi);
}

TEST(CapOcclusion, MatchesNumericalIntegration) {
  double worst = 0.0;
  int cases = 0;
  for (int i = 0; i <= 24; ++i) {
    const double omega = 4.0 * kPi * i / 24.0;  // includes 0, 2 pi and 4 pi
    for (int j = 0; j <= 36; ++j) {
      const double beta = kPi * j / 36.0;
      const double expected = cap_occlusion_quadrature(omega, beta);
      const double got = cap_occlusion(static_cast<float>(omega), static_cast<float>(std::cos(beta)));
      worst = std::max(worst, std::abs(got - expected));
      EXPECT_NEAR(got, expected, 1e-5) << "omega " << omega << " beta " << beta;
      ++cases;
    }
  }
  EXPECT_EQ(cases, 25 * 37);
  RecordProperty("max_abs_error", std::to_string(worst));
}

TEST(CapOcclusion, ClosedFormSpecialValues) {
  // A cap centred on the normal: sin^2(alpha); a hemisphere centred on it: 1; the full sphere: 1.
  for (double alpha : {0.1, 0.5, 1.0, 1.5}) {
    const double omega = 2.0 * kPi * (1.0 - std::cos(alpha));
    EXPECT_NEAR(cap_occlusion(static_cast<float>(omega), 1.0f), std::sin(alpha) * std::sin(alpha), 1e-6);
    // Pointing straight away from the normal: nothing of the hemisphere is covered.
    EXPECT_NEAR(cap_occlusion(static_cast<float>(omega), -1.0f), 0.0, 1e-7);
  }
  EXPECT_NEAR(cap_occlusion(static_cast<float>(2.0 * kPi), 1.0f), 1.0, 1e-6);
  EXPECT_NEAR(cap_occlusion(static_cast<float>(4.0 * kPi), -0.3f), 1.0, 1e-6);
  EXPECT_EQ(cap_occlusion(0.0f, 1.0f), 0.0f);
  // A hemisphere-sized cap whose axis lies in the tangent plane covers half the cosine lobe.
  EXPECT_NEAR(cap_occlusion(static_cast<float>(2.0 * kPi), 0.0f), 0.5, 1e-6);
  // Symmetry: a cap and its complement together cover everything.
  for (double omega : {0.3, 2.0, 5.0}) {
    for (double cb : {-0.9, -0.2, 0.4, 0.8}) {
      const float a = cap_occlusion(static_cast<float>(omega), static_cast<float>(cb));
      const float b = cap_occlusion(static_cast<float>(4.0 * kPi - omega), static_cast<float>(-cb));
      EXPECT_NEAR(a + b, 1.0, 2e-6);
    }
  }
  // Out-of-range and non-finite inputs stay in [0, 1].
  for (float omega : {-1.0f, 100.0f, std::nanf("")})
    for (float cb : {-2.0f, 2.0f, std::nanf("")}) {
      const float a = cap_occlusion(omega, cb);
      EXPECT_TRUE(a >= 0.0f && a <= 1.0f) << omega << " " << cb;
    }
}

TEST(CapOcclusion, MonotoneInSolidAngleAndAngle) {
  for (int j = 0; j <= 20; ++j) {
    const float cb = -1.0f + 0.1f * static_cast<float>(j);
    float prev = -1.0f;
    for (int i = 0; i <= 50; ++i) {
      const float a = cap_occlusion(4.0f * std::numbers::pi_v<float> * static_cast<float>(i) / 50.0f, cb);
      EXPECT_GE(a, prev - 1e-6f);
      prev = a;
    }
  }
}

TEST(CapOcclusion, TableFollowsTheClosedForm) {
  double worst = 0.0, sum = 0.0;
  int count = 0;
  Rng rng = Rng::stream(17, 0);
  for (int k = 0; k < 200000; ++k) {
    const float omega = 4.0f * std::numbers::pi_v<float> * rng.next_float();
    const float cb = 2.0f * rng.next_float() - 1.0f;
    const double d = std::abs(double(cap_occlusion_table(omega, cb)) - double(cap_occlusion(omega, cb)));
    worst = std::max(worst, d);
    sum += d;
    ++count;
  }
  RecordProperty("table_max_abs_error", std::to_string(worst));
  EXPECT_LT(worst, 1e-3);  // measured 6.5e-4 (near the horizon kinks)
  EXPECT_LT(sum / count, 2e-4);
  // Exact at the grid nodes and the ends; in range for any input.
  EXPECT_NEAR(cap_occlusion_table(0.0f, 1.0f), 0.0f, 1e-7f);
  EXPECT_NEAR(cap_occlusion_table(4.0f * std::numbers::pi_v<float>, -1.0f), 1.0f, 1e-6f);
  for (float omega : {-1.0f, 100.0f, std::nanf("")})
    for (float cb : {-2.0f, 2.0f, std::nanf("")}) {
      const float a = cap_occlusion_table(omega, cb);
      EXPECT_TRUE(a >= 0.0f && a <= 1.0f) << omega << " " << cb;
    }
}

TEST(AOFieldCaster, PresetsAreValid) {
  for (Preset p : {Preset::Draft, Preset::Medium, Preset::High}) {
    const AOFieldCaster c = AOFieldCaster::preset(p);
    EXPECT_TRUE(validate_ao_field_caster(c, glm::mat4(1.0f), "ao field 'x'").ok());
  }
  EXPECT_LT(AOFieldCaster::preset(Preset::Draft).resolution, AOFieldCaster::preset(Preset::High).resolution);
}

TEST(AOFieldCaster, ValidationNamesTheProblem) {
  const auto message = [](const AOFieldCaster& c, const glm::mat4& m) {
    const Status s = validate_ao_field_caster(c, m, "ao field 'crate'");
    EXPECT_FALSE(s.ok());
    if (s.ok()) return std::string();
    EXPECT_EQ(s.error().code, ErrorCode::InvalidArgument);
    EXPECT_NE(s.error().message.find("ao field 'crate'"), std::string::npos);
    return s.error().message;
  };
  AOFieldCaster c;
  const glm::mat4 id(1.0f);
  c.resolution = 0;
  EXPECT_NE(message(c, id).find("resolution"), std::string::npos);
  c = {};
  c.radial_samples = 2;
  EXPECT_NE(message(c, id).find("radial_samples"), std::string::npos);
  c = {};
  c.rays_per_sample = 4;
  EXPECT_NE(message(c, id).find("rays_per_sample"), std::string::npos);
  c = {};
  c.falloff_distance = -1.0f;
  EXPECT_NE(message(c, id).find("falloff_distance"), std::string::npos);
  c = {};
  c.fade_start = 1.0f;
  EXPECT_NE(message(c, id).find("fade_start"), std::string::npos);
  c = {};
  c.inside_occlusion = 2.0f;
  EXPECT_NE(message(c, id).find("inside_occlusion"), std::string::npos);
  c = {};
  EXPECT_NE(message(c, glm::scale(id, glm::vec3(1.0f, 2.0f, 1.0f))).find("non-uniform scale"), std::string::npos);
  EXPECT_NE(message(c, glm::scale(id, glm::vec3(0.0f))).find("singular"), std::string::npos);
  glm::mat4 shear(1.0f);
  shear[1] = glm::vec4(0.6f, 0.8f, 0.0f, 0.0f);  // unit columns, not orthogonal
  EXPECT_NE(message(c, shear).find("shear"), std::string::npos);
  // Rotation, translation and uniform scale at extreme magnitudes are fine.
  for (float s : {1e-3f, 1e4f}) {
    const glm::mat4 m = glm::scale(glm::rotate(glm::translate(id, glm::vec3(3, -2, 7)), 0.7f, glm::vec3(1, 2, 3)),
                                   glm::vec3(s));
    EXPECT_TRUE(validate_ao_field_caster(c, m, "x").ok()) << s;
  }
}

TEST(AOField, CubeDirectionsCoverTheSphereOnce) {
  // Every texel centre maps back to its own texel through the lookup parameterisation: check
  // that directions are unit, distinct faces point along their axes, and face centres are axes.
  const glm::vec3 axes[6] = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
  for (std::uint32_t f = 0; f < 6; ++f) {
    EXPECT_NEAR(glm::distance(cube_direction(f, 0.0f, 0.0f), axes[f]), 0.0f, 1e-7f);
    for (float s : {-0.99f, 0.0f, 0.5f})
      for (float t : {-0.5f, 0.99f}) {
        const glm::vec3 d = cube_direction(f, s, t);
        EXPECT_NEAR(glm::length(d), 1.0f, 1e-6f);
        EXPECT_GT(glm::dot(d, axes[f]), 0.5f);
      }
  }
}

TEST(AOField, CombinationStaysInRangeForManyCasters) {
  std::vector<float> many(10000, 0.3f);
  const float all = combine_occlusion(many);
  EXPECT_GE(all, 0.0f);
  EXPECT_LE(all, 1.0f);
  EXPECT_FLOAT_EQ(all, 1.0f);  // 0.7^10000 underflows to 0: fully occluded, never above 1
  const std::vector<float> two{0.5f, 0.5f};
  EXPECT_FLOAT_EQ(combine_occlusion(two), 0.75f);
  const std::vector<float> odd{-0.5f, 1.5f, std::nanf("")};
  const float c = combine_occlusion(odd);
  EXPECT_TRUE(c >= 0.0f && c <= 1.0f);
  EXPECT_EQ(combine_occlusion({}), 0.0f);
  const std::vector<float> tiny(1000, 1e-30f);
  EXPECT_GE(combine_occlusion(tiny), 0.0f);
}

TEST(AOField, CapOverlapRuleIsExactForDisjointAndNestedCaps) {
  // Caps of half-angle alpha around an axis, their occlusion of a normal along +Y from the closed
  // form: the rule needs only A, omega and the axis.
  const auto cap = [](double alpha, glm::vec3 axis) {
    const float omega = static_cast<float>(2.0 * kPi * (1.0 - std::cos(alpha)));
    const glm::vec3 a = glm::normalize(axis);
    return AOFieldCap{cap_occlusion(omega, a.y), omega, a};
  };
  // One cap: itself. None: 0.
  const AOFieldCap one = cap(0.4, {0.3f, 1.0f, 0.0f});
  EXPECT_FLOAT_EQ(combine_caps(std::span<const AOFieldCap>(&one, 1)), one.occlusion);
  EXPECT_EQ(combine_caps({}), 0.0f);
  // Disjoint caps (axes 90 degrees apart, radii 0.3 each): the cosine-weighted measure adds up,
  // where the multiplicative rule is too light by A1 A2.
  const std::vector<AOFieldCap> apart = {cap(0.3, {1.0f, 1.0f, 0.0f}), cap(0.3, {-1.0f, 1.0f, 0.0f})};
  EXPECT_NEAR(combine_caps(apart), apart[0].occlusion + apart[1].occlusion, 1e-6f);
  const std::vector<float> apart_a = {apart[0].occlusion, apart[1].occlusion};
  EXPECT_LT(combine_occlusion(apart_a), combine_caps(apart));
  // Nested caps (a small one inside a large one): the union is the large one, where the
  // multiplicative rule is too dark.
  const std::vector<AOFieldCap> nested = {cap(0.8, {0.0f, 1.0f, 0.2f}), cap(0.2, {0.0f, 1.0f, 0.3f})};
  EXPECT_NEAR(combine_caps(nested), nested[0].occlusion, 1e-6f);
  const std::vector<float> nested_a = {nested[0].occlusion, nested[1].occlusion};
  EXPECT_GT(combine_occlusion(nested_a), combine_caps(nested));
  // Partly overlapping: between the larger alone and the sum.
  const std::vector<AOFieldCap> partly = {cap(0.5, {0.2f, 1.0f, 0.0f}), cap(0.5, {-0.4f, 1.0f, 0.0f})};
  const float p = combine_caps(partly);
  EXPECT_GT(p, std::max(partly[0].occlusion, partly[1].occlusion));
  EXPECT_LT(p, partly[0].occlusion + partly[1].occlusion);
  // Many caps, odd inputs: always in [0, 1].
  std::vector<AOFieldCap> many;
  Rng rng = Rng::stream(2, 0);
  for (int i = 0; i < 300; ++i)
    many.push_back(cap(1.5 * rng.next_float(), glm::vec3(rng.next_float() - 0.5f, rng.next_float(), rng.next_float() - 0.5f)));
  many.push_back(AOFieldCap{std::nanf(""), std::nanf(""), glm::vec3(0.0f)});
  many.push_back(AOFieldCap{-3.0f, 50.0f, glm::vec3(0, 1, 0)});
  const float all = combine_caps(many);
  EXPECT_GE(all, 0.0f);
  EXPECT_LE(all, 1.0f);
}

}  // namespace
}  // namespace penumbra
