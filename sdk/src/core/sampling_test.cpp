#include "penumbra/core/sampling.h"

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include <glm/geometric.hpp>

namespace penumbra {
namespace {

constexpr double kPi = 3.14159265358979323846;

// Every elementary interval of area 2^-k (2^i x 2^(k-i) cells) holds exactly one of 2^k points.
bool is_0m2_net(const std::vector<glm::vec2>& points, unsigned k) {
  for (unsigned i = 0; i <= k; ++i) {
    const std::uint32_t nx = 1u << i, ny = 1u << (k - i);
    std::vector<int> cells(std::size_t{1} << k, 0);
    for (glm::vec2 p : points) {
      const auto cx = static_cast<std::uint32_t>(p.x * static_cast<float>(nx));
      const auto cy = static_cast<std::uint32_t>(p.y * static_cast<float>(ny));
      if (++cells[cy * nx + cx] > 1) return false;
    }
  }
  return true;
}

TEST(Sobol, ScrambledPrefixesAreNets) {
  for (std::uint32_t seed : {0u, 1u, 12345u, 0xdeadbeefu}) {
    for (unsigned k = 0; k <= 12; ++k) {
      std::vector<glm::vec2> points;
      for (std::uint32_t i = 0; i < (1u << k); ++i) points.push_back(sobol_2d(i, seed));
      EXPECT_TRUE(is_0m2_net(points, k)) << "seed " << seed << " k " << k;
    }
  }
}

TEST(Sobol, EachDimensionIsStratified) {
  // Every single dimension of 2^k points has one point in each interval of length 2^-k.
  for (std::uint32_t dim = 0; dim < 4; ++dim) {
    std::vector<int> cells(256, 0);
    for (std::uint32_t i = 0; i < 256; ++i) {
      const float x = sobol(i, dim, 77);
      ASSERT_GE(x, 0.0f);
      ASSERT_LT(x, 1.0f);
      ++cells[static_cast<std::size_t>(x * 256.0f)];
    }
    for (int c : cells) EXPECT_EQ(c, 1) << "dim " << dim;
  }
}

TEST(Sobol, DeterministicAndSeedDependent) {
  int equal = 0;
  for (std::uint32_t i = 0; i < 64; ++i) {
    EXPECT_EQ(sobol(i, 2, 5), sobol(i, 2, 5));
    equal += sobol(i, 2, 5) == sobol(i, 2, 6);
  }
  EXPECT_LT(equal, 4);
  // sobol_2d is dimensions 0 and 1 of sobol(), bit for bit.
  for (std::uint32_t i = 0; i < 4096; i += 7)
    for (std::uint32_t seed : {0u, 9u, 0xdeadbeefu}) {
      EXPECT_EQ(sobol_2d(i, seed).x, sobol(i, 0, seed));
      EXPECT_EQ(sobol_2d(i, seed).y, sobol(i, 1, seed));
    }
}

TEST(Sobol, PairsOfDimensionsIntegrateProducts) {
  // int_0^1 int_0^1 x y = 1/4 in dimensions (0, 1) and (2, 3): a wrong direction number makes
  // two dimensions correlated and moves the estimate far from 1/4.
  const std::uint32_t n = 1u << 14;
  double xy = 0.0, zw = 0.0;
  for (std::uint32_t i = 0; i < n; ++i) {
    xy += static_cast<double>(sobol(i, 0, 3)) * sobol(i, 1, 3);
    zw += static_cast<double>(sobol(i, 2, 3)) * sobol(i, 3, 3);
  }
  EXPECT_NEAR(xy / n, 0.25, 2e-3);
  EXPECT_NEAR(zw / n, 0.25, 2e-3);
}

TEST(Halton, RadicalInverseClosedForm) {
  EXPECT_EQ(halton(1, 0), 0.5f);
  EXPECT_EQ(halton(3, 0), 0.75f);
  EXPECT_EQ(halton(6, 0), 0.375f);  // 110b -> 0.011b
  EXPECT_NEAR(halton(1, 1), 1.0f / 3.0f, 1e-7f);
  EXPECT_NEAR(halton(5, 1), 7.0f / 9.0f, 1e-7f);  // 12 in base 3 -> 0.21
  EXPECT_NEAR(halton(7, 2), 2.0f / 5.0f + 1.0f / 25.0f, 1e-7f);  // 12 in base 5
  // Rotation wraps around and stays below 1.
  EXPECT_NEAR(halton(3, 0, 0.5f), 0.25f, 1e-7f);
  for (std::uint32_t i = 0; i < 1000; ++i) {
    for (std::uint32_t d = 0; d < 32; d += 5) {
      const float x = halton(i * 7919u + 0xffff0000u, d, 0.999999f);
      EXPECT_GE(x, 0.0f);
      EXPECT_LT(x, 1.0f);
    }
  }
}

TEST(Halton, BaseBPrefixesAreStratified) {
  // The first b^2 points in base b are exactly the b^2 fractions j / b^2 (up to rounding).
  for (std::uint32_t dim : {1u, 3u, 10u}) {
    const std::uint32_t primes[] = {2, 3, 5, 7, 11, 13, 17, 19, 23, 29, 31};
    const std::uint32_t b = primes[dim], n = b * b;
    std::vector<int> cells(n, 0);
    for (std::uint32_t i = 0; i < n; ++i) {
      const double j = static_cast<double>(halton(i, dim)) * n;
      EXPECT_NEAR(j, std::round(j), 1e-4);
      ++cells[static_cast<std::size_t>(std::lround(j))];
    }
    for (int c : cells) EXPECT_EQ(c, 1) << "dim " << dim;
  }
}

TEST(Mappings, UnitVectorsInTheRightHemisphere) {
  for (std::uint32_t i = 0; i < 4096; ++i) {
    const glm::vec2 u = sobol_2d(i, 9);
    for (glm::vec3 d : {uniform_sphere(u), uniform_hemisphere(u), cosine_hemisphere(u)}) {
      EXPECT_NEAR(glm::length(d), 1.0f, 2e-6f);
    }
    EXPECT_GE(uniform_hemisphere(u).z, 0.0f);
    EXPECT_GE(cosine_hemisphere(u).z, 0.0f);
    EXPECT_LE(glm::length(concentric_disk(u)), 1.0f + 1e-6f);
  }
  EXPECT_EQ(concentric_disk({0.5f, 0.5f}), glm::vec2(0.0f));
}

TEST(Mappings, CosineSamplingIntegratesTheCosineExactly) {
  // f / pdf = cos / (cos / pi) = pi for every sample: zero variance.
  for (std::uint32_t i = 1; i < 1024; ++i) {
    const glm::vec3 d = cosine_hemisphere(sobol_2d(i, 4));
    if (d.z <= 0.0f) continue;
    EXPECT_NEAR(d.z / cosine_hemisphere_pdf(d.z), kPi, 1e-5);
  }
}

TEST(Mappings, MonteCarloIntegralsConverge) {
  // Closed forms: over the hemisphere, int cos = pi and int cos^2 = 2 pi / 3; over the sphere,
  // int z^2 = 4 pi / 3 and int x = 0; with cosine sampling int cos^2 = 2 pi / 3.
  double err_prev = 1e9;
  for (std::uint32_t n : {256u, 4096u, 65536u}) {
    double hemi_cos = 0, hemi_cos2 = 0, sph_z2 = 0, sph_x = 0, cos_cos2 = 0;
    for (std::uint32_t i = 0; i < n; ++i) {
      const glm::vec2 u = sobol_2d(i, 21);
      const glm::vec3 h = uniform_hemisphere(u), s = uniform_sphere(u), c = cosine_hemisphere(u);
      hemi_cos += h.z / uniform_hemisphere_pdf();
      hemi_cos2 += h.z * h.z / uniform_hemisphere_pdf();
      sph_z2 += s.z * s.z / uniform_sphere_pdf();
      sph_x += s.x / uniform_sphere_pdf();
      if (c.z > 0.0f) cos_cos2 += c.z * c.z / cosine_hemisphere_pdf(c.z);
    }
    const double err = std::abs(hemi_cos / n - kPi) + std::abs(hemi_cos2 / n - 2 * kPi / 3) +
                       std::abs(sph_z2 / n - 4 * kPi / 3) + std::abs(sph_x / n) + std::abs(cos_cos2 / n - 2 * kPi / 3);
    EXPECT_LT(err, 10.0 / n);  // QMC: error about 1/N, far below Monte Carlo's 1/sqrt(N)
    EXPECT_LT(err, err_prev);
    err_prev = err;
  }
}

TEST(Basis, OrthonormalAndMapsZToN) {
  for (std::uint32_t i = 0; i < 2048; ++i) {
    const glm::vec3 n = uniform_sphere(sobol_2d(i, 2));
    glm::vec3 t, b;
    orthonormal_basis(n, t, b);
    EXPECT_NEAR(glm::dot(t, t), 1.0f, 1e-5f);
    EXPECT_NEAR(glm::dot(b, b), 1.0f, 1e-5f);
    EXPECT_NEAR(glm::dot(t, b), 0.0f, 1e-5f);
    EXPECT_NEAR(glm::dot(t, n), 0.0f, 1e-5f);
    EXPECT_NEAR(glm::dot(b, n), 0.0f, 1e-5f);
    // Right-handed: t x b = n.
    EXPECT_NEAR(glm::length(glm::cross(t, b) - n), 0.0f, 1e-5f);
    EXPECT_NEAR(glm::length(to_world(n, {0, 0, 1}) - n), 0.0f, 1e-6f);
  }
}

}  // namespace
}  // namespace penumbra
