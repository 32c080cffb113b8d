// Probe-grid bake against closed forms: the furnace, an infinite lit floor (at any scale and
// light intensity), geometry that swallows the grid; determinism, budget, cancellation, and the
// baker / system round trip through bake_world.
#include "penumbra/probe_grid/probe_grid_baker.h"

#include <gtest/gtest.h>

#include <cmath>
#include <memory>
#include <numbers>

#include <glm/geometric.hpp>
#include <glm/gtc/matrix_transform.hpp>
#include <glm/gtc/quaternion.hpp>

#include "penumbra/bake/baker.h"
#include "penumbra/core/random.h"
#include "penumbra/core/sampling.h"
#include "penumbra/ecs/transform.h"
#include "penumbra/probe_grid/probe_grid_system.h"
#include "penumbra/runtime.h"
#include "penumbra/scene/builtin.h"
#include "penumbra/scene/mesh.h"
#include "test_cornell_front.h"

namespace penumbra {
namespace {

constexpr float kPi = std::numbers::pi_v<float>;

Entity add_static(World& w, MeshData mesh, const glm::mat4& m, glm::vec3 albedo) {
  const Entity e = w.create();
  w.add<Mesh>(e, Mesh{std::make_shared<const MeshData>(std::move(mesh))});
  w.add<WorldTransform>(e, WorldTransform{m});
  Material mat;
  mat.base_color = glm::vec4(albedo, 1.0f);
  w.add<Material>(e, mat);
  w.add<Static>(e);
  return e;
}

Entity add_sun(World& w, float illuminance, glm::vec3 towards) {
  Light sun;
  sun.type = Light::Type::Directional;
  sun.intensity = illuminance;
  const Entity e = w.create();
  w.add<Light>(e, sun);
  // Shines along local -Z: rotate -Z onto `towards`.
  w.add<WorldTransform>(e, WorldTransform{glm::mat4_cast(glm::quatLookAt(glm::normalize(towards), {0, 0, 1}))});
  return e;
}

IrradianceProbeGrid small_grid(glm::vec3 lo, glm::vec3 hi, glm::uvec3 res, ProbeSampling mode) {
  IrradianceProbeGrid g;
  g.box.min = lo;
  g.box.max = hi;
  g.resolution = res;
  g.sampling = mode;
  g.samples_per_node = 8;
  g.rays_per_sample = 32;
  g.lighting = LightingContent::All;  // the closed forms below are of the whole irradiance
  return g;
}

// Built-in scene `name` loaded into `w`, its transforms updated, and its ray scene.
Result<RayScene> builtin_ray_scene(World& w, const char* name) {
  if (auto loaded = load_builtin(w, name); !loaded) return loaded.error();
  update_world_transforms(w);
  return RayScene::build(w);
}

Result<ProbeGridData> bake(const IrradianceProbeGrid& g, World& w, const RayScene& scene, unsigned threads = 1,
                           std::uint64_t seed = 1) {
  ThreadPool pool(threads);
  JobContext jobs(&pool);
  MemoryBudget budget;
  const auto lights = gather_lights(w);
  return bake_probe_grid(g, glm::mat4(1.0f), scene, lights, seed, jobs, budget);
}

// --- Furnace: E = pi Le / (1 - rho) everywhere, for every normal --------------------------------

TEST(ProbeBaker, FurnaceEveryNodeAndNormal) {
  World w;
  auto scene = builtin_ray_scene(w, "furnace");
  ASSERT_TRUE(scene.ok()) << scene.error().message;
  for (ProbeSampling mode : {ProbeSampling::Point, ProbeSampling::Supersampled, ProbeSampling::Fitted}) {
    IrradianceProbeGrid g = small_grid(glm::vec3(-0.25f), glm::vec3(0.25f), {3, 3, 3}, mode);
    // Tents reach 0.5 m from the centre per axis: every sample is inside the unit sphere.
    g.bounces = kProbeAllBounces;
    // The fit trades the averages' blur for Monte Carlo variance (a corner node sees an octant of
    // its tent): give it more samples so that the test checks the closed form, not the noise.
    if (mode == ProbeSampling::Fitted) g.samples_per_node = 32;
    auto d = bake(g, w, *scene, 2);
    ASSERT_TRUE(d.ok()) << d.error().message;
    EXPECT_EQ(d->valid_fraction(), 1.0f);
    Rng rng = Rng::stream(5, 0);
    for (std::size_t n = 0; n < d->node_count(); ++n) {
      EXPECT_EQ(d->validity[n], 1.0f);
      for (int k = 0; k < 8; ++k) {
        const glm::vec3 normal = uniform_sphere({rng.next_float(), rng.next_float()});
        const glm::vec3 e = sh_evaluate(d->node(n), normal);
        for (int c = 0; c < 3; ++c) EXPECT_NEAR(e[c], kFurnaceIrradiance, 0.06f * kFurnaceIrradiance) << to_string(mode);
      }
    }
  }
}

// --- Infinite floor under a sun: a closed form for the expansion ---------------------------------
// Sun from straight above (illuminance E0) over a floor of albedo rho: incident radiance is the
// delta E0 at +Y plus rho E0 / pi from the whole lower hemisphere (one bounce; the floor cannot
// see itself). Its L2 irradiance expansion follows from the core SH functions exactly.

struct FloorScene {
  World world;
  std::unique_ptr<RayScene> rays;
};
constexpr float kRho = 0.5f;

void build_floor(FloorScene& s, float scale, float sun) {
  const glm::mat4 floor = glm::rotate(glm::scale(glm::mat4(1.0f), glm::vec3(scale)), -kPi / 2, {1, 0, 0});
  add_static(s.world, make_quad(2000.0f, 2000.0f), floor, glm::vec3(kRho));
  add_sun(s.world, sun, {0, -1, 0});
  auto r = RayScene::build(s.world);
  ASSERT_TRUE(r.ok());
  s.rays = std::make_unique<RayScene>(std::move(*r));
}

SH9rgb floor_expansion(float e0) {
  SH9rgb radiance;
  sh_add_sample(radiance, {0, 1, 0}, glm::vec3(e0));
  // Lower hemisphere of radiance rho E0 / pi: projection by a fine midpoint rule in (cos, phi).
  const int n = 400;
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) {
      const float y = -(float(i) + 0.5f) / float(n);
      const float phi = 2.0f * kPi * (float(j) + 0.5f) / float(n);
      const float r = std::sqrt(1.0f - y * y);
      sh_add_sample(radiance, {r * std::cos(phi), y, r * std::sin(phi)},
                    glm::vec3(kRho * e0 / kPi * 2.0f * kPi / float(n * n)));
    }
  return sh_convolve_cosine(radiance);
}

// The largest error of the grid against the closed form over receivers in the box, relative to
// E0, for normals +-Y and four sideways.
float floor_error(const ProbeGridData& d, float scale, float e0) {
  const SH9rgb exact = floor_expansion(e0);
  float worst = 0.0f;
  Rng rng = Rng::stream(9, 0);
  for (int i = 0; i < 50; ++i) {
    const glm::vec3 x = scale * glm::vec3(-1.0f + 2.0f * rng.next_float(), 0.05f + rng.next_float(),
                                          -1.0f + 2.0f * rng.next_float());
    for (glm::vec3 n : {glm::vec3(0, 1, 0), glm::vec3(0, -1, 0), glm::vec3(1, 0, 0), glm::vec3(0, 0, -1)}) {
      const float got = evaluate(d, x, n).x, want = std::max(0.0f, sh_evaluate(exact, n).x);
      worst = std::max(worst, std::abs(got - want) / e0);
    }
  }
  return worst;
}

IrradianceProbeGrid floor_grid(float scale, ProbeSampling mode) {
  IrradianceProbeGrid g = small_grid(scale * glm::vec3(-1.0f, 0.05f, -1.0f), scale * glm::vec3(1.0f, 1.05f, 1.0f),
                                     {3, 3, 3}, mode);
  g.bounces = 1;
  return g;
}

TEST(ProbeBaker, FloorUnderSunMatchesTheClosedFormInEveryMode) {
  FloorScene s;
  build_floor(s, 1.0f, 3.0f);
  for (ProbeSampling mode : {ProbeSampling::Point, ProbeSampling::Supersampled, ProbeSampling::Fitted}) {
    auto d = bake(floor_grid(1.0f, mode), s.world, *s.rays);
    ASSERT_TRUE(d.ok()) << d.error().message;
    EXPECT_LT(floor_error(*d, 1.0f, 3.0f), 0.02f) << to_string(mode);
    // Supersampled: the bottom nodes' tents reach 0.45 m below the floor; those samples see the
    // floor's back face and are dropped, so bottom nodes have partial coverage. Fitted: the tents
    // are folded into the box (which starts 5 cm above the floor), so every sample is in the domain.
    if (mode == ProbeSampling::Supersampled) {
      EXPECT_LT(d->validity[0], 1.0f);
      EXPECT_GT(d->validity[0], 0.0f);
    }
    if (mode == ProbeSampling::Fitted) {
      EXPECT_EQ(d->validity[0], 1.0f);
    }
    EXPECT_EQ(d->validity[d->node_count() - 1], 1.0f);
  }
}

// The same floor as a closed slab 10 cm thick with open space under it (the courtyard's ground):
// below the slab is in the domain (only the slab's front-facing underside is visible) and unlit.
// The fitted mode measures only the box, and its tents are folded into it: the bottom nodes match
// the closed form. The paper's supersampling averages that dark space in (36% of a bottom node's
// tent lies under the slab), a limitation of the domain-of-interest test on open-bottomed ground;
// with the leak guard the bottom node's reach downwards ends at the slab, so it averages only the
// lit side it serves and matches the closed form too.
TEST(ProbeBaker, FittedTentsStayInTheBoxAboveAGroundSlab) {
  World w;
  add_static(w, make_box({1000.0f, 0.05f, 1000.0f}), glm::translate(glm::mat4(1.0f), {0.0f, -0.05f, 0.0f}),
             glm::vec3(kRho));
  add_sun(w, 3.0f, {0, -1, 0});
  auto scene = RayScene::build(w);
  ASSERT_TRUE(scene.ok());
  const float up = sh_evaluate(floor_expansion(3.0f), {0, 1, 0}).x;
  auto fitted = bake(floor_grid(1.0f, ProbeSampling::Fitted), w, *scene);
  ASSERT_TRUE(fitted.ok()) << fitted.error().message;
  EXPECT_LT(floor_error(*fitted, 1.0f, 3.0f), 0.02f);
  EXPECT_EQ(fitted->validity[0], 1.0f);
  // The bottom node (y = 0.05) itself, facing up and down.
  for (glm::vec3 n : {glm::vec3(0, 1, 0), glm::vec3(0, -1, 0)})
    EXPECT_NEAR(sh_evaluate(fitted->node(0), n).x, sh_evaluate(floor_expansion(3.0f), n).x, 0.06f);
  IrradianceProbeGrid plain = floor_grid(1.0f, ProbeSampling::Supersampled);
  plain.leak_guard = false;
  auto super = bake(plain, w, *scene);
  ASSERT_TRUE(super.ok()) << super.error().message;
  EXPECT_LT(sh_evaluate(super->node(0), {0, 1, 0}).x, 0.85f * up);
  auto guarded = bake(floor_grid(1.0f, ProbeSampling::Supersampled), w, *scene);
  ASSERT_TRUE(guarded.ok()) << guarded.error().message;
  EXPECT_NEAR(sh_evaluate(guarded->node(0), {0, 1, 0}).x, up, 0.06f);
  EXPECT_LT(floor_error(*guarded, 1.0f, 3.0f), 0.02f);
}

// --- Leak guard: a thin wall between a sunlit and a shadowed half-space ------------------------

// A black wall 5 cm thick across the whole grid at z in [-0.4, -0.35] (between node planes, 0.35
// cells behind the middle one), the sun shining along -z, no bounces: each side's exact irradiance
// is one constant expansion (the sun's delta, cosine-convolved, in front; zero behind). Plain
// trilinear lookups leak light through the wall both ways in every mode; with the leak guard every
// mode reproduces both sides, since each side's receivers use only the nodes on their side.
TEST(ProbeBaker, LeakGuardStopsLightThroughAThinWall) {
  World w;
  add_static(w, make_box({100.0f, 100.0f, 0.025f}), glm::translate(glm::mat4(1.0f), {0.0f, 0.0f, -0.375f}),
             glm::vec3(0.0f));
  add_sun(w, 3.0f, {0, 0, -1});
  auto scene = RayScene::build(w);
  ASSERT_TRUE(scene.ok());
  SH9rgb radiance;
  sh_add_sample(radiance, {0, 0, 1}, glm::vec3(3.0f));
  const SH9rgb front = sh_convolve_cosine(radiance);
  // Receivers within one cell of the wall on either side, at random normals.
  Rng rng = Rng::stream(5, 0);
  std::vector<SurfacePoint> receivers;
  for (int i = 0; i < 400; ++i) {
    const bool behind = i % 2 == 0;
    const float z = behind ? -0.98f + 0.56f * rng.next_float() : -0.33f + 0.31f * rng.next_float();
    receivers.push_back({{-0.9f + 1.8f * rng.next_float(), -0.9f + 1.8f * rng.next_float(), z},
                         uniform_sphere({rng.next_float(), rng.next_float()})});
  }
  const auto rmse = [&](const ProbeGridData& d) {
    double sq = 0.0;
    for (const SurfacePoint& p : receivers) {
      const glm::vec3 exact =
          p.position.z < -0.375f ? glm::vec3(0.0f) : sh_evaluate_non_negative(front, p.normal, 3);
      const glm::vec3 diff = evaluate(d, p.position, p.normal) - exact;
      sq += double(glm::dot(diff, diff)) / 3.0;
    }
    return std::sqrt(sq / double(receivers.size()));
  };
  for (ProbeSampling mode : {ProbeSampling::Point, ProbeSampling::Supersampled, ProbeSampling::Fitted}) {
    IrradianceProbeGrid g = small_grid({-1, -1, -1}, {1, 1, 1}, {3, 3, 3}, mode);
    g.bounces = 0;
    g.leak_guard = false;
    auto plain = bake(g, w, *scene);
    g.leak_guard = true;
    auto guarded = bake(g, w, *scene);
    ASSERT_TRUE(plain.ok() && guarded.ok()) << to_string(mode);
    // Reach of the middle node plane: 0.35 cells down to the wall; of the bottom plane 0.6 up.
    EXPECT_NEAR(guarded->reach[6 * guarded->layout.node_index({1, 1, 1}) + 5], 0.35f * 255.0f, 1.0f);
    EXPECT_NEAR(guarded->reach[6 * guarded->layout.node_index({1, 1, 0}) + 4], 0.6f * 255.0f, 1.0f);
    EXPECT_EQ(guarded->reach[6 * guarded->layout.node_index({1, 1, 0}) + 0], 255);
    const double plain_error = rmse(*plain), guarded_error = rmse(*guarded);
    EXPECT_GT(plain_error, 0.1) << to_string(mode) << ": the plain lookup leaks";
    EXPECT_LT(guarded_error, 0.01) << to_string(mode) << " (plain " << plain_error << ")";
  }
}

// Nodes inside solids: inside a thick block (near one face, no face the other way within a cell)
// the node stays open on every side, so the paper's in-domain average serves the receivers outside
// it; inside a slab thinner than a cell (back faces both ways) it stays hidden.
TEST(ProbeBaker, LeakGuardOpensNodesInsideThickSolidsOnly) {
  World w;
  add_static(w, make_box({1.0f, 1.0f, 1.0f}), glm::mat4(1.0f), glm::vec3(0.5f));  // a 2 m block
  add_static(w, make_box({1.0f, 0.02f, 1.0f}), glm::translate(glm::mat4(1.0f), {3.0f, 0.25f, 0.0f}),
             glm::vec3(0.5f));  // a 4 cm slab around the node plane y = 0.25
  add_sun(w, 3.0f, {0, -1, 0});
  auto scene = RayScene::build(w);
  ASSERT_TRUE(scene.ok());
  IrradianceProbeGrid g = small_grid({-1.25f, -1.25f, -1.25f}, {4.25f, 1.25f, 1.25f}, {12, 6, 6},
                                     ProbeSampling::Supersampled);  // 0.5 m spacing
  g.bounces = 0;
  auto d = bake(g, w, *scene);
  ASSERT_TRUE(d.ok()) << d.error().message;
  const auto reach = [&](glm::uvec3 ijk) { return &d->reach[6 * d->layout.node_index(ijk)]; };
  // (0.75, 0.25, 0.25): 0.25 m inside the block's +x face.
  ASSERT_EQ(d->layout.node_position({4, 3, 3}), glm::vec3(0.75f, 0.25f, 0.25f));
  for (int k = 0; k < 6; ++k) EXPECT_EQ(reach({4, 3, 3})[k], 255) << "direction " << k;
  // (3.25, 0.25, 0.25): inside the slab, 2 cm from either face.
  ASSERT_EQ(d->layout.node_position({9, 3, 3}), glm::vec3(3.25f, 0.25f, 0.25f));
  EXPECT_LE(reach({9, 3, 3})[2], 11);  // +y: 0.02 m = 0.04 cells
  EXPECT_LE(reach({9, 3, 3})[3], 11);  // -y
  // (1.25, 0.25, 0.25): in the open, 0.25 m from the block's +x face, which hides it that way.
  EXPECT_NEAR(reach({5, 3, 3})[1], 127.5f, 1.0f);
  EXPECT_EQ(reach({5, 3, 3})[0], 255);
}

// Scaling the scene by 1e-3 or 1e4 leaves the relative error unchanged (ray offsets scale).
TEST(ProbeBaker, ScaleInvariance) {
  float reference = 0.0f;
  for (float scale : {1.0f, 1e-3f, 1e4f}) {
    FloorScene s;
    build_floor(s, scale, 3.0f);
    auto d = bake(floor_grid(scale, ProbeSampling::Supersampled), s.world, *s.rays);
    ASSERT_TRUE(d.ok()) << d.error().message;
    const float err = floor_error(*d, scale, 3.0f);
    if (scale == 1.0f) reference = err;
    EXPECT_NEAR(err, reference, 0.005f) << "scale " << scale;
    EXPECT_LT(err, 0.02f) << "scale " << scale;
  }
}

// A dark light gives exactly zero; a 1e6 light gives the same relative error, all finite.
TEST(ProbeBaker, LightsOfZeroAndHugeIntensity) {
  FloorScene dark;
  build_floor(dark, 1.0f, 0.0f);
  auto zero = bake(floor_grid(1.0f, ProbeSampling::Supersampled), dark.world, *dark.rays);
  ASSERT_TRUE(zero.ok());
  for (const glm::vec3& c : zero->coefficients) EXPECT_EQ(c, glm::vec3(0.0f));
  FloorScene bright;
  build_floor(bright, 1.0f, 1e6f);
  auto huge = bake(floor_grid(1.0f, ProbeSampling::Supersampled), bright.world, *bright.rays);
  ASSERT_TRUE(huge.ok());
  for (const glm::vec3& c : huge->coefficients) EXPECT_TRUE(std::isfinite(c.x) && std::isfinite(c.y) && std::isfinite(c.z));
  EXPECT_LT(floor_error(*huge, 1.0f, 1e6f), 0.02f);
}

// --- Determinism ---------------------------------------------------------------------------------

TEST(ProbeBaker, BitIdenticalAtOneAndTwoThreads) {
  World w;
  auto scene = builtin_ray_scene(w, "cornell");
  ASSERT_TRUE(scene.ok()) << scene.error().message;
  for (ProbeSampling mode : {ProbeSampling::Supersampled, ProbeSampling::Fitted}) {
    IrradianceProbeGrid g = small_grid({0.1f, 0.1f, 0.1f}, {0.5f, 0.5f, 0.5f}, {3, 3, 3}, mode);
    // The Cornell box is about 0.55 m wide, from the origin: the grid sits inside it.
    auto one = bake(g, w, *scene, 1, 77);
    auto two = bake(g, w, *scene, 2, 77);
    auto other_seed = bake(g, w, *scene, 2, 78);
    ASSERT_TRUE(one.ok() && two.ok() && other_seed.ok());
    EXPECT_EQ(one->coefficients, two->coefficients) << to_string(mode);
    EXPECT_EQ(one->validity, two->validity) << to_string(mode);
    EXPECT_NE(one->coefficients, other_seed->coefficients) << to_string(mode);
  }
}

// The noise target (IrradianceProbeGrid::noise) on the Cornell box's indirect light: the nodes
// noisier than the target trace more rays, so the node values of two seeds differ less (the
// bake's own noise falls), still bit-identical at one and two threads; a target every node meets
// changes nothing.
TEST(ProbeBaker, ANoiseTargetTracesMoreRaysWhereTheNodesAreNoisy) {
  World w;
  auto scene = builtin_ray_scene(w, "cornell");
  ASSERT_TRUE(scene.ok()) << scene.error().message;
  IrradianceProbeGrid g = small_grid({0.1f, 0.1f, 0.1f}, {0.5f, 0.5f, 0.5f}, {3, 3, 3}, ProbeSampling::Supersampled);
  g.lighting = LightingContent::Indirect;
  g.bounces = 2;
  g.rays_per_sample = 8;
  // Relative RMS difference of the nodes' constant terms between seeds 1 and 2.
  const auto spread = [&](const IrradianceProbeGrid& grid, ProbeGridData* first = nullptr) {
    auto a = bake(grid, w, *scene, 2, 1), b = bake(grid, w, *scene, 2, 2);
    EXPECT_TRUE(a.ok() && b.ok());
    if (!a.ok() || !b.ok()) return 0.0;
    double sq = 0.0, mean = 0.0;
    const std::size_t count = a->coefficients.size() / a->node_count();
    for (std::size_t n = 0; n < a->node_count(); ++n) {
      const glm::vec3 ca = a->coefficients[n * count], cb = b->coefficients[n * count];
      const double d = (ca.x + ca.y + ca.z - cb.x - cb.y - cb.z) / 3.0;
      sq += d * d;
      mean += (ca.x + ca.y + ca.z + cb.x + cb.y + cb.z) / 6.0;
    }
    if (first) *first = *a;
    const double nodes = double(a->node_count());
    return std::sqrt(sq / nodes) / (mean / nodes);
  };
  ProbeGridData plain_data, target_data;
  const double plain = spread(g, &plain_data);
  EXPECT_EQ(plain_data.refined_nodes, 0u);
  EXPECT_EQ(plain_data.ray_factor, 1.0f);
  g.noise = 0.01f;
  const double target = spread(g, &target_data);
  EXPECT_GT(target_data.refined_nodes, 0u);
  EXPECT_GT(target_data.ray_factor, 1.5f);
  EXPECT_LE(target_data.ray_factor, float(kProbeMaxRayFactor));
  EXPECT_LT(target, 0.7 * plain) << "seed-to-seed spread " << plain << " -> " << target << " at "
                                 << target_data.ray_factor << "x the rays";
  RecordProperty("spread_plain", std::to_string(plain));
  RecordProperty("spread_target", std::to_string(target));
  RecordProperty("ray_factor", std::to_string(target_data.ray_factor));
  auto one = bake(g, w, *scene, 1, 1);
  ASSERT_TRUE(one.ok());
  EXPECT_EQ(one->coefficients, target_data.coefficients);
  EXPECT_EQ(one->refined_nodes, target_data.refined_nodes);
  g.noise = 1.0f;
  auto met = bake(g, w, *scene, 2, 1);
  ASSERT_TRUE(met.ok());
  EXPECT_EQ(met->refined_nodes, 0u);
  EXPECT_EQ(met->coefficients, plain_data.coefficients);
}

// The Cornell box's short block: its front looks out of the box's open side, and both blocks are
// turned about the vertical, so nodes inside the block stay open to the leak guard's axis-aligned
// reach. The default grid baked at 8 samples a node and no noise target, against the path-traced
// indirect irradiance at 20 points of the front (16384 paths each; the mean's relative standard
// error 0.54 %): a moving receiver's lookup (the reach, which blends in the nodes inside the turned
// block whose tents lie mostly outside it) still shows the leak, 1.17x; a static receiver's does
// not, 1.032x. (The medium preset's bake, 20 s here, gives about 1.05x at these points and 1.053x
// over the face's pixels in penumbra bench image-accuracy: the grid's own error, not the leak.)
TEST(ProbeBaker, TheShortBlocksFrontTakesNoLightFromInsideTheBlock) {
  World w;
  auto scene = builtin_ray_scene(w, "cornell");
  ASSERT_TRUE(scene.ok()) << scene.error().message;
  auto grid = add_default_probe_grid(w, Preset::Medium);
  ASSERT_TRUE(grid.ok()) << grid.error().message;
  IrradianceProbeGrid g = w.get<IrradianceProbeGrid>(*grid);
  g.samples_per_node = 8;
  g.noise = 0.0f;
  auto data = bake(g, w, *scene, 2);
  ASSERT_TRUE(data.ok()) << data.error().message;
  const test_scenes::CornellFront front = test_scenes::cornell_short_block_front();
  const glm::vec3 n = front.normal;
  const IrradianceSettings reference = test_scenes::cornell_front_reference();
  const auto lights = gather_lights(w);
  double ref = 0.0, ref_var = 0.0, fixed = 0.0, moving = 0.0;
  const auto mean = [](glm::vec3 e) { return (double(e.x) + e.y + e.z) / 3.0; };
  for (std::size_t k = 0; k < front.points.size(); ++k) {
    const glm::vec3 x = front.points[k];
    Rng rng = Rng::stream(5, k);
    const Estimate e = irradiance(*scene, lights, x, n, reference, rng);
    ref += mean(e.value);
    ref_var += mean(e.std_error) * mean(e.std_error);
    fixed += mean(evaluate(*data, x, n, ProbeReceiver::Static));
    moving += mean(evaluate(*data, x, n, ProbeReceiver::Moving));
  }
  const double ref_stderr = std::sqrt(ref_var) / ref;
  RecordProperty("static_ratio", std::to_string(fixed / ref));
  RecordProperty("moving_ratio", std::to_string(moving / ref));
  RecordProperty("reference_relative_stderr", std::to_string(ref_stderr));
  ASSERT_LT(ref_stderr, 0.01) << "the reference is too noisy to judge 5 %";
  EXPECT_NEAR(fixed / ref, 1.0, 0.05) << "moving " << moving / ref;
  EXPECT_GT(moving / ref, 1.1) << "the test no longer sees the leak it guards against";
}

// --- Geometry swallowing the grid ----------------------------------------------------------------

TEST(ProbeBaker, EveryProbeInsideGeometryIsAClearErrorAndPartlyInsideIsFilled) {
  World w;
  add_static(w, make_box(glm::vec3(2.0f)), glm::mat4(1.0f), glm::vec3(0.5f));  // closed, outward faces
  add_sun(w, 3.0f, {0.0f, -1.0f, 0.0f});
  auto scene = RayScene::build(w);
  ASSERT_TRUE(scene.ok());
  // Entirely inside (tents included): every sample sees back faces.
  auto inside = bake(small_grid(glm::vec3(-1.0f), glm::vec3(1.0f), {3, 3, 3}, ProbeSampling::Supersampled), w, *scene);
  ASSERT_FALSE(inside.ok());
  EXPECT_EQ(inside.error().code, ErrorCode::InvalidInput);
  EXPECT_NE(inside.error().message.find("inside geometry"), std::string::npos) << inside.error().message;
  // Point mode keeps the classic behaviour: values at the nodes, validity 0, no error.
  auto classic = bake(small_grid(glm::vec3(-1.0f), glm::vec3(1.0f), {3, 3, 3}, ProbeSampling::Point), w, *scene);
  ASSERT_TRUE(classic.ok());
  EXPECT_EQ(classic->valid_fraction(), 0.0f);
  // Partly inside: 1 m spacing; the nodes at x = -1, 0, 1 have their whole tent inside the box
  // (x in [-2, 2]) and are filled from valid neighbours, and lit like them.
  IrradianceProbeGrid half =
      small_grid({-1.0f, -0.5f, -0.5f}, {7.0f, 0.5f, 0.5f}, {9, 2, 2}, ProbeSampling::Supersampled);
  auto d = bake(half, w, *scene);
  ASSERT_TRUE(d.ok()) << d.error().message;
  EXPECT_EQ(d->validity[0], 0.0f);  // x = -1: deep inside the box
  EXPECT_EQ(d->filled[0], 1);
  EXPECT_EQ(d->filled[4], 0);
  EXPECT_GT(d->validity[4], 0.0f);
  EXPECT_GT(sh_evaluate(d->node(0), {0, 1, 0}).x, 0.5f);  // sunlit value, not the dark inside
  EXPECT_EQ(d->filled[2], 1);
  EXPECT_NEAR(d->valid_fraction(), 24.0f / 36.0f, 1e-6f);
  // Fitted: the nodes at x = -1, 0, 1 have no in-domain point in their support and keep their
  // filled values exactly; the one on the box's face (x = 2) is fitted from the points outside
  // it, where it weighs little; all stay finite and sunlit.
  half.sampling = ProbeSampling::Fitted;
  auto f = bake(half, w, *scene);
  ASSERT_TRUE(f.ok()) << f.error().message;
  EXPECT_EQ(f->filled, d->filled);
  for (const glm::vec3& c : f->coefficients) EXPECT_TRUE(std::isfinite(c.x) && std::isfinite(c.y) && std::isfinite(c.z));
  for (std::size_t n = 0; n < f->node_count(); ++n)
    if (n % 9 <= 2) {
      EXPECT_EQ(f->node(n), d->node(n)) << "node " << n;
    }
  const float face = sh_evaluate(f->node(3), {0, 1, 0}).x, far = sh_evaluate(f->node(8), {0, 1, 0}).x;
  EXPECT_GT(face, 0.5f * far);
  EXPECT_LT(face, 2.0f * far);
}

// --- Budget and cancellation ----------------------------------------------------------------------

TEST(ProbeBaker, OverBudgetFailsBeforeAllocatingAndCancelStops) {
  World w;
  add_static(w, make_quad(10.0f, 10.0f), glm::mat4(1.0f), glm::vec3(0.5f));
  auto scene = RayScene::build(w);
  ASSERT_TRUE(scene.ok());
  IrradianceProbeGrid g = small_grid(glm::vec3(0.0f), glm::vec3(100.0f), {200, 200, 200}, ProbeSampling::Point);
  JobContext serial;
  MemoryBudget budget(64ull << 20);
  auto r = bake_probe_grid(g, glm::mat4(1.0f), *scene, {}, 1, serial, budget, "probe grid 'big'");
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().code, ErrorCode::OutOfBudget);
  EXPECT_NE(r.error().message.find("probe grid 'big'"), std::string::npos) << r.error().message;
  EXPECT_NE(r.error().message.find("larger spacing"), std::string::npos) << r.error().message;
  EXPECT_EQ(budget.reserved(), 0u);

