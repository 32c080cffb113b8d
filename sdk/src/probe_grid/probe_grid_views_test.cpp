// The error heat map: in the furnace (closed form of the indirect part pi Le rho / (1 - rho)
// everywhere) a grid baked with 2 bounces misses exactly the rho^2 of it that takes more; without a
// bake it refuses;
// the map is the same at any thread count.
#include "probe_grid_views.h"

#include <cmath>

#include <glm/ext/matrix_clip_space.hpp>
#include <glm/ext/matrix_transform.hpp>
#include <gtest/gtest.h>

#include "editor_model.h"
#include "penumbra/probe_grid/probe_grid.h"
#include "penumbra/scene/builtin.h"

namespace penumbra::editor {
namespace {

CameraView inside_furnace() {
  CameraView c;
  c.position = glm::vec3(0.0f, 0.0f, 0.3f);
  c.view = glm::lookAtRH(c.position, glm::vec3(0.0f, 0.0f, -1.0f), glm::vec3(0, 1, 0));
  c.projection = glm::perspectiveRH_ZO(1.0f, 16.0f / 9.0f, 0.01f, 10.0f);
  c.projection[1][1] = -c.projection[1][1];
  return c;
}

TEST(ErrorMap, FurnaceGridMatchesTheReferenceWithinItsNoise) {
  EditorModel model;
  ASSERT_TRUE(model.open("builtin:furnace", Preset::Medium).ok());
  ErrorMapRequest request;
  request.camera = inside_furnace();
  request.columns = 16;
  request.rows = 9;
  request.reference.samples = 64;
  JobContext serial;
  auto unbaked = compute_error_map(model.document()->world(), request, serial);
  ASSERT_FALSE(unbaked.ok());
  EXPECT_NE(unbaked.error().message.find("bake the probe grid first"), std::string::npos);

  model.bake_settings.preset = Preset::Medium;
  ASSERT_TRUE(model.bake({"probe-grid"}).ok());
  model.bakes().wait();
  ASSERT_TRUE(model.poll());
  ASSERT_EQ(model.bakes().status().state, BakeStatus::State::Done) << model.bakes().status().error;

  auto map = compute_error_map(model.document()->world(), request, serial);
  ASSERT_TRUE(map.ok()) << map.error().message;
  EXPECT_EQ(map->relative_error.size(), 16u * 9u);
  EXPECT_GT(map->cells, 100u);  // the camera sees the inside wall everywhere the grid covers
  // The medium grid stores indirect light (the scene's default grid) with the bounces its
  // truncation asks for (5 at rho 0.5 and 5 %): pi Le (rho + ... + rho^k) against the indirect
  // reference's pi Le rho / (1 - rho), a relative error of rho^k = 0.031 <= the truncation, up to
  // both estimates' noise.
  const std::uint32_t k = probe_bounces(IrradianceProbeGrid::preset(Preset::Medium), kFurnaceAlbedo);
  EXPECT_EQ(k, 5u);
  const float expected = std::pow(kFurnaceAlbedo, float(k));
  EXPECT_NEAR(map->mean, expected, 0.04f) << "reference noise " << map->reference_noise;
  EXPECT_GT(map->reference_noise, 0.0f);
  EXPECT_EQ(map->relative_noise.size(), map->relative_error.size());
  // The reference's noise against its paths: 8, 64 (above) and 2048 a cell. It falls as
  // 1 / sqrt(paths); the raw mean error falls with it towards the grid's own error, which the
  // noise-corrected RMS estimates alike at 64 and 2048 paths (the grid's truncation and its own bake
  // noise). At 8 paths the noise swamps the error, and the map says so.
  const auto at = [&](std::uint32_t paths) {
    ErrorMapRequest r = request;
    r.reference.samples = paths;
    auto m = compute_error_map(model.document()->world(), r, serial);
    EXPECT_TRUE(m.ok());
    std::printf("furnace error map at %u paths: mean %.4f, reference noise %.4f, noise-corrected rms %.4f, above "
                "the noise %d\n",
                paths, m->mean, m->reference_noise, m->noise_corrected_rms, int(m->above_noise()));
    return *m;
  };
  const ErrorMap coarse = at(8), fine = at(2048);
  at(64);
  EXPECT_FALSE(coarse.above_noise());
  EXPECT_NEAR(fine.reference_noise / map->reference_noise, std::sqrt(64.0f / 2048.0f), 0.05f);
  EXPECT_LT(fine.mean, map->mean);
  EXPECT_TRUE(fine.above_noise());
  EXPECT_NEAR(fine.noise_corrected_rms, map->noise_corrected_rms, 0.25f * fine.noise_corrected_rms);
  EXPECT_GT(fine.noise_corrected_rms, 0.5f * expected);  // at least the truncation's

  // Same map on two threads, through the background job.
  ErrorMapJob job;
  request.threads = 2;
  ASSERT_TRUE(job.start(model.document()->world(), request).ok());
  std::optional<Result<ErrorMap>> again;
  while (!(again = job.take())) std::this_thread::yield();
  ASSERT_TRUE(again->ok());
  ASSERT_EQ((*again)->relative_error.size(), map->relative_error.size());
  for (std::size_t i = 0; i < map->relative_error.size(); ++i) {
    const float a = map->relative_error[i], b = (*again)->relative_error[i];
    EXPECT_TRUE((std::isnan(a) && std::isnan(b)) || a == b) << i;
  }
}

}  // namespace
}  // namespace penumbra::editor
