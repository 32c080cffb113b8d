// What a probe grid stores (IrradianceProbeGrid::lighting): an Indirect grid of a scene where no
// light reflects is zero; in the furnace Indirect = All - pi Le (the closed forms, and against the
// integrator's reference); All = Indirect + the direct-only bake at the nodes with the same seed;
// indirect bakes are bit-identical at 1 and 2 threads; the version 2 chunk round-trips and version 1
// reads as All; validation, input hash, default grid.
#include "penumbra/probe_grid/probe_grid_baker.h"

#include <gtest/gtest.h>

#include <cmath>
#include <memory>
#include <numbers>
#include <tuple>

#include <glm/gtc/matrix_transform.hpp>
#include <glm/gtc/quaternion.hpp>

#include "penumbra/bake/baker.h"
#include "penumbra/core/random.h"
#include "penumbra/core/sampling.h"
#include "penumbra/ecs/transform.h"
#include "penumbra/probe_grid/probe_grid_system.h"
#include "penumbra/scene/builtin.h"
#include "penumbra/scene/mesh.h"

namespace penumbra {
namespace {

constexpr float kPi = std::numbers::pi_v<float>;

Entity add_static(World& w, MeshData mesh, const glm::mat4& m, glm::vec3 albedo, glm::vec3 emissive = glm::vec3(0.0f)) {
  const Entity e = w.create();
  w.add<Mesh>(e, Mesh{std::make_shared<const MeshData>(std::move(mesh))});
  w.add<WorldTransform>(e, WorldTransform{m});
  Material mat;
  mat.base_color = glm::vec4(albedo, 1.0f);
  mat.emissive = emissive;
  w.add<Material>(e, mat);
  w.add<Static>(e);
  return e;
}

IrradianceProbeGrid grid_over(glm::vec3 lo, glm::vec3 hi, ProbeSampling mode, LightingContent lighting) {
  IrradianceProbeGrid g;
  g.box.min = lo;
  g.box.max = hi;
  g.resolution = {3, 3, 3};
  g.sampling = mode;
  g.samples_per_node = 8;
  g.rays_per_sample = 32;
  g.lighting = lighting;
  return g;
}

Result<ProbeGridData> bake(const IrradianceProbeGrid& g, World& w, const RayScene& scene, std::uint64_t seed = 1,
                           unsigned threads = 2) {
  ThreadPool pool(threads);
  JobContext jobs(&pool);
  MemoryBudget budget;
  return bake_probe_grid(g, glm::mat4(1.0f), scene, gather_lights(w), seed, jobs, budget);
}

constexpr ProbeSampling kModes[] = {ProbeSampling::Point, ProbeSampling::Supersampled, ProbeSampling::Fitted};

// A sun and a black emissive panel over a black floor: every light reaching a node comes straight
// from a light or an emitter, so the Indirect grid is exactly zero while the All grid is not.
TEST(ProbeLighting, NoReflectionMeansAZeroIndirectGrid) {
  World w;
  add_static(w, make_quad(100.0f, 100.0f), glm::rotate(glm::mat4(1.0f), -kPi / 2, {1, 0, 0}), glm::vec3(0.0f));
  add_static(w, make_quad(1.0f, 1.0f), glm::translate(glm::mat4(1.0f), {0.0f, 1.0f, -2.0f}), glm::vec3(0.0f),
             glm::vec3(2.0f));  // faces +Z, towards the grid
  Light sun;
  sun.type = Light::Type::Directional;
  sun.intensity = 3.0f;
  const Entity s = w.create();
  w.add<Light>(s, sun);
  w.add<WorldTransform>(s, WorldTransform{glm::mat4_cast(glm::quatLookAt(glm::vec3(0, -1, 0), {0, 0, 1}))});
  auto scene = RayScene::build(w);
  ASSERT_TRUE(scene.ok()) << scene.error().message;
  for (ProbeSampling mode : kModes) {
    IrradianceProbeGrid g = grid_over({-1.0f, 0.1f, -1.0f}, {1.0f, 2.0f, 1.0f}, mode, LightingContent::Indirect);
    g.bounces = 3;
    auto indirect = bake(g, w, *scene);
    ASSERT_TRUE(indirect.ok()) << indirect.error().message;
    EXPECT_EQ(indirect->lighting, LightingContent::Indirect);
    for (const glm::vec3& c : indirect->coefficients) EXPECT_EQ(c, glm::vec3(0.0f)) << to_string(mode);
    g.lighting = LightingContent::All;
    auto all = bake(g, w, *scene);
    ASSERT_TRUE(all.ok()) << all.error().message;
    // Facing up: at least the sun's 3 W/m^2 (plus some of the panel).
    EXPECT_GT(evaluate(*all, {0.0f, 1.0f, 0.0f}, {0, 1, 0}).x, 2.85f) << to_string(mode);
    // Facing the panel: its emission, absent from the Indirect grid.
    EXPECT_GT(evaluate(*all, {0.0f, 1.0f, 0.0f}, {0, 0, -1}).x, 0.05f) << to_string(mode);
  }
}

// Furnace with finite bounces (exact: every path sees the same walls): All = pi Le sum_{k<=B}
// rho^k, Indirect the same without k = 0, for every normal. The same seed traces the same rays, so
// each grid is its constant radiance projected over them: Indirect = (rho + rho^2) (All - Indirect)
// coefficient by coefficient, up to rounding; the SH projection's noise only enters the closed forms.
TEST(ProbeLighting, FurnaceIndirectIsAllMinusTheEmission) {
  World w;
  ASSERT_TRUE(load_builtin(w, "furnace").ok());
  update_world_transforms(w);
  auto scene = RayScene::build(w);
  ASSERT_TRUE(scene.ok());
  const float direct = kPi * kFurnaceRadiance, rho = kFurnaceAlbedo;
  for (ProbeSampling mode : kModes) {
    IrradianceProbeGrid g = grid_over(glm::vec3(-0.25f), glm::vec3(0.25f), mode, LightingContent::All);
    g.bounces = 2;
    // The fit trades blur for variance (a corner node sees an octant of its tent): more samples.
    if (mode == ProbeSampling::Fitted) g.samples_per_node = 32;
    auto all = bake(g, w, *scene);
    g.lighting = LightingContent::Indirect;
    auto indirect = bake(g, w, *scene);
    ASSERT_TRUE(all.ok() && indirect.ok());
    float worst = 0.0f;
    for (std::size_t i = 0; i < all->coefficients.size(); ++i) {
      const glm::vec3 a = all->coefficients[i], ind = indirect->coefficients[i];
      worst = std::max(worst, glm::length(ind - (rho + rho * rho) * (a - ind)));
    }
    EXPECT_LT(worst, 1e-4f * direct) << to_string(mode);
    // The closed forms, within the projection's noise (as the all-bounce furnace test).
    Rng rng = Rng::stream(3, 0);
    for (std::size_t n = 0; n < all->node_count(); ++n)
      for (int k = 0; k < 4; ++k) {
        const glm::vec3 normal = uniform_sphere({rng.next_float(), rng.next_float()});
        const float a = sh_evaluate(all->node(n), normal).x, i = sh_evaluate(indirect->node(n), normal).x;
        EXPECT_NEAR(a, direct * (1.0f + rho + rho * rho), 0.06f * direct * (1.0f + rho + rho * rho)) << to_string(mode);
        EXPECT_NEAR(i, direct * (rho + rho * rho), 0.06f * direct * (rho + rho * rho)) << to_string(mode);
        EXPECT_NEAR(a - i, direct, 0.06f * direct) << to_string(mode);
      }
  }
}

// Furnace with every bounce: the Indirect grid against the integrator's Indirect reference and
// the closed form pi Le rho / (1 - rho), within the reference's standard error and the grid's noise.
TEST(ProbeLighting, FurnaceIndirectGridMatchesTheIndirectReference) {
  World w;
  ASSERT_TRUE(load_builtin(w, "furnace").ok());
  update_world_transforms(w);
  auto scene = RayScene::build(w);
  ASSERT_TRUE(scene.ok());
  IrradianceProbeGrid g =
      grid_over(glm::vec3(-0.25f), glm::vec3(0.25f), ProbeSampling::Supersampled, LightingContent::Indirect);
  g.bounces = kProbeAllBounces;
  auto d = bake(g, w, *scene);
  ASSERT_TRUE(d.ok()) << d.error().message;
  IrradianceSettings ref;
  ref.reference = true;
  ref.content = LightingContent::Indirect;
  ref.samples = 8000;
  Rng rng = Rng::stream(4, 0);
  const glm::vec3 x(0.1f, -0.05f, 0.2f), n(0.0f, 0.0f, 1.0f);
  const Estimate e = irradiance(*scene, gather_lights(w), x, n, ref, rng);
  const float closed = kPi * kFurnaceRadiance * kFurnaceAlbedo / (1.0f - kFurnaceAlbedo);
  EXPECT_NEAR(e.value.x, closed, 3.0f * e.std_error.x);
  EXPECT_LT(e.std_error.x, 0.02f * closed);
  EXPECT_NEAR(evaluate(*d, x, n).x, e.value.x, 3.0f * e.std_error.x + 0.05f * closed);
}

// In the courtyard (sun and point lights: deltas, so the lights draw no random numbers): at every
// node All = Indirect + the bake with no bounce (direct only), same seed, up to rounding. Every
// sample point counts (threshold 1): the direct bake traces other rays after a node's first point,
// and a domain decision taken from other rays could drop other points. The fit is not linear in
// its data (conjugate gradients), so the identity is checked for the averaging modes. The sky is
// ambient light, in every content (integrators.h), so it is taken away here.
TEST(ProbeLighting, AllIsIndirectPlusDirectAtTheNodes) {
  World w;
  ASSERT_TRUE(load_builtin(w, "courtyard").ok());
  w.each<Environment>([](Environment& sky) { sky.radiance = glm::vec3(0.0f); });
  update_world_transforms(w);
  auto scene = RayScene::build(w);
  ASSERT_TRUE(scene.ok());
  for (ProbeSampling mode : {ProbeSampling::Point, ProbeSampling::Supersampled}) {
    IrradianceProbeGrid g = grid_over({-3.0f, 0.3f, -3.0f}, {3.0f, 3.0f, 3.0f}, mode, LightingContent::All);
    g.samples_per_node = 4;
    g.rays_per_sample = 16;
    g.bounces = 2;
    g.back_face_threshold = 1.0f;
    auto all = bake(g, w, *scene, 11);
    g.lighting = LightingContent::Indirect;
    auto indirect = bake(g, w, *scene, 11);
    g.lighting = LightingContent::All;
    g.bounces = 0;
    auto direct = bake(g, w, *scene, 11);
    ASSERT_TRUE(all.ok() && indirect.ok() && direct.ok());
    float scale = 0.0f, worst = 0.0f, indirect_sum = 0.0f;
    for (std::size_t i = 0; i < all->coefficients.size(); ++i) {
      scale = std::max(scale, std::abs(all->coefficients[i].x));
      worst = std::max(worst, glm::length(all->coefficients[i] - indirect->coefficients[i] - direct->coefficients[i]));
      indirect_sum += indirect->coefficients[i].x;
    }
    EXPECT_GT(indirect_sum, 0.0f) << to_string(mode);  // the courtyard reflects light
    EXPECT_LT(worst, 1e-4f * scale) << to_string(mode);
    // Indirect bakes are bit-identical at any thread count, like all bakes.
    g.lighting = LightingContent::Indirect;
    g.bounces = 2;
    auto serial = bake(g, w, *scene, 11, 1);
    ASSERT_TRUE(serial.ok());
    EXPECT_EQ(serial->coefficients, indirect->coefficients) << to_string(mode);
  }
}

// --- Chunk, validation, hash, default grid -------------------------------------------------------

ProbeGridData small_data(LightingContent lighting) {
  ProbeGridData d;
  d.key = "probe grid";
  d.layout.resolution = {2, 2, 2};
  d.sh_order = ProbeShOrder::L1;
  d.sampling = ProbeSampling::Fitted;
  d.lighting = lighting;
  d.bounces = 10;
  for (int i = 0; i < 8 * 4; ++i) d.coefficients.push_back(glm::vec3(float(i), 0.5f, -float(i) * 0.25f));
  d.validity.assign(8, 1.0f);
  d.filled.assign(8, 0);
  return d;
}

TEST(ProbeLighting, ChunkRoundTripsAndOtherVersionsAreRefused) {
  for (LightingContent lighting : {LightingContent::All, LightingContent::Indirect}) {
    for (bool guard : {false, true}) {
      ProbeGridData d = small_data(lighting);
      if (guard)
        for (int i = 0; i < 8 * 6; ++i) d.reach.push_back(static_cast<std::uint8_t>(37 * i));
      const BakeChunk chunk = write_probe_grid_chunk(d);
      EXPECT_EQ(chunk.version, kProbeGridChunkVersion);
      EXPECT_EQ(chunk.label, "probe-grid:probe grid");
      auto back = read_probe_grid_chunk(chunk);
      ASSERT_TRUE(back.ok()) << back.error().message;
      EXPECT_EQ(back->key, d.key);
      EXPECT_EQ(back->lighting, lighting);
      EXPECT_EQ(back->coefficients, d.coefficients);
      EXPECT_EQ(back->reach, d.reach);
      EXPECT_EQ(back->bounces, 10u);
      const std::vector<std::string> info = describe_probe_grid_chunk(chunk);
      EXPECT_NE(info[0].find(std::string(to_string(lighting)) + " lighting, 10 bounces"), std::string::npos) << info[0];
      EXPECT_NE(info[1].find(guard ? "leak guard on" : "leak guard off"), std::string::npos) << info[1];
    }
  }
  // Reach of the wrong length: a clear error naming the sizes.
  ProbeGridData short_reach = small_data(LightingContent::Indirect);
  short_reach.reach.assign(5, 255);
  auto sr = read_probe_grid_chunk(write_probe_grid_chunk(short_reach));
  ASSERT_FALSE(sr.ok());
  EXPECT_NE(sr.error().message.find("8 nodes"), std::string::npos) << sr.error().message;
  // The noise target's record round-trips and is described; values no bake writes are refused.
  ProbeGridData refined = small_data(LightingContent::Indirect);
  refined.noise = 0.02f;
  refined.refined_nodes = 3;
  refined.ray_factor = 2.5f;
  auto rb = read_probe_grid_chunk(write_probe_grid_chunk(refined));
  ASSERT_TRUE(rb.ok()) << rb.error().message;
  EXPECT_EQ(rb->noise, 0.02f);
  EXPECT_EQ(rb->refined_nodes, 3u);
  EXPECT_EQ(rb->ray_factor, 2.5f);
  const std::vector<std::string> refined_info = describe_probe_grid_chunk(write_probe_grid_chunk(refined));
  ASSERT_EQ(refined_info.size(), 3u);
  EXPECT_EQ(refined_info[2], "noise target 2%: 3 nodes (37.5%) traced more rays, 2.50x the rays on average");
  for (const auto& [noise, nodes, factor] : {std::tuple{std::nanf(""), 0u, 1.0f}, std::tuple{1.5f, 0u, 1.0f},
                                             std::tuple{0.02f, 9u, 2.0f}, std::tuple{0.02f, 1u, 0.0f},
                                             std::tuple{0.02f, 1u, 9.0f}}) {
    ProbeGridData wrong = refined;
    wrong.noise = noise;
    wrong.refined_nodes = nodes;
    wrong.ray_factor = factor;
    auto w = read_probe_grid_chunk(write_probe_grid_chunk(wrong));
    ASSERT_FALSE(w.ok()) << noise << " " << nodes << " " << factor;
    EXPECT_NE(w.error().message.find("re-bake the probe grid"), std::string::npos) << w.error().message;
  }
  // Chunks keyed by bake-time entity index (versions 1 to 3), those without the noise target's
  // record (4, 5) and future versions are refused, naming both versions and asking for a re-bake.
  const ProbeGridData d = small_data(LightingContent::Indirect);
  for (std::uint32_t version : {4u, 5u, kProbeGridChunkVersion + 1}) {
    BakeChunk other = write_probe_grid_chunk(d);
    other.version = version;
    auto f = read_probe_grid_chunk(other);
    ASSERT_FALSE(f.ok());
    EXPECT_EQ(f.error().code, ErrorCode::Unsupported);
    EXPECT_NE(f.error().message.find("version " + std::to_string(version)), std::string::npos) << f.error().message;
    EXPECT_NE(f.error().message.find("version " + std::to_string(kProbeGridChunkVersion)), std::string::npos)
        << f.error().message;
  }
  // An unknown lighting value in the payload.
  ProbeGridData bad = d;
  bad.lighting = static_cast<LightingContent>(5);
  auto b = read_probe_grid_chunk(write_probe_grid_chunk(bad));
  ASSERT_FALSE(b.ok());
  EXPECT_NE(b.error().message.find("lighting 5"), std::string::npos) << b.error().message;
}

TEST(ProbeLighting, ValidationHashAndTheDefaultGrid) {
  IrradianceProbeGrid g = grid_over(glm::vec3(0.0f), glm::vec3(1.0f), ProbeSampling::Point, LightingContent::All);
  g.lighting = static_cast<LightingContent>(2);
  auto layout = probe_grid_layout(g, glm::mat4(1.0f), "probe grid 'hall'");
  ASSERT_FALSE(layout.ok());
  EXPECT_NE(layout.error().message.find("probe grid 'hall': field 'lighting' = 2 is not one of all, indirect"),
            std::string::npos)
      << layout.error().message;

  World w;
  register_transform_systems(w);
  register_probe_grid_system(w);
  register_probe_grid_baker(w);
  ASSERT_TRUE(load_builtin(w, "cornell").ok());
  w.update(0.0);
  auto grid = add_default_probe_grid(w, Preset::Draft);
  ASSERT_TRUE(grid.ok()) << grid.error().message;
  EXPECT_EQ(w.get<IrradianceProbeGrid>(*grid).lighting, LightingContent::Indirect);  // for the SDK's renderer
  w.update(0.0);
  const BakeSettings settings;
  const std::uint64_t indirect = bake_input_hash(w, {"probe-grid"}, settings);
  EXPECT_EQ(indirect, bake_input_hash(w, {"probe-grid"}, settings));
  w.patch<IrradianceProbeGrid>(*grid).lighting = LightingContent::All;
  EXPECT_NE(indirect, bake_input_hash(w, {"probe-grid"}, settings));
}

}  // namespace
}  // namespace penumbra