  CancelToken cancel;
  cancel.cancel();
  JobContext cancelled(nullptr, {}, &cancel);
  MemoryBudget unlimited;
  auto c = bake_probe_grid(small_grid(glm::vec3(0.0f), glm::vec3(1.0f), {4, 4, 4}, ProbeSampling::Point),
                           glm::mat4(1.0f), *scene, {}, 1, cancelled, unlimited);
  ASSERT_FALSE(c.ok());
  EXPECT_EQ(c.error().code, ErrorCode::Cancelled);
  EXPECT_EQ(unlimited.reserved(), 0u);
}

// --- Baker, file and system ------------------------------------------------------------------------

TEST(ProbeBaker, BakeWorldAttachAndLightAReceiver) {
  World w;
  register_transform_systems(w);
  register_probe_grid_system(w);
  register_probe_grid_baker(w);
  ASSERT_TRUE(load_builtin(w, "cornell").ok());
  w.update(0.0);
  auto grid = add_default_probe_grid(w, Preset::Draft);
  ASSERT_TRUE(grid.ok()) << grid.error().message;
  w.patch<IrradianceProbeGrid>(*grid).resolution = {3, 3, 3};
  w.patch<IrradianceProbeGrid>(*grid).samples_per_node = 4;
  const Entity receiver = w.create();
  w.add<Transform>(receiver, Transform{{0.28f, 0.45f, 0.28f}});
  w.add<ProbeLit>(receiver);
  w.update(0.0);
  EXPECT_FALSE(w.get<ProbeLit>(receiver).covered);  // not baked yet

  BakeSettings settings;
  JobContext jobs;
  auto result = bake_world(w, {"probe-grid"}, settings, jobs);
  ASSERT_TRUE(result.ok()) << result.error().message;
  const BakeChunk* chunk = result->file.find(fourcc("PRBG"));
  ASSERT_NE(chunk, nullptr);
  ASSERT_EQ(result->report.items.size(), 1u);
  ASSERT_EQ(result->report.items[0].lines.size(), 2u);
  EXPECT_NE(result->report.items[0].lines[0].find("3x3x3"), std::string::npos);
  w.update(0.0);
  const ProbeLit& lit = w.get<ProbeLit>(receiver);
  ASSERT_TRUE(lit.covered);
  const auto& data = *w.get<IrradianceProbeGrid>(*grid).data;
  const glm::vec3 up(0, 1, 0);
  EXPECT_EQ(probe_lit_irradiance(lit, up), evaluate(data, {0.28f, 0.45f, 0.28f}, up));
  EXPECT_GT(probe_lit_irradiance(lit, up).x, 0.0f);

  // The same chunk attached to a fresh load of the scene gives the same data.
  World again;
  ASSERT_TRUE(load_builtin(again, "cornell").ok());
  update_world_transforms(again);
  auto grid2 = add_default_probe_grid(again, Preset::Draft);
  ASSERT_TRUE(grid2.ok());
  ASSERT_EQ(grid2->index, grid->index);
  ASSERT_TRUE(attach_bake(again, result->file).ok());
  EXPECT_EQ(again.get<IrradianceProbeGrid>(*grid2).data->coefficients, data.coefficients);
  World empty;
  EXPECT_EQ(attach_bake(empty, result->file).error().code, ErrorCode::NotFound);
}

}  // namespace
}  // namespace penumbra
