#include "penumbra/offline/irradiance_filter.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <random>
#include <vector>

#include <glm/geometric.hpp>

#include "penumbra/core/jobs.h"

namespace penumbra {
namespace {

constexpr std::uint32_t kWidth = 48, kHeight = 32;

// A synthetic frame: a floor seen from above (pixel (i, j) at (i h, 0, j h) plus a little relief)
// whose normals turn by up to about 30 degrees across it, a wall on the right third (normal -x),
// a few pixels without a surface, noisy irradiance, 1-4 rays per pixel and harmonic mean distances
// from 0.5 to 20 pixel widths (some infinite: every ray escaped).
std::vector<FilterPixel> synthetic_frame(std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> unit(0.0f, 1.0f);
  constexpr float h = 0.01f;
  std::vector<FilterPixel> pixels(std::size_t{kWidth} * kHeight);
  for (std::uint32_t j = 0; j < kHeight; ++j)
    for (std::uint32_t i = 0; i < kWidth; ++i) {
      FilterPixel& p = pixels[std::size_t{j} * kWidth + i];
      if (unit(rng) < 0.03f) continue;  // no surface
      const bool wall = i >= 2 * kWidth / 3;
      const float x = float(i) * h, z = float(j) * h;
      p.position = wall ? glm::vec3(float(2 * kWidth / 3) * h, x - float(2 * kWidth / 3) * h, z)
                        : glm::vec3(x, 0.002f * std::sin(9.0f * x + 5.0f * z), z);
      p.normal = wall ? glm::vec3(-1.0f, 0.0f, 0.0f)
                      : glm::normalize(glm::vec3(0.6f * std::sin(4.0f * x), 1.0f, 0.3f * std::cos(6.0f * z)));
      p.footprint = h;
      p.irradiance = glm::vec3(1.0f + unit(rng), 0.5f + 2.0f * unit(rng), unit(rng)) * (wall ? 0.3f : 1.0f);
      p.samples = 1 + static_cast<std::uint32_t>(unit(rng) * 4.0f);
      p.harmonic_distance = unit(rng) < 0.1f ? std::numeric_limits<float>::infinity() : h * (0.5f + 19.5f * unit(rng));
    }
  return pixels;
}

// The paper's filter at pixel p in double (predictor_radius 0: m_p is p's own harmonic distance):
// sum K(eps / a) N_q E_q / sum K N_q over the window, eps = |x_p - x_q| max(1 / m_p, 1 / m_q) +
// sqrt(1 - n_p . n_q), K(t) = exp(-t^2) for t <= 2. `ambiguous` is set when a tap's t lies within
// 1e-4 of the cut, where float and double may decide differently.
glm::dvec3 formula(const std::vector<FilterPixel>& px, const IrradianceFilterSettings& s, std::size_t p,
                   bool& ambiguous) {
  const FilterPixel& c = px[p];
  const auto inverse = [](const FilterPixel& q) {
    return std::isfinite(q.harmonic_distance) ? 1.0 / q.harmonic_distance : 0.0;
  };
  std::uint32_t radius = s.max_radius;
  if (inverse(c) > 0.0) {  // as the filter computes it, in float
    const float pixels = std::ceil(2.0f * s.a / (float(inverse(c)) * c.footprint));
    radius = pixels < float(s.max_radius) ? std::uint32_t(pixels) : s.max_radius;
  }
  const long x = long(p % kWidth), y = long(p / kWidth), r = radius;
  glm::dvec3 sum(0.0);
  double weight = 0.0;
  for (long yy = std::max(0L, y - r); yy <= std::min<long>(kHeight - 1, y + r); ++yy)
    for (long xx = std::max(0L, x - r); xx <= std::min<long>(kWidth - 1, x + r); ++xx) {
      const FilterPixel& q = px[std::size_t(yy) * kWidth + std::size_t(xx)];
      if (q.samples == 0) continue;
      const double d = glm::length(glm::dvec3(q.position) - glm::dvec3(c.position));
      // 1 - n_p . n_q in float, as the filter takes it: where the normals barely turn, float loses
      // most of its digits there, and that is not what this compares.
      const float cos_turn = 1.0f - (c.normal.x * q.normal.x + c.normal.y * q.normal.y + c.normal.z * q.normal.z);
      const double turn = std::max(0.0, double(cos_turn));
      const double t = (d * std::max(inverse(c), inverse(q)) + std::sqrt(turn)) / s.a;
      if (std::abs(t - 2.0) < 1e-4) ambiguous = true;
      if (t > 2.0) continue;
      const double k = std::exp(-t * t) * q.samples;
      sum += k * glm::dvec3(q.irradiance);
      weight += k;
    }
  return sum / weight;
}

TEST(IrradianceFilter, EveryPixelIsThePapersWeightedMean) {
  const std::vector<FilterPixel> pixels = synthetic_frame(7);
  ThreadPool pool(2);
  JobContext jobs(&pool);
  for (const Isa isa : {Isa::Best, Isa::Portable}) {
    const char* path = isa == Isa::Best ? "best" : "portable";
    for (float a : {0.1f, 0.2f, 0.4f}) {
      IrradianceFilterSettings s;
      s.a = a;
      s.predictor_radius = 0;
      std::vector<glm::vec3> out(pixels.size());
      ASSERT_TRUE(filter_irradiance(pixels, kWidth, kHeight, s, out, jobs, isa).ok());
      std::size_t compared = 0, skipped = 0;
      for (std::size_t p = 0; p < pixels.size(); ++p) {
        if (pixels[p].samples == 0) {
          EXPECT_EQ(out[p], glm::vec3(0.0f)) << p;
          continue;
        }
        bool ambiguous = false;
        const glm::dvec3 expected = formula(pixels, s, p, ambiguous);
        if (ambiguous) {
          ++skipped;
          continue;
        }
        ++compared;
        for (int k = 0; k < 3; ++k)
          ASSERT_NEAR(out[p][k], expected[k], 2e-5 * std::max(1.0, std::abs(expected[k])))
              << "pixel " << p << " channel " << k << " a " << a << " " << path;
      }
      EXPECT_GT(compared, 20 * skipped) << "a " << a << " " << path;  // almost every pixel is compared
    }
  }
}

TEST(IrradianceFilter, ConstantIrradianceStaysConstantAndNoneStaysNone) {
  std::vector<FilterPixel> pixels = synthetic_frame(11);
  ThreadPool pool(2);
  JobContext jobs(&pool);
  const IrradianceFilterSettings s;
  std::vector<glm::vec3> out(pixels.size());
  for (const glm::vec3 e : {glm::vec3(0.0f), glm::vec3(0.25f, 1.0f, 3.0f)}) {
    for (FilterPixel& p : pixels) p.irradiance = e;
    ASSERT_TRUE(filter_irradiance(pixels, kWidth, kHeight, s, out, jobs).ok());
    for (std::size_t p = 0; p < pixels.size(); ++p)
      for (int k = 0; k < 3; ++k) ASSERT_NEAR(out[p][k], pixels[p].samples != 0 ? e[k] : 0.0f, 1e-6f * e[k]) << p;
  }
}

TEST(IrradianceFilter, ANonFiniteGeometryPixelTakesNoPartInItsNeighbours) {
  std::vector<FilterPixel> pixels = synthetic_frame(13);
  ThreadPool pool(1);
  JobContext jobs(&pool);
  const IrradianceFilterSettings s;
  // The same frame with that pixel empty, and with it holding a NaN position and a huge value.
  const std::size_t bad = std::size_t{kHeight / 2} * kWidth + kWidth / 3;
  pixels[bad].samples = 0;
  std::vector<glm::vec3> clean(pixels.size()), out(pixels.size());
  ASSERT_TRUE(filter_irradiance(pixels, kWidth, kHeight, s, clean, jobs).ok());
  pixels[bad].samples = 2;
  pixels[bad].position.x = std::numeric_limits<float>::quiet_NaN();
  pixels[bad].irradiance = glm::vec3(1e30f);
  ASSERT_TRUE(filter_irradiance(pixels, kWidth, kHeight, s, out, jobs).ok());
  std::size_t changed = 0;
  for (std::size_t p = 0; p < pixels.size(); ++p) {
    ASSERT_TRUE(std::isfinite(out[p].x + out[p].y + out[p].z)) << p;
    if (p != bad) changed += out[p] != clean[p];
  }
  EXPECT_EQ(changed, 0u);
}

TEST(IrradianceFilter, TheWideAndThePortableGatherGiveTheSameBits) {
#if defined(__x86_64__) && defined(__GNUC__)
  if (!__builtin_cpu_supports("avx2")) GTEST_SKIP() << "this CPU has no AVX2: both paths are the portable one";
#endif
  ThreadPool pool(2);
  JobContext jobs(&pool);
  for (std::uint32_t seed : {1u, 2u, 3u}) {
    const std::vector<FilterPixel> pixels = synthetic_frame(seed);
    for (std::uint32_t predictor : {0u, 1u}) {
      IrradianceFilterSettings s;
      s.predictor_radius = predictor;
      s.max_radius = 9 + seed;  // windows whose rows are not a multiple of the lanes
      std::vector<glm::vec3> best(pixels.size()), portable(pixels.size());
      ASSERT_TRUE(filter_irradiance(pixels, kWidth, kHeight, s, best, jobs, Isa::Best).ok());
      ASSERT_TRUE(filter_irradiance(pixels, kWidth, kHeight, s, portable, jobs, Isa::Portable).ok());
      EXPECT_EQ(std::memcmp(best.data(), portable.data(), best.size() * sizeof(glm::vec3)), 0) << seed;
      std::vector<float> support_best(pixels.size()), support_portable(pixels.size());
      ASSERT_TRUE(irradiance_filter_support(pixels, kWidth, kHeight, s, 30.0f, support_best, jobs, Isa::Best).ok());
      ASSERT_TRUE(
          irradiance_filter_support(pixels, kWidth, kHeight, s, 30.0f, support_portable, jobs, Isa::Portable).ok());
      EXPECT_EQ(std::memcmp(support_best.data(), support_portable.data(), support_best.size() * sizeof(float)), 0)
          << seed;
    }
  }
}

}  // namespace
}  // namespace penumbra
