// The lit view against the offline reference: the per-cell comparison on images made by hand, and
// the whole job in the furnace, whose lit view has the closed form Le / (1 - rho) everywhere.
#include "reference_map.h"

#include <algorithm>
#include <cmath>
#include <thread>

#include <glm/ext/matrix_clip_space.hpp>
#include <glm/ext/matrix_transform.hpp>
#include <gtest/gtest.h>

#include "load_world.h"
#include "penumbra/scene/builtin.h"

namespace penumbra::editor {
namespace {

// 4 x 2 cells of 2 x 2 pixels: the reference 1 in every covered pixel with a standard error of
// 0.01, the rightmost column of cells not covered.
OfflineImage flat_reference(const ReferenceMapRequest& r) {
  OfflineImage ref;
  ref.width = r.width();
  ref.height = r.height();
  const std::size_t n = std::size_t{ref.width} * ref.height;
  ref.lit.assign(n, glm::vec3(1.0f));
  ref.lit_std_error.assign(n, glm::vec3(0.01f));
  ref.covered.assign(n, 1);
  for (std::size_t i = 0; i < n; ++i)
    if (i % ref.width >= ref.width - r.cell_pixels) ref.covered[i] = 0;
  return ref;
}

TEST(ReferenceMap, ComparesCellMeansWithTheReferencesNoise) {
  ReferenceMapRequest r;
  r.columns = 4;
  r.rows = 2;
  r.cell_pixels = 2;
  const OfflineImage ref = flat_reference(r);
  std::vector<glm::vec3> tested(ref.lit.size(), glm::vec3(1.1f));
  tested[0] = glm::vec3(std::nanf(""));  // a non-finite pixel leaves its cell without a value
  auto map = compare_with_reference(tested, ref, r);
  ASSERT_TRUE(map.ok()) << map.error().message;
  EXPECT_EQ(map->cells, 5u);  // 8 cells, less the uncovered column and the NaN's
  EXPECT_TRUE(std::isnan(map->relative_error[0]));
  EXPECT_TRUE(std::isnan(map->relative_error[3]));
  EXPECT_NEAR(map->relative_error[1], 0.1f, 1e-5f);
  EXPECT_NEAR(map->relative_noise[1], 0.005f, 1e-6f);  // 0.01 / sqrt(4 pixels)
  EXPECT_NEAR(map->mean, 0.1f, 1e-5f);
  EXPECT_NEAR(map->ratio, 1.1f, 1e-5f);
  EXPECT_NEAR(map->noise_corrected_rms, std::sqrt(0.01f - 0.005f * 0.005f), 1e-5f);
  EXPECT_TRUE(map->above_noise());
  // Equal images: no error; sizes that do not match and a reference without its error: refused.
  auto same = compare_with_reference(ref.lit, ref, r);
  ASSERT_TRUE(same.ok());
  EXPECT_EQ(same->mean, 0.0f);
  EXPECT_FALSE(same->above_noise());
  EXPECT_FALSE(compare_with_reference(std::span(tested).first(5), ref, r).ok());
  OfflineImage unlit = ref;
  std::fill(unlit.lit.begin(), unlit.lit.end(), glm::vec3(0.0f));
  auto dark = compare_with_reference(tested, unlit, r);
  ASSERT_FALSE(dark.ok()) << "a map without a cell";
  EXPECT_NE(dark.error().message.find("no cell"), std::string::npos);
  OfflineImage no_error = ref;
  no_error.lit_std_error.clear();
  auto refused = compare_with_reference(tested, no_error, r);
  ASSERT_FALSE(refused.ok());
  EXPECT_NE(refused.error().message.find("mode reference"), std::string::npos);
}

// In the furnace the lit view is Le / (1 - rho) at every pixel: an image of exactly that is within
// the reference's noise, one 20 % brighter is 20 % off with the ratio to match, and the job refuses
// to start twice or with a wrong size.
TEST(ReferenceMap, TheFurnacesClosedFormIsWithinTheReferencesNoise) {
  World world;
  ASSERT_TRUE(cli::load_world(world, "builtin:furnace", Preset::Draft).ok());
  ReferenceMapRequest r;
  r.camera.position = glm::vec3(0.0f, 0.0f, 0.3f);
  r.camera.view = glm::lookAtRH(r.camera.position, glm::vec3(0.0f, 0.0f, -1.0f), glm::vec3(0, 1, 0));
  r.camera.projection = glm::perspectiveRH_ZO(1.0f, 4.0f / 3.0f, 0.01f, 10.0f);
  r.camera.projection[1][1] = -r.camera.projection[1][1];
  r.columns = 8;
  r.rows = 6;
  r.spp = 32;
  r.threads = 2;
  const float lit = kFurnaceRadiance / (1.0f - kFurnaceAlbedo);
  for (float scale : {1.0f, 1.2f}) {
    ReferenceMapJob job;
    EXPECT_FALSE(job.start(world, std::vector<glm::vec3>(7), r).ok());
    const std::vector<glm::vec3> tested(std::size_t{r.width()} * r.height(), glm::vec3(scale * lit));
    ASSERT_TRUE(job.start(world, tested, r).ok());
    EXPECT_FALSE(job.start(world, tested, r).ok()) << "a second start while one runs";
    std::optional<Result<ErrorMap>> done;
    while (!(done = job.take())) std::this_thread::sleep_for(std::chrono::milliseconds(10));
    ASSERT_TRUE(done->ok()) << done->error().message;
    const ErrorMap& map = done->value();
    EXPECT_EQ(map.cells, 48u);
    EXPECT_GT(map.reference_noise, 0.0f);
    EXPECT_NEAR(map.ratio, scale, 3.0f * map.reference_noise / std::sqrt(48.0f) + 1e-3f) << scale;
    if (scale == 1.0f) {
      EXPECT_FALSE(map.above_noise()) << "mean " << map.mean << " noise " << map.reference_noise;
    } else {
      EXPECT_TRUE(map.above_noise());
      EXPECT_NEAR(map.mean, 0.2f, 0.03f);
    }
  }
}

}  // namespace
}  // namespace penumbra::editor
