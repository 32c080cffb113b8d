#include "penumbra/bake/integrators.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <limits>
#include <memory>
#include <numbers>
#include <vector>

#include <glm/gtc/matrix_transform.hpp>

#include "penumbra/core/random.h"
#include "penumbra/ecs/transform.h"
#include "penumbra/scene/components.h"
#include "penumbra/scene/builtin.h"
#include "penumbra/scene/mesh.h"

namespace penumbra {
namespace {

constexpr float kPi = std::numbers::pi_v<float>;
constexpr float kInf = std::numeric_limits<float>::infinity();

Entity add_mesh(World& world, MeshData mesh, const glm::mat4& m, glm::vec3 albedo = glm::vec3(1.0f),
                glm::vec3 emissive = glm::vec3(0.0f)) {
  Entity e = world.create();
  world.add<Mesh>(e, Mesh{std::make_shared<const MeshData>(std::move(mesh))});
  world.add<WorldTransform>(e, WorldTransform{m});
  Material mat;
  mat.base_color = glm::vec4(albedo, 1.0f);
  mat.emissive = emissive;
  world.add<Material>(e, mat);
  world.add<Static>(e);
  return e;
}

Entity add_light(World& world, const Light& light, const glm::mat4& m) {
  Entity e = world.create();
  world.add<Light>(e, light);
  world.add<WorldTransform>(e, WorldTransform{m});
  return e;
}

// make_quad faces +Z; this turns it to face +Y (a floor), centred at `at`.
glm::mat4 floor_at(glm::vec3 at) {
  return glm::rotate(glm::translate(glm::mat4(1.0f), at), glm::radians(-90.0f), {1.0f, 0.0f, 0.0f});
}

// --- (1) AO of a point on a plane beside a sphere ---------------------------------------------

// A sphere of radius R whose centre is at distance D from x, at angle beta from n, fully above
// the horizon, occludes the cosine-weighted fraction cos(beta) (R / D)^2 (the projected cap).
TEST(Integrators, AmbientOcclusionOfSphereBesidePointOnPlane) {
  World world;
  add_mesh(world, make_quad(100.0f, 100.0f), floor_at({0.0f, 0.0f, 0.0f}));
  const glm::vec3 centre(1.5f, 2.0f, 0.0f);
  const float radius = 1.0f;
  add_mesh(world, make_icosphere(radius, 6), glm::translate(glm::mat4(1.0f), centre));  // 81,920 triangles
  auto scene = RayScene::build(world);
  ASSERT_TRUE(scene.ok()) << scene.error().message;
  ASSERT_GE(scene->triangle_count(), 80000u);

  // Receivers on the plane with the plane's normal; the plane itself never occludes them.
  const glm::vec3 up(0.0f, 1.0f, 0.0f);
  for (const glm::vec3& x : {glm::vec3(0.0f), glm::vec3(-1.0f, 0.0f, 0.8f)}) {
    const float d = glm::length(centre - x);
    const float cos_beta = glm::dot(up, centre - x) / d;
    ASSERT_LT(std::acos(cos_beta) + std::asin(radius / d), kPi / 2) << "sphere must be above the horizon";
    const float expected = 1.0f - cos_beta * (radius / d) * (radius / d);
    Rng rng = Rng::stream(11, 0);
    const AoEstimate ao = ambient_occlusion(*scene, x, up, kInf, 200000, rng);
    EXPECT_EQ(ao.samples, 200000u);
    EXPECT_LT(ao.std_error, 1.5e-3f);  // small against the occluded fraction (> 0.05): a meaningful test
    EXPECT_LT(expected, 0.95f);
    EXPECT_NEAR(ao.value, expected, 3.0f * ao.std_error) << "x = " << x.x << "," << x.y << "," << x.z;
  }
  // Beyond max_distance nothing occludes: exactly 1.
  Rng rng = Rng::stream(12, 0);
  const float gap = glm::length(centre) - radius;
  const AoEstimate near_only = ambient_occlusion(*scene, glm::vec3(0.0f), up, 0.9f * gap, 4096, rng);
  EXPECT_EQ(near_only.value, 1.0f);
  EXPECT_EQ(near_only.std_error, 0.0f);
}

// Sobol' AO (the default of the batched integrator) against the closed form above over a ring of
// receivers: unbiased, with an error bar whose mean square matches the actual squared error, and
// with half the rays below the noise of independent rays.
TEST(Integrators, SobolAmbientOcclusionNeedsHalfTheRaysWithAnHonestErrorBar) {
  World world;
  add_mesh(world, make_quad(100.0f, 100.0f), floor_at({0.0f, 0.0f, 0.0f}));
  const glm::vec3 centre(0.0f, 2.0f, 0.0f);
  const float radius = 1.0f;
  add_mesh(world, make_icosphere(radius, 6), glm::translate(glm::mat4(1.0f), centre));
  auto scene = RayScene::build(world);
  ASSERT_TRUE(scene.ok()) << scene.error().message;
  const glm::vec3 up(0.0f, 1.0f, 0.0f);
  constexpr int kPoints = 256;
  std::vector<SurfacePoint> points(kPoints);
  std::vector<float> expected(kPoints);
  for (int i = 0; i < kPoints; ++i) {
    const float angle = 2.0f * kPi * float(i) / kPoints, r = 0.5f + 1.5f * float(i % 16) / 16.0f;
    points[i].position = glm::vec3(r * std::cos(angle), 0.0f, r * std::sin(angle));
    points[i].normal = up;
    const float d = glm::length(centre - points[i].position);
    const float cos_beta = glm::dot(up, centre - points[i].position) / d;
    ASSERT_LT(std::acos(cos_beta) + std::asin(radius / d), kPi / 2);
    expected[i] = 1.0f - cos_beta * (radius / d) * (radius / d);
  }
  const auto errors = [&](AoSampling sampling, std::uint32_t rays, double& mean_square, double& mean_se2) {
    AoSettings settings;
    settings.rays = rays;
    settings.seed = 5;
    settings.sampling = sampling;
    std::vector<AoEstimate> out(kPoints);
    JobContext jobs;
    ASSERT_TRUE(ambient_occlusion(*scene, points, settings, out, jobs).ok());
    mean_square = mean_se2 = 0.0;
    for (int i = 0; i < kPoints; ++i) {
      const double e = double(out[i].value) - expected[i];
      mean_square += e * e / kPoints;
      mean_se2 += double(out[i].std_error) * out[i].std_error / kPoints;
    }
  };
  double sobol_ms = 0, sobol_se2 = 0, mc_ms = 0, mc_se2 = 0;
  errors(AoSampling::Sobol, 64, sobol_ms, sobol_se2);
  errors(AoSampling::Independent, 128, mc_ms, mc_se2);
  std::printf("RMS error: Sobol 64 rays %.4f (error bar %.4f), independent 128 rays %.4f (error bar %.4f)\n",
              std::sqrt(sobol_ms), std::sqrt(sobol_se2), std::sqrt(mc_ms), std::sqrt(mc_se2));
  EXPECT_LT(sobol_ms, mc_ms);  // half the rays, less noise
  // Both error bars are unbiased estimates of the variance: the ratio is 1 up to the noise of 256 points.
  EXPECT_GT(sobol_ms / sobol_se2, 0.5);
  EXPECT_LT(sobol_ms / sobol_se2, 2.0);
  EXPECT_GT(mc_ms / mc_se2, 0.5);
  EXPECT_LT(mc_ms / mc_se2, 2.0);
}

// --- (2) Furnace --------------------------------------------------------------------------------

// Inside a closed inward-facing sphere of albedo rho and emission Le, E = pi Le sum_k rho^k.
TEST(Integrators, FurnaceIrradiance) {
  World world;
  const glm::vec3 rho(0.3f, 0.5f, 0.7f), le(1.0f, 2.0f, 0.5f);
  add_mesh(world, make_icosphere(1.0f, 3, /*inward=*/true), glm::mat4(1.0f), rho, le);
  auto scene = RayScene::build(world);
  ASSERT_TRUE(scene.ok()) << scene.error().message;
  const std::vector<WorldLight> no_lights;
  const glm::vec3 x(0.2f, -0.3f, 0.1f), n = glm::normalize(glm::vec3(1.0f, 2.0f, -0.5f));

  // N bounces: every path sees the same walls, so the estimate is exact (zero variance).
  for (std::uint32_t bounces : {0u, 1u, 3u}) {
    IrradianceSettings s;
    s.samples = 64;
    s.bounces = bounces;
    Rng rng = Rng::stream(3, bounces);
    const Estimate e = irradiance(*scene, no_lights, x, n, s, rng);
    glm::vec3 expected(0.0f), rho_k(1.0f);
    for (std::uint32_t k = 0; k <= bounces; ++k, rho_k *= rho) expected += kPi * le * rho_k;
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(e.value[c], expected[c], 1e-5f * expected[c]) << bounces;
    // Indirect content: the same sum without the walls' emission seen from x (k = 0).
    s.content = LightingContent::Indirect;
    const Estimate ind = irradiance(*scene, no_lights, x, n, s, rng);
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(ind.value[c], expected[c] - kPi * le[c], 1e-5f * expected[c]) << bounces;
  }

  // Reference (all bounces, Russian roulette): pi Le / (1 - rho) within 3 standard errors.
  IrradianceSettings ref;
  ref.reference = true;
  ref.samples = 20000;
  Rng rng = Rng::stream(5, 0);
  const Estimate e = irradiance(*scene, no_lights, x, n, ref, rng);
  const glm::vec3 expected = kPi * le / (1.0f - rho);
  for (int c = 0; c < 3; ++c) {
    EXPECT_GT(e.std_error[c], 0.0f);
    EXPECT_LT(e.std_error[c], 0.01f * expected[c]);
    EXPECT_NEAR(e.value[c], expected[c], 3.0f * e.std_error[c]) << "channel " << c;
  }
  // Indirect reference: pi Le rho / (1 - rho).
  ref.content = LightingContent::Indirect;
  const Estimate ind = irradiance(*scene, no_lights, x, n, ref, rng);
  for (int c = 0; c < 3; ++c) {
    const float expected_indirect = kPi * le[c] * rho[c] / (1.0f - rho[c]);
    EXPECT_LT(ind.std_error[c], 0.01f * expected[c]);
    EXPECT_NEAR(ind.value[c], expected_indirect, 3.0f * ind.std_error[c]) << "channel " << c;
  }
}

// The built-in furnace scene states its own closed form.
TEST(Integrators, BuiltinFurnaceReference) {
  World world;
  auto loaded = load_builtin(world, "furnace");
  ASSERT_TRUE(loaded.ok()) << loaded.error().message;
  update_world_transforms(world);
  auto scene = RayScene::build(world);
  ASSERT_TRUE(scene.ok()) << scene.error().message;
  IrradianceSettings ref;
  ref.reference = true;
  ref.samples = 8000;
  Rng rng = Rng::stream(6, 0);
  const Estimate e = irradiance(*scene, gather_lights(world), glm::vec3(0.1f, 0.2f, -0.3f), glm::vec3(0, 0, 1), ref, rng);
  for (int c = 0; c < 3; ++c) {
    EXPECT_LT(e.std_error[c], 0.02f * kFurnaceIrradiance);
    EXPECT_NEAR(e.value[c], kFurnaceIrradiance, 3.0f * e.std_error[c]) << "channel " << c;
  }
}

// --- (4) Direct light from each light type ------------------------------------------------------

// An environment map lights by its directions: with L(d) = (max(0, d.x), max(0, d.y), max(0, -d.z))
// (a 128 x 64 map of it) a point facing up receives E = (2/3, 2 pi / 3, 2/3) (the cosine-weighted
// integrals over the upper hemisphere), up to the map's bilinear texels; the ray scene looks the
// map up by direction.
TEST(Integrators, AnEnvironmentMapLightsByItsDirections) {
  World world;
  add_mesh(world, make_quad(2000.0f, 2000.0f), floor_at({0.0f, 0.0f, 0.0f}), glm::vec3(0.5f));
  const std::uint32_t w = 128, h = 64;
  std::vector<glm::vec3> texels;
  for (std::uint32_t y = 0; y < h; ++y)
    for (std::uint32_t x = 0; x < w; ++x) {
      const float phi = ((float(x) + 0.5f) / float(w) - 0.5f) * 2.0f * kPi, theta = (float(y) + 0.5f) / float(h) * kPi;
      const glm::vec3 d(std::sin(theta) * std::sin(phi), std::cos(theta), -std::sin(theta) * std::cos(phi));
      texels.push_back(glm::max(glm::vec3(d.x, d.y, -d.z), glm::vec3(0.0f)));
    }
  auto map = make_environment_map(w, h, std::move(texels), "test map");
  ASSERT_TRUE(map.ok()) << map.error().message;
  Environment sky;
  sky.map_data = *map;
  world.add<Environment>(world.create(), sky);
  auto scene = RayScene::build(world);
  ASSERT_TRUE(scene.ok()) << scene.error().message;
  EXPECT_NEAR(scene->sky({1.0f, 0.0f, 0.0f}).x, 1.0f, 0.01f);
  EXPECT_NEAR(scene->sky({-1.0f, 0.0f, 0.0f}).x, 0.0f, 0.01f);
  IrradianceSettings s;
  s.samples = 16384;
  s.reference = true;
  Rng rng = Rng::stream(7, 0);
  const Estimate up = irradiance(*scene, {}, {0.0f, 0.01f, 0.0f}, {0.0f, 1.0f, 0.0f}, s, rng);
  const glm::vec3 expected(2.0f / 3.0f, 2.0f * kPi / 3.0f, 2.0f / 3.0f);
  for (int c = 0; c < 3; ++c)
    EXPECT_NEAR(up.value[c], expected[c], 4.0f * up.std_error[c] + 0.01f * expected[c]) << c;
}

// A uniform sky of radiance L over an open floor of albedo rho: facing up E = pi L exactly (every
// path leaves at once: no variance); facing the floor from just above it, E = pi rho L (the floor,
// lit by the sky, is all it sees), up to the floor's finite size; in Indirect content the same
// (the sky is ambient light); without a sky, nothing.
TEST(Integrators, SkyLightsByItsClosedForms) {
  World world;
  const float rho = 0.6f;
  add_mesh(world, make_quad(2000.0f, 2000.0f), floor_at({0.0f, 0.0f, 0.0f}), glm::vec3(rho));
  const glm::vec3 sky(0.2f, 0.3f, 0.5f);
  world.add<Environment>(world.create(), Environment{sky});
  auto scene = RayScene::build(world);
  ASSERT_TRUE(scene.ok()) << scene.error().message;
  EXPECT_EQ(scene->sky({0.0f, 1.0f, 0.0f}), sky);
  IrradianceSettings s;
  s.samples = 4096;
  s.reference = true;
  for (LightingContent content : {LightingContent::All, LightingContent::Indirect}) {
    s.content = content;
    Rng rng = Rng::stream(5, 0);
    const Estimate up = irradiance(*scene, {}, {0.0f, 0.01f, 0.0f}, {0.0f, 1.0f, 0.0f}, s, rng);
    EXPECT_LT(glm::length(up.value - kPi * sky), 1e-5f);
    EXPECT_EQ(up.std_error, glm::vec3(0.0f));
    const Estimate down = irradiance(*scene, {}, {0.0f, 0.01f, 0.0f}, {0.0f, -1.0f, 0.0f}, s, rng);
    for (int c = 0; c < 3; ++c)
      EXPECT_NEAR(down.value[c], kPi * rho * sky[c], 4.0f * down.std_error[c] + 1e-3f * kPi * sky[c]) << c;
  }
  World dark;
  add_mesh(dark, make_quad(2000.0f, 2000.0f), floor_at({0.0f, 0.0f, 0.0f}), glm::vec3(rho));
  auto none = RayScene::build(dark);
  ASSERT_TRUE(none.ok());
  Rng rng = Rng::stream(5, 0);
  EXPECT_EQ(irradiance(*none, {}, {0.0f, 0.01f, 0.0f}, {0.0f, 1.0f, 0.0f}, s, rng).value, glm::vec3(0.0f));
}

TEST(Integrators, DirectLightClosedForms) {
  World world;
  add_mesh(world, make_quad(50.0f, 50.0f), floor_at({0.0f, 0.0f, 0.0f}), glm::vec3(0.0f));  // black floor
  auto scene = RayScene::build(world);
  ASSERT_TRUE(scene.ok()) << scene.error().message;
  const glm::vec3 x(0.0f), n(0.0f, 1.0f, 0.0f);
  IrradianceSettings s;
  s.samples = 2;
  s.bounces = 0;
  const auto e_of = [&](const Light& light, const glm::mat4& m, std::uint32_t samples = 2) {
    World lw;
    add_light(lw, light, m);
    const std::vector<WorldLight> lights = gather_lights(lw);
    EXPECT_EQ(lights.size(), 1u);
    IrradianceSettings si = s;
    si.samples = samples;
    Rng rng = Rng::stream(9, 0);
    return irradiance(*scene, lights, x, n, si, rng);
  };
  const auto rel = [](glm::vec3 a, glm::vec3 b) { return glm::length(a - b) / std::max(glm::length(b), 1e-20f); };

  // Point light: I cos / d^2.
  Light point;
  point.type = Light::Type::Point;
  point.intensity = 10.0f;
  point.color = {1.0f, 0.5f, 0.25f};
  const glm::vec3 lp(0.7f, 2.0f, -0.4f);
  const float d = glm::length(lp), cos_x = lp.y / d;
  EXPECT_LT(rel(e_of(point, glm::translate(glm::mat4(1.0f), lp)).value, point.color * 10.0f * cos_x / (d * d)), 1e-4f);
  // With a range: the KHR_lights_punctual window (1 - (d/r)^4)^2.
  point.range = 4.0f;
  const float w = 1.0f - std::pow(d / 4.0f, 4.0f);
  EXPECT_LT(rel(e_of(point, glm::translate(glm::mat4(1.0f), lp)).value,
                point.color * 10.0f * cos_x * w * w / (d * d)), 1e-4f);
  point.range = 0.5f * d;
  EXPECT_EQ(e_of(point, glm::translate(glm::mat4(1.0f), lp)).value, glm::vec3(0.0f));
  point.range = 0.0f;
  // Below the horizon of n: nothing.
  EXPECT_EQ(e_of(point, glm::translate(glm::mat4(1.0f), {1.0f, -1.0f, 0.0f})).value, glm::vec3(0.0f));

  // Spot light pointing straight down (local -Z to world -Y), 2 m above x.
  Light spot = point;
  spot.type = Light::Type::Spot;
  spot.inner_cone_angle = 0.2f;
  spot.outer_cone_angle = 0.5f;
  const auto spot_at = [](glm::vec3 p) {
    return glm::rotate(glm::translate(glm::mat4(1.0f), p), glm::radians(-90.0f), {1.0f, 0.0f, 0.0f});
  };
  const auto spot_expected = [&](glm::vec3 p) {
    const float dist = glm::length(p);
    const float cd = p.y / dist;  // cos of the angle between the spot axis and the direction to x
    const float t = glm::clamp((cd - std::cos(0.5f)) / (std::cos(0.2f) - std::cos(0.5f)), 0.0f, 1.0f);
    return spot.color * spot.intensity * (p.y / dist) * t * t / (dist * dist);
  };
  const glm::vec3 inside(0.1f, 2.0f, 0.0f), edge(0.7f, 2.0f, 0.0f), outside(1.5f, 2.0f, 0.0f);
  EXPECT_LT(rel(e_of(spot, spot_at(inside)).value, spot_expected(inside)), 1e-4f);
  EXPECT_GT(spot_expected(edge).x, 0.0f);
  EXPECT_LT(spot_expected(edge).x, spot.intensity * 0.9f / glm::dot(edge, edge));  // inside the falloff
  EXPECT_LT(rel(e_of(spot, spot_at(edge)).value, spot_expected(edge)), 1e-4f);
  EXPECT_EQ(e_of(spot, spot_at(outside)).value, glm::vec3(0.0f));

  // Directional: illuminance x cos, light going along local -Z rotated to come in at 60 degrees.
  Light sun;
  sun.type = Light::Type::Directional;
  sun.intensity = 3.0f;
  const glm::mat4 tilt = glm::rotate(glm::mat4(1.0f), glm::radians(-60.0f), {1.0f, 0.0f, 0.0f});
  EXPECT_LT(rel(e_of(sun, tilt).value, glm::vec3(3.0f * std::cos(glm::radians(30.0f)))), 1e-5f);

  // Rect light of half sizes a x b, parallel, centred h above x, facing down:
  // E = pi L F, F = 4 F_corner(a, b, h) (the differential-area-to-parallel-rectangle form factor).
  Light rect;
  rect.type = Light::Type::Rect;
  rect.intensity = 2.0f;
  rect.size = {1.2f, 0.8f};
  const float a = 0.6f, b = 0.4f, h = 0.5f;
  const auto corner = [](float p, float q) {
    const float sp = std::sqrt(1.0f + p * p), sq = std::sqrt(1.0f + q * q);
    return (p / sp * std::atan(q / sp) + q / sq * std::atan(p / sq)) / (2.0f * kPi);
  };
  const float expected_rect = kPi * 2.0f * 4.0f * corner(a / h, b / h);
  const Estimate er = e_of(rect, spot_at({0.0f, h, 0.0f}), 512);
  for (int c = 0; c < 3; ++c) {
    EXPECT_LT(er.std_error[c], 0.005f * expected_rect);
    EXPECT_NEAR(er.value[c], expected_rect, 3.0f * er.std_error[c] + 1e-4f * expected_rect);
  }
  // Facing away (rotated to shine up): nothing reaches x.
  EXPECT_EQ(e_of(rect, glm::rotate(glm::translate(glm::mat4(1.0f), {0.0f, h, 0.0f}), glm::radians(90.0f),
                                   {1.0f, 0.0f, 0.0f}))
                .value,
            glm::vec3(0.0f));

  // A blocker between x and the lights casts a full shadow.
  World blocked;
  add_mesh(blocked, make_quad(50.0f, 50.0f), floor_at({0.0f, 0.0f, 0.0f}), glm::vec3(0.0f));
  add_mesh(blocked, make_quad(20.0f, 20.0f), floor_at({0.0f, 0.3f, 0.0f}), glm::vec3(0.0f));
  add_light(blocked, point, glm::translate(glm::mat4(1.0f), lp));
  add_light(blocked, sun, tilt);
  add_light(blocked, rect, spot_at({0.0f, h, 0.0f}));
  auto shadowed = RayScene::build(blocked);
  ASSERT_TRUE(shadowed.ok());
  Rng rng = Rng::stream(1, 0);
  const std::vector<WorldLight> lights = gather_lights(blocked);
  EXPECT_EQ(lights.size(), 3u);
  EXPECT_EQ(irradiance(*shadowed, lights, x, n, s, rng).value, glm::vec3(0.0f));
}

// --- (3) Energy balance in a Cornell box --------------------------------------------------------

struct Cornell {
  World world;
  struct Surface { std::shared_ptr<const MeshData> mesh; glm::mat4 m; glm::vec3 albedo; };
  std::vector<Surface> surfaces;
  float light_radiance = 4.0f;
  glm::vec2 light_size{0.5f, 0.4f};

