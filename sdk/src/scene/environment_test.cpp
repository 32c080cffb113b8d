// Environment maps (scene/components.h): the equirectangular convention, bilinear lookup, the
// checks on their texels, and the World's environment.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <numbers>

#include "penumbra/scene/components.h"

namespace penumbra {
namespace {

constexpr float kPi = std::numbers::pi_v<float>;

// The direction through the centre of texel (x, y) of a w x h map, by the convention the header
// states: u = 0.5 + atan2(d.x, -d.z) / 2pi, v = acos(d.y) / pi.
glm::vec3 texel_direction(std::uint32_t x, std::uint32_t y, std::uint32_t w, std::uint32_t h) {
  const float phi = ((float(x) + 0.5f) / float(w) - 0.5f) * 2.0f * kPi;
  const float theta = (float(y) + 0.5f) / float(h) * kPi;
  return {std::sin(theta) * std::sin(phi), std::cos(theta), -std::sin(theta) * std::cos(phi)};
}

// Each texel a different value: (x, y, x + w y).
std::shared_ptr<const EnvironmentMap> numbered_map(std::uint32_t w, std::uint32_t h) {
  std::vector<glm::vec3> texels;
  for (std::uint32_t y = 0; y < h; ++y)
    for (std::uint32_t x = 0; x < w; ++x) texels.emplace_back(float(x), float(y), float(x + w * y));
  auto map = make_environment_map(w, h, std::move(texels), "numbered");
  EXPECT_TRUE(map.ok());
  return map.ok() ? *map : nullptr;
}

TEST(EnvironmentMap, EachTexelCentreReturnsThatTexel) {
  const auto map = numbered_map(16, 8);
  ASSERT_TRUE(map);
  for (std::uint32_t y = 0; y < 8; ++y)
    for (std::uint32_t x = 0; x < 16; ++x) {
      const glm::vec3 got = sample_environment_map(*map, texel_direction(x, y, 16, 8));
      EXPECT_NEAR(got.x, float(x), 2e-3f) << x << ", " << y;
      EXPECT_NEAR(got.y, float(y), 2e-3f) << x << ", " << y;
    }
  // The landmarks: -Z at the centre of the width, +X at three quarters, the top row up.
  EXPECT_NEAR(sample_environment_map(*map, {0.0f, 0.0f, -1.0f}).x, 7.5f, 1e-3f);
  EXPECT_NEAR(sample_environment_map(*map, {1.0f, 0.0f, 0.0f}).x, 11.5f, 1e-3f);
  EXPECT_NEAR(sample_environment_map(*map, {0.0f, 1.0f, 0.0f}).y, 0.0f, 1e-6f);
  EXPECT_NEAR(sample_environment_map(*map, {0.0f, -1.0f, 0.0f}).y, 7.0f, 1e-6f);
}

// Across the seam (+Z, u = 0 and 1) the lookup blends the last column with the first; between
// rows it blends linearly.
TEST(EnvironmentMap, BilinearAcrossTheSeamAndBetweenRows) {
  const auto map = numbered_map(16, 8);
  ASSERT_TRUE(map);
  // Column 0's centre mirrored in x lies at column 15's, the other side of the seam.
  const glm::vec3 mirrored = sample_environment_map(*map, texel_direction(0, 3, 16, 8) * glm::vec3(-1.0f, 1.0f, 1.0f));
  EXPECT_NEAR(mirrored.x, 15.0f, 2e-3f);
  // On the horizon toward +Z: half way between columns 15 and 0, and between rows 3 and 4.
  const glm::vec3 at_z = sample_environment_map(*map, {0.0f, 0.0f, 1.0f});
  EXPECT_NEAR(at_z.x, 7.5f, 2e-3f);  // columns 15 and 0
  EXPECT_NEAR(at_z.y, 3.5f, 2e-3f);  // rows 3 and 4
}

TEST(EnvironmentMap, RefusesBadTexelsAndSizesNamingThem) {
  auto zero = make_environment_map(0, 4, {}, "sky.exr");
  ASSERT_FALSE(zero.ok());
  EXPECT_NE(zero.error().message.find("sky.exr"), std::string::npos);
  auto count = make_environment_map(4, 2, std::vector<glm::vec3>(7), "sky.exr");
  ASSERT_FALSE(count.ok());
  EXPECT_NE(count.error().message.find("7 texels"), std::string::npos);
  for (float bad : {std::numeric_limits<float>::quiet_NaN(), std::numeric_limits<float>::infinity(), -0.5f}) {
    std::vector<glm::vec3> texels(8, glm::vec3(1.0f));
    texels[6].y = bad;  // x 2, y 1
    auto r = make_environment_map(4, 2, texels, "sky.exr");
    ASSERT_FALSE(r.ok()) << bad;
    EXPECT_EQ(r.error().code, ErrorCode::InvalidArgument);
    EXPECT_NE(r.error().message.find("sky.exr: texel (2, 1)"), std::string::npos) << r.error().message;
  }
  // The digest follows the texels.
  auto a = make_environment_map(2, 1, {glm::vec3(1.0f), glm::vec3(2.0f)}, "a");
  auto b = make_environment_map(2, 1, {glm::vec3(1.0f), glm::vec3(2.5f)}, "b");
  ASSERT_TRUE(a.ok() && b.ok());
  EXPECT_NE((*a)->digest, (*b)->digest);
}

// A NaN direction sees black; a 1 x 1 map is a constant sky; the scale multiplies, and the World's
// environment is the first one in entity order.
TEST(EnvironmentMap, DegenerateLookupsAndTheWorldsEnvironment) {
  auto one = make_environment_map(1, 1, {glm::vec3(0.5f, 1.0f, 2.0f)}, "one");
  ASSERT_TRUE(one.ok());
  const float nan = std::numeric_limits<float>::quiet_NaN();
  EXPECT_EQ(sample_environment_map(**one, {nan, 0.0f, 0.0f}), glm::vec3(0.0f));
  for (glm::vec3 d : {glm::vec3(0, 1, 0), glm::vec3(0, -1, 0), glm::vec3(0.6f, 0.0f, 0.8f)})
    EXPECT_EQ(sample_environment_map(**one, d), glm::vec3(0.5f, 1.0f, 2.0f));
  Environment sky;
  sky.radiance = glm::vec3(9.0f);
  EXPECT_EQ(sky.toward({0, 1, 0}), glm::vec3(9.0f));
  sky.map_data = *one;
  sky.map_scale = 2.0f;
  EXPECT_EQ(sky.toward({0, 1, 0}), glm::vec3(1.0f, 2.0f, 4.0f));

  World world;
  EXPECT_EQ(world_environment(world).toward({0, 1, 0}), glm::vec3(0.0f));
  const Entity first = world.create(), second = world.create();
  world.add<Environment>(second, Environment{glm::vec3(3.0f)});
  world.add<Environment>(first, sky);
  EXPECT_EQ(world_environment(world).map_data, *one);
}

}  // namespace
}  // namespace penumbra
