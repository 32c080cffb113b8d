// Spherical harmonics against numerical integration in double precision: Gauss-Legendre in
// cos(theta) times the trapezoid rule in phi integrates polynomials in (x, y, z) of degree < 16
// exactly, so every quantity below is checked against its integral to 1e-5.
#include "penumbra/core/sh.h"

#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <vector>

#include <glm/geometric.hpp>

#include "penumbra/core/random.h"
#include "penumbra/core/sampling.h"

namespace penumbra {
namespace {

constexpr double kPi = 3.14159265358979323846;

struct Node {
  glm::dvec3 d;
  double w;
};

// Gauss-Legendre nodes and weights on [-1, 1] (Newton iteration on P_n).
std::vector<std::pair<double, double>> gauss_legendre(int n) {
  std::vector<std::pair<double, double>> out;
  for (int i = 0; i < n; ++i) {
    double x = std::cos(kPi * (i + 0.75) / (n + 0.5));
    double dp = 0.0;
    for (int iter = 0; iter < 100; ++iter) {
      double p0 = 1.0, p1 = x;
      for (int k = 2; k <= n; ++k) {
        const double p2 = ((2.0 * k - 1.0) * x * p1 - (k - 1.0) * p0) / k;
        p0 = p1;
        p1 = p2;
      }
      dp = n * (x * p1 - p0) / (x * x - 1.0);
      const double dx = p1 / dp;
      x -= dx;
      if (std::abs(dx) < 1e-16) break;
    }
    out.push_back({x, 2.0 / ((1.0 - x * x) * dp * dp)});
  }
  return out;
}

// Quadrature over the sphere (z in [-1, 1]) or over the hemisphere z >= 0 around +Z.
std::vector<Node> quadrature(bool hemisphere, int n_theta = 16, int n_phi = 32) {
  std::vector<Node> nodes;
  for (auto [x, w] : gauss_legendre(n_theta)) {
    const double z = hemisphere ? 0.5 * (x + 1.0) : x;
    const double wz = hemisphere ? 0.5 * w : w;
    const double r = std::sqrt(1.0 - z * z);
    for (int j = 0; j < n_phi; ++j) {
      const double phi = 2.0 * kPi * (j + 0.5) / n_phi;
      nodes.push_back({{r * std::cos(phi), r * std::sin(phi), z}, wz * 2.0 * kPi / n_phi});
    }
  }
  return nodes;
}

glm::vec3 to_float(glm::dvec3 d) { return glm::vec3(d); }

// A band-limited test function (degree 2 polynomial) and its exact coefficients.
double test_function(glm::dvec3 d) { return 1.0 + 2.0 * d.x - 3.0 * d.y * d.z + 0.5 * d.z * d.z; }

SH9f random_sh(std::uint64_t item, float dc) {
  Rng rng = Rng::stream(2024, item);
  SH9f sh;
  for (float& c : sh.c) c = 2.0f * rng.next_float() - 1.0f;
  sh.c[0] = dc;
  return sh;
}

glm::mat3 random_rotation(std::uint64_t item) {
  Rng rng = Rng::stream(77, item);
  const glm::vec3 axis = uniform_sphere({rng.next_float(), rng.next_float()});
  const float angle = 6.2831853f * rng.next_float();
  // Rodrigues: R = I cos + (1 - cos) a a^T + sin [a]x, built column by column.
  const float c = std::cos(angle), s = std::sin(angle);
  glm::mat3 r;
  for (int j = 0; j < 3; ++j) {
    glm::vec3 e(0.0f);
    e[j] = 1.0f;
    r[j] = e * c + axis * (glm::dot(axis, e) * (1.0f - c)) + glm::cross(axis, e) * s;
  }
  return r;
}

TEST(SH, BasisIsOrthonormal) {
  const std::vector<Node> q = quadrature(false);
  for (int i = 0; i < 9; ++i) {
    for (int j = 0; j < 9; ++j) {
      double integral = 0.0;
      for (const Node& n : q) {
        const SH9f y = sh_basis(to_float(n.d));
        integral += n.w * static_cast<double>(y[i]) * y[j];
      }
      EXPECT_NEAR(integral, i == j ? 1.0 : 0.0, 1e-5) << i << "," << j;
    }
  }
}

TEST(SH, ProjectionOfAKnownFunction) {
  SH9f sh;
  for (const Node& n : quadrature(false)) sh_add_sample(sh, to_float(n.d), static_cast<float>(test_function(n.d) * n.w));
  // Closed forms: int 1 = 4 pi, int x^2 = int z^2 = 4 pi / 3, int y^2 z^2 = 4 pi / 15,
  // int z^4 = 4 pi / 5, and the normalisation constants of sh.h.
  const double y0 = 0.5 / std::sqrt(kPi), y1 = std::sqrt(3.0 / (4.0 * kPi));
  const double y2a = 0.5 * std::sqrt(15.0 / kPi), y2b = 0.25 * std::sqrt(5.0 / kPi);
  const double expected[9] = {y0 * (4.0 * kPi + 0.5 * 4.0 * kPi / 3.0),
                              0.0,
                              0.0,
                              -y1 * 2.0 * 4.0 * kPi / 3.0,
                              0.0,
                              3.0 * y2a * 4.0 * kPi / 15.0,
                              0.5 * y2b * (3.0 * 4.0 * kPi / 5.0 - 4.0 * kPi / 3.0),
                              0.0,
                              0.0};
  for (int i = 0; i < 9; ++i) EXPECT_NEAR(sh[i], expected[i], 1e-5) << i;
  // Reconstruction is exact for a band-limited function.
  for (std::uint32_t k = 0; k < 256; ++k) {
    const glm::vec3 d = uniform_sphere(sobol_2d(k, 3));
    EXPECT_NEAR(sh_evaluate(sh, d), test_function(glm::dvec3(d)), 1e-5);
  }
}

TEST(SH, L1EvaluationUsesTheFirstFourCoefficients) {
  const SH9f sh = random_sh(1, 1.0f);
  SH9f l1 = sh;
  for (int i = 4; i < 9; ++i) l1[i] = 0.0f;
  SH9f l0 = sh;
  for (int i = 1; i < 9; ++i) l0[i] = 0.0f;
  for (std::uint32_t k = 0; k < 64; ++k) {
    const glm::vec3 d = uniform_sphere(sobol_2d(k, 5));
    EXPECT_FLOAT_EQ(sh_evaluate(sh, d, 2), sh_evaluate(l1, d));
    EXPECT_FLOAT_EQ(sh_evaluate(sh, d, 1), sh_evaluate(l0, d));
  }
}

TEST(SH, CosineConvolutionMatchesTheIrradianceIntegral) {
  // E(n) = int L(w) max(0, n.w) dw, integrated over the hemisphere around n, where the integrand
  // is a polynomial (no kink), against the convolved coefficients evaluated at n.
  const std::vector<Node> hemi = quadrature(true);
  for (std::uint64_t item = 0; item < 8; ++item) {
    const SH9f radiance = random_sh(item, 4.0f);
    const SH9f irradiance = sh_convolve_cosine(radiance);
    for (std::uint32_t k = 0; k < 16; ++k) {
      const glm::vec3 n = uniform_sphere(sobol_2d(k, static_cast<std::uint32_t>(item)));
      glm::vec3 t, b;
      orthonormal_basis(n, t, b);
      double e = 0.0;
      for (const Node& q : hemi) {
        const glm::dvec3 w = q.d.x * glm::dvec3(t) + q.d.y * glm::dvec3(b) + q.d.z * glm::dvec3(n);
        e += q.w * q.d.z * sh_evaluate(radiance, to_float(w));
      }
      EXPECT_NEAR(sh_evaluate(irradiance, n), e, 1e-5 * std::abs(e)) << item << " " << k;
    }
  }
  // A constant radiance L gives E = pi L everywhere.
  SH9f constant;
  constant[0] = 1.0f / 0.28209479177387814f;
  EXPECT_NEAR(sh_evaluate(sh_convolve_cosine(constant), {0, 1, 0}), kPi, 1e-5);
}

TEST(SH, RotationCommutesWithEvaluation) {
  for (std::uint64_t item = 0; item < 16; ++item) {
    const SH9f sh = random_sh(item, 0.5f);
    const glm::mat3 r = random_rotation(item);
    const SH9f rotated = sh_rotate(sh, r);
    EXPECT_EQ(rotated[0], sh[0]);
    for (std::uint32_t k = 0; k < 64; ++k) {
      const glm::vec3 d = uniform_sphere(sobol_2d(k, 11));
      EXPECT_NEAR(sh_evaluate(rotated, d), sh_evaluate(sh, glm::transpose(r) * d), 1e-5);
    }
    // Rotating back restores the coefficients; energy per band is preserved.
    const SH9f back = sh_rotate(rotated, glm::transpose(r));
    for (int i = 0; i < 9; ++i) EXPECT_NEAR(back[i], sh[i], 1e-5);
  }
}

TEST(SH, RgbMatchesPerChannelFloat) {
  SH9rgb rgb;
  SH9f ch[3] = {random_sh(3, 1.0f), random_sh(4, 2.0f), random_sh(5, 3.0f)};
  for (int i = 0; i < 9; ++i) rgb[i] = {ch[0][i], ch[1][i], ch[2][i]};
  const glm::mat3 r = random_rotation(9);
  const SH9rgb rot = sh_rotate(sh_convolve_cosine(rgb), r);
  const glm::vec3 d = glm::normalize(glm::vec3(0.3f, -0.5f, 0.8f));
  for (int c = 0; c < 3; ++c) {
    EXPECT_FLOAT_EQ(sh_evaluate(rot, d)[c], sh_evaluate(sh_rotate(sh_convolve_cosine(ch[c]), r), d));
  }
  SH9rgb projected;
  sh_add_sample(projected, d, glm::vec3(1.0f, 2.0f, 3.0f));
  SH9f one;
  sh_add_sample(one, d, 2.0f);
  for (int i = 0; i < 9; ++i) EXPECT_FLOAT_EQ(projected[i].y, one[i]);
}

TEST(SH, WindowsAndNonNegativeEvaluation) {
  const auto hann = sh_hanning_window(3.0f);
  EXPECT_FLOAT_EQ(hann[0], 1.0f);
  EXPECT_NEAR(hann[1], 0.75f, 1e-6f);  // (1 + cos(pi/3)) / 2
  EXPECT_NEAR(hann[2], 0.25f, 1e-6f);  // (1 + cos(2 pi/3)) / 2
  EXPECT_EQ(sh_hanning_window(2.0f)[2], 0.0f);
  const auto lanczos = sh_lanczos_window(4.0f);
  EXPECT_FLOAT_EQ(lanczos[0], 1.0f);
  EXPECT_NEAR(lanczos[1], std::sin(kPi / 4) / (kPi / 4), 1e-6);
  EXPECT_GT(lanczos[1], lanczos[2]);

  // A small bright cap (cos theta > 0.8 around +Z): its truncated L2 expansion rings below zero
  // (Gibbs); the Hanning- and Lanczos-windowed expansions ring less, and the clamped evaluation of
  // the irradiance never goes negative.
  SH9f cap;
  for (const Node& n : quadrature(false, 64, 64)) {
    if (n.d.z > 0.8) sh_add_sample(cap, to_float(n.d), static_cast<float>(10.0 * n.w));
  }
  const SH9f windowed = sh_apply_window(cap, hann);
  const SH9f e = sh_convolve_cosine(cap);
  float min_raw = 1e9f, min_hann = 1e9f, min_lanczos = 1e9f, min_e = 1e9f;
  for (std::uint32_t k = 0; k < 1024; ++k) {
    const glm::vec3 d = uniform_sphere(sobol_2d(k, 8));
    min_raw = std::min(min_raw, sh_evaluate(cap, d));
    min_hann = std::min(min_hann, sh_evaluate(windowed, d));
    min_lanczos = std::min(min_lanczos, sh_evaluate(sh_apply_window(cap, sh_lanczos_window(3.0f)), d));
    min_e = std::min(min_e, sh_evaluate(e, d));
    EXPECT_GE(sh_evaluate_non_negative(e, d), 0.0f);
    EXPECT_EQ(sh_evaluate_non_negative(e, d), std::max(0.0f, sh_evaluate(e, d)));
  }
  EXPECT_LT(min_raw, -1.0f);
  EXPECT_GT(min_hann, 0.5f * min_raw);
  EXPECT_GT(min_lanczos, 0.5f * min_raw);
  EXPECT_LT(min_e, 0.0f);  // the irradiance rings too: clamping matters
  // The window keeps the mean (band 0).
  EXPECT_EQ(windowed[0], cap[0]);
}

}  // namespace
}  // namespace penumbra