  void add(MeshData mesh, const glm::mat4& m, glm::vec3 albedo) {
    Entity e = add_mesh(world, std::move(mesh), m, albedo);
    surfaces.push_back({world.get<Mesh>(e).data, m, albedo});
  }
  // Box x in [-1, 1], y in [0, 2], z in [-1, 1], open at z = +1; walls face inwards.
  Cornell() {
    const glm::mat4 id(1.0f);
    const glm::vec3 white(0.7f), red(0.6f, 0.1f, 0.1f), green(0.1f, 0.6f, 0.15f);
    add(make_quad(2, 2), floor_at({0, 0, 0}), white);                                                    // floor
    add(make_quad(2, 2), glm::rotate(glm::translate(id, {0, 2, 0}), glm::radians(90.0f), {1, 0, 0}), white);  // ceiling
    add(make_quad(2, 2), glm::translate(id, {0, 1, -1}), white);                                          // back
    add(make_quad(2, 2), glm::rotate(glm::translate(id, {-1, 1, 0}), glm::radians(90.0f), {0, 1, 0}), red);   // left
    add(make_quad(2, 2), glm::rotate(glm::translate(id, {1, 1, 0}), glm::radians(-90.0f), {0, 1, 0}), green); // right
    add(make_box({0.3f, 0.3f, 0.3f}), glm::rotate(glm::translate(id, {-0.4f, 0.3f, 0.2f}), 0.3f, {0, 1, 0}), white);
    add(make_box({0.3f, 0.6f, 0.3f}), glm::rotate(glm::translate(id, {0.4f, 0.6f, -0.3f}), -0.3f, {0, 1, 0}), white);
    Light light;
    light.type = Light::Type::Rect;
    light.intensity = light_radiance;
    light.size = light_size;
    add_light(world, light, glm::rotate(glm::translate(id, {0, 1.99f, 0}), glm::radians(-90.0f), {1, 0, 0}));
  }
};

// Area-uniform random points on a mesh in world space (triangle by area, then uniform barycentrics).
std::vector<SurfacePoint> sample_surface(const MeshData& mesh, const glm::mat4& m, std::size_t count, Rng& rng,
                                         float& area) {
  std::vector<float> cdf;
  area = 0.0f;
  const auto corner = [&](std::size_t t, int j) {
    return glm::vec3(m * glm::vec4(mesh.positions[mesh.indices[3 * t + j]], 1.0f));
  };
  for (std::size_t t = 0; t < mesh.triangle_count(); ++t) {
    area += 0.5f * glm::length(glm::cross(corner(t, 1) - corner(t, 0), corner(t, 2) - corner(t, 0)));
    cdf.push_back(area);
  }
  std::vector<SurfacePoint> points;
  for (std::size_t i = 0; i < count; ++i) {
    const float pick = rng.next_float() * area;
    const std::size_t t = std::min<std::size_t>(
        static_cast<std::size_t>(std::upper_bound(cdf.begin(), cdf.end(), pick) - cdf.begin()), cdf.size() - 1);
    float u = rng.next_float(), v = rng.next_float();
    if (u + v > 1.0f) { u = 1.0f - u; v = 1.0f - v; }
    const glm::vec3 p0 = corner(t, 0), p1 = corner(t, 1), p2 = corner(t, 2);
    points.push_back({p0 + u * (p1 - p0) + v * (p2 - p0), glm::normalize(glm::cross(p1 - p0, p2 - p0))});
  }
  return points;
}

TEST(Integrators, CornellBoxEnergyBalance) {
  Cornell box;
  auto scene = RayScene::build(box.world);
  ASSERT_TRUE(scene.ok()) << scene.error().message;
  const std::vector<WorldLight> lights = gather_lights(box.world);
  ASSERT_EQ(lights.size(), 1u);
  ThreadPool pool(2);
  JobContext jobs(&pool);
  IrradianceSettings s;
  s.reference = true;
  s.samples = 2;
  s.rect_light_samples = 4;
  const std::size_t per_surface = 6000;

  // Flux through a set of points: area x mean of f(E), with the variance of that mean.
  Rng rng = Rng::stream(21, 0);
  glm::dvec3 absorbed(0.0), absorbed_var(0.0);
  const auto integrate = [&](const std::vector<SurfacePoint>& points, float area, glm::vec3 weight,
                             glm::dvec3& total, glm::dvec3& var) {
    std::vector<Estimate> out(points.size());
    ASSERT_TRUE(irradiance(*scene, lights, points, s, out, jobs).ok());
    glm::dvec3 sum(0.0), sum_sq(0.0);
    for (const Estimate& e : out) {
      const glm::dvec3 f = glm::dvec3(e.value * weight) * double(area);
      sum += f;
      sum_sq += f * f;
    }
    const double n = double(points.size());
    const glm::dvec3 mean = sum / n;
    total += mean;
    var += (sum_sq / n - mean * mean) / (n - 1.0);
  };
  for (const auto& surface : box.surfaces) {
    float area = 0.0f;
    const auto points = sample_surface(*surface.mesh, surface.m, per_surface, rng, area);
    integrate(points, area, glm::vec3(1.0f) - surface.albedo, absorbed, absorbed_var);
  }
  // The open front (z = 1), irradiance facing into the box: what leaves through it.
  float opening_area = 0.0f;
  const glm::mat4 opening = glm::rotate(glm::translate(glm::mat4(1.0f), {0, 1, 1}), glm::radians(180.0f), {0, 1, 0});
  const auto front = sample_surface(make_quad(2, 2), opening, 4 * per_surface, rng, opening_area);
  ASSERT_NEAR(front[0].normal.z, -1.0f, 1e-5f);
  glm::dvec3 escaped(0.0), escaped_var(0.0);
  integrate(front, opening_area, glm::vec3(1.0f), escaped, escaped_var);

  const double emitted = kPi * box.light_radiance * box.light_size.x * box.light_size.y;
  for (int c = 0; c < 3; ++c) {
    const double se = std::sqrt(absorbed_var[c] + escaped_var[c]);
    EXPECT_LT(se, 0.03 * emitted);
    EXPECT_GT(escaped[c], 0.05 * emitted);  // both terms matter
    EXPECT_NEAR(absorbed[c] + escaped[c], emitted, 3.0 * se)
        << "channel " << c << ": absorbed " << absorbed[c] << " + escaped " << escaped[c];
  }
}

// --- (5) Determinism at 1 and 2 threads, (6) invalid input --------------------------------------

TEST(Integrators, BatchesAreBitIdenticalAtOneAndTwoThreads) {
  Cornell box;
  auto scene = RayScene::build(box.world);
  ASSERT_TRUE(scene.ok());
  const std::vector<WorldLight> lights = gather_lights(box.world);
  Rng rng = Rng::stream(4, 0);
  float area = 0.0f;
  const auto points = sample_surface(*box.surfaces[0].mesh, box.surfaces[0].m, 200, rng, area);

  IrradianceSettings s;
  s.samples = 8;
  s.bounces = 2;
  s.seed = 99;
  AoSettings ao;
  ao.rays = 128;
  ao.max_distance = 1.0f;
  ao.seed = 5;
  std::vector<Estimate> e1(points.size()), e2(points.size());
  std::vector<AoEstimate> a1(points.size()), a2(points.size());
  {
    ThreadPool pool(1);
    JobContext jobs(&pool);
    ASSERT_TRUE(irradiance(*scene, lights, points, s, e1, jobs).ok());
    ASSERT_TRUE(ambient_occlusion(*scene, points, ao, a1, jobs).ok());
  }
  {
    ThreadPool pool(2);
    JobContext jobs(&pool);
    ASSERT_TRUE(irradiance(*scene, lights, points, s, e2, jobs).ok());
    ASSERT_TRUE(ambient_occlusion(*scene, points, ao, a2, jobs).ok());
  }
  EXPECT_EQ(std::memcmp(e1.data(), e2.data(), e1.size() * sizeof(Estimate)), 0);
  EXPECT_EQ(std::memcmp(a1.data(), a2.data(), a1.size() * sizeof(AoEstimate)), 0);
  // Not trivially equal: most points are lit, and by different amounts.
  std::size_t lit = 0, distinct = 0;
  for (std::size_t i = 0; i < e1.size(); ++i) {
    lit += e1[i].value.x > 0.0f ? 1 : 0;
    distinct += (i > 0 && e1[i].value != e1[i - 1].value) ? 1 : 0;
  }
  EXPECT_GT(lit, e1.size() / 2);
  EXPECT_GT(distinct, e1.size() / 2);
  // A different seed changes the estimates.
  s.seed = 100;
  JobContext serial;
  ASSERT_TRUE(irradiance(*scene, lights, points, s, e2, serial).ok());
  EXPECT_NE(std::memcmp(e1.data(), e2.data(), e1.size() * sizeof(Estimate)), 0);
}

TEST(Integrators, InvalidInputIsAValueNotACrash) {
  Cornell box;
  auto scene = RayScene::build(box.world);
  ASSERT_TRUE(scene.ok());
  const std::vector<WorldLight> lights = gather_lights(box.world);
  const float nan = std::numeric_limits<float>::quiet_NaN();
  // A NaN receiver: no ray reaches Embree, every one is counted; the process survives.
  Rng rng = Rng::stream(1, 0);
  const std::uint64_t before = scene->invalid_ray_count();
  const AoEstimate ao = ambient_occlusion(*scene, glm::vec3(nan, 0.5f, 0.0f), glm::vec3(0, 1, 0), 1.0f, 64, rng);
  EXPECT_EQ(ao.samples, 64u);
  EXPECT_EQ(scene->invalid_ray_count(), before + 64);
  IrradianceSettings s;
  s.samples = 4;
  const Estimate e = irradiance(*scene, lights, glm::vec3(0.0f, nan, 0.0f), glm::vec3(0, 1, 0), s, rng);
  EXPECT_EQ(e.samples, 4u);
  EXPECT_GT(scene->invalid_ray_count(), before + 64);

  // Bad settings are errors naming the setting.
  JobContext jobs;
  std::vector<SurfacePoint> points(3);
  std::vector<AoEstimate> out(3);
  AoSettings bad;
  bad.rays = 1;
  auto status = ambient_occlusion(*scene, points, bad, out, jobs);
  ASSERT_FALSE(status.ok());
  EXPECT_NE(status.error().message.find("rays"), std::string::npos);
  std::vector<Estimate> short_out(2);
  status = irradiance(*scene, lights, points, s, short_out, jobs);
  ASSERT_FALSE(status.ok());
  EXPECT_EQ(status.error().code, ErrorCode::InvalidArgument);
}

}  // namespace
}  // namespace penumbra
