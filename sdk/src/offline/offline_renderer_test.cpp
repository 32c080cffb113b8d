#include "penumbra/offline/offline_renderer.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <limits>
#include <memory>
#include <numbers>
#include <vector>

#include <glm/ext/matrix_clip_space.hpp>
#include <glm/ext/matrix_transform.hpp>

#include "penumbra/ecs/transform.h"
#include "penumbra/scene/builtin.h"
#include "penumbra/scene/components.h"
#include "penumbra/scene/mesh.h"

namespace penumbra {
namespace {

constexpr float kPi = std::numbers::pi_v<float>;

Entity add_mesh(World& world, MeshData mesh, const glm::mat4& m, glm::vec3 albedo, glm::vec3 emissive = glm::vec3(0.0f)) {
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

// A camera at `eye` looking at `target` (90 degree vertical field, Vulkan clip space).
CameraView look_at(glm::vec3 eye, glm::vec3 target, float aspect) {
  CameraView v;
  v.position = eye;
  glm::vec3 up(0.0f, 1.0f, 0.0f);
  if (std::abs(glm::dot(glm::normalize(target - eye), up)) > 0.99f) up = glm::vec3(0.0f, 0.0f, -1.0f);
  v.view = glm::lookAtRH(eye, target, up);
  v.projection = glm::perspectiveRH_ZO(glm::radians(90.0f), aspect, 0.01f, 100.0f);
  v.projection[1][1] = -v.projection[1][1];
  return v;
}

OfflineImage render(World& world, const CameraView& camera, OfflineSettings s, unsigned threads = 2) {
  auto scene = RayScene::build(world);
  EXPECT_TRUE(scene.ok()) << scene.error().message;
  const std::vector<WorldLight> lights = gather_lights(world);
  ThreadPool pool(threads);
  JobContext jobs(&pool);
  auto image = render_offline(*scene, lights, camera, s, jobs);
  EXPECT_TRUE(image.ok()) << image.error().message;
  return image.ok() ? std::move(*image) : OfflineImage{};
}

double relative_rmse(const std::vector<glm::vec3>& a, const std::vector<glm::vec3>& ref, const std::vector<std::uint8_t>& covered) {
  double err = 0.0, norm = 0.0;
  for (std::size_t i = 0; i < a.size(); ++i) {
    if (!covered[i]) continue;
    const glm::dvec3 d = glm::dvec3(a[i]) - glm::dvec3(ref[i]);
    err += glm::dot(d, d);
    norm += glm::dot(glm::dvec3(ref[i]), glm::dvec3(ref[i]));
  }
  return std::sqrt(err / norm);
}

// The furnace (scene/builtin.h): inside a closed enclosure emitting Le with albedo rho, the
// radiance leaving every surface is Le / (1 - rho), whatever the camera sees.
TEST(OfflineRenderer, FurnaceEveryModeReachesTheClosedForm) {
  World world;
  ASSERT_TRUE(load_builtin(world, "furnace").ok());
  update_world_transforms(world);
  const CameraView camera = look_at(glm::vec3(0.1f, 0.2f, 0.0f), glm::vec3(0.0f, -0.3f, -1.0f), 1.0f);
  const float expected = kFurnaceRadiance / (1.0f - kFurnaceAlbedo);
  for (const OfflineMode mode : {OfflineMode::Reference, OfflineMode::MonteCarlo, OfflineMode::IrradianceFilter,
                                 OfflineMode::IrradianceCache}) {
    OfflineSettings s;
    s.mode = mode;
    s.width = s.height = 12;
    s.spp = mode == OfflineMode::Reference ? 256 : mode == OfflineMode::IrradianceCache ? 64 : 16;
    const OfflineImage image = render(world, camera, s);
    ASSERT_EQ(image.covered_pixels, 144u) << to_string(mode);
    EXPECT_EQ(image.nonfinite_samples, 0u);
    double mean = 0.0;
    for (std::size_t i = 0; i < image.lit.size(); ++i) {
      mean += image.lit[i].x / double(image.lit.size());
      EXPECT_EQ(image.direct[i], glm::vec3(0.0f)) << "the furnace has no lights";
      if (mode == OfflineMode::Reference) {
        const float se = image.lit_std_error[i].x;
        EXPECT_GT(se, 0.0f);
        EXPECT_LT(se, 0.05f * expected);  // small enough for the test to mean something
        EXPECT_NEAR(image.lit[i].x, expected, 5.0f * se) << "pixel " << i;
      }
    }
    EXPECT_NEAR(mean, expected, 0.02 * expected) << to_string(mode);
  }
}

// Albedo near 1: the same closed form with rho = 0.95 (a twenty-fold multiplication of light) is
// reached by the unbiased paths (Russian roulette), within the reference's own error.
TEST(OfflineRenderer, FurnaceWithAlbedoNearOne) {
  World world;
  const float rho = 0.95f, le = 0.1f;
  add_mesh(world, make_icosphere(1.0f, 3, true), glm::mat4(1.0f), glm::vec3(rho), glm::vec3(le));
  const CameraView camera = look_at(glm::vec3(0.0f), glm::vec3(0.0f, 0.0f, -1.0f), 1.0f);
  OfflineSettings s;
  s.mode = OfflineMode::Reference;
  s.width = s.height = 6;
  s.spp = 2048;
  const OfflineImage image = render(world, camera, s);
  double mean = 0.0, var = 0.0;
  for (std::size_t i = 0; i < image.lit.size(); ++i) {
    mean += image.lit[i].x / double(image.lit.size());
    var += double(image.lit_std_error[i].x) * image.lit_std_error[i].x / double(image.lit.size() * image.lit.size());
  }
  const double expected = le / (1.0 - rho);
  EXPECT_LT(std::sqrt(var), 0.02 * expected);
  EXPECT_NEAR(mean, expected, 4.0 * std::sqrt(var) + 0.01 * expected);  // 1 %: the icosphere is not a sphere
}

// A floor under a sun and a sky, nothing above it: direct light is E cos(theta) exactly, the
// indirect irradiance is pi L_sky exactly (every ray escapes), and no mode invents more light.
TEST(OfflineRenderer, OpenFloorUnderSunAndSkyIsExactInEveryMode) {
  World world;
  const glm::vec3 albedo(0.6f, 0.5f, 0.4f), sky(0.2f, 0.3f, 0.5f);
  add_mesh(world, make_quad(200.0f, 200.0f),
           glm::rotate(glm::mat4(1.0f), glm::radians(-90.0f), glm::vec3(1.0f, 0.0f, 0.0f)), albedo);
  Entity sun = world.create();
  Light light;
  light.type = Light::Type::Directional;
  light.intensity = 3.0f;
  world.add<Light>(sun, light);
  // Local -Z turned 60 degrees from straight down: cos(theta) = 0.5.
  world.add<WorldTransform>(sun, WorldTransform{glm::rotate(glm::mat4(1.0f), glm::radians(-30.0f), glm::vec3(1, 0, 0))});
  world.add<Environment>(world.create(), Environment{sky});
  const CameraView camera = look_at(glm::vec3(0.0f, 2.0f, 0.0f), glm::vec3(0.0f, 0.0f, -1.5f), 1.5f);
  for (const OfflineMode mode : {OfflineMode::MonteCarlo, OfflineMode::IrradianceFilter, OfflineMode::IrradianceCache,
                                 OfflineMode::Reference}) {
    OfflineSettings s;
    s.mode = mode;
    s.width = 24;
    s.height = 16;
    s.spp = mode == OfflineMode::IrradianceCache ? 16 : 4;
    const OfflineImage image = render(world, camera, s);
    ASSERT_GT(image.covered_pixels, 0u);
    for (std::size_t i = 0; i < image.lit.size(); ++i) {
      if (!image.covered[i]) {
        EXPECT_EQ(image.lit[i], sky) << "a miss shows the sky";
        continue;
      }
      for (int c = 0; c < 3; ++c) {
        EXPECT_NEAR(image.direct[i][c], albedo[c] / kPi * 3.0f * 0.5f, 1e-4f) << to_string(mode);
        EXPECT_NEAR(image.indirect[i][c], albedo[c] * sky[c], 1e-5f) << to_string(mode);
      }
    }
  }
  // Without the sky nothing reaches the floor indirectly: exactly zero, filtered or not.
  world.destroy(world.view<Environment>().sorted_entities().front());
  OfflineSettings s;
  s.width = 24;
  s.height = 16;
  const OfflineImage image = render(world, camera, s);
  ASSERT_GT(image.covered_pixels, 0u);
  for (const glm::vec3& v : image.indirect) EXPECT_EQ(v, glm::vec3(0.0f));
}

// Tiny and huge scenes: a floor meeting a wall under a sky, built at 1 mm and at 1 km as well as
// at 1 m, camera scaled with it. Every estimator works in units of the scene (harmonic distances,
// pixel footprints, ray offsets), so the same seed gives the same image at every scale, to float
// rounding: a scale-dependent constant anywhere shows here as a different image.
TEST(OfflineRenderer, TinyAndHugeScenesGiveTheSameImage) {
  const auto corner = [](float scale) {
    auto world = std::make_unique<World>();
    const glm::mat4 s = glm::scale(glm::mat4(1.0f), glm::vec3(scale));
    add_mesh(*world, make_quad(4.0f, 4.0f), s * glm::rotate(glm::mat4(1.0f), glm::radians(-90.0f), glm::vec3(1, 0, 0)),
             glm::vec3(0.7f, 0.6f, 0.5f));
    add_mesh(*world, make_quad(4.0f, 2.0f), s * glm::translate(glm::mat4(1.0f), glm::vec3(0.0f, 1.0f, -2.0f)),
             glm::vec3(0.8f, 0.3f, 0.2f));
    world->add<Environment>(world->create(), Environment{glm::vec3(0.4f, 0.5f, 0.7f)});
    return world;
  };
  for (const OfflineMode mode : {OfflineMode::MonteCarlo, OfflineMode::IrradianceFilter, OfflineMode::IrradianceCache}) {
    OfflineSettings s;
    s.mode = mode;
    s.width = 32;
    s.height = 24;
    s.spp = mode == OfflineMode::IrradianceCache ? 16 : 2;
    std::vector<OfflineImage> images;
    for (const float scale : {1.0f, 1e-3f, 1e3f}) {
      auto world = corner(scale);
      CameraView camera = look_at(glm::vec3(0.5f, 1.2f, 1.5f) * scale, glm::vec3(0.0f, 0.3f, -2.0f) * scale, 4.0f / 3.0f);
      camera.projection = glm::perspectiveRH_ZO(glm::radians(90.0f), 4.0f / 3.0f, 0.01f * scale, 100.0f * scale);
      camera.projection[1][1] = -camera.projection[1][1];
      images.push_back(render(*world, camera, s));
    }
    ASSERT_GT(images[0].covered_pixels, 300u);
    for (std::size_t k = 1; k < images.size(); ++k) {
      EXPECT_EQ(images[k].covered, images[0].covered) << to_string(mode) << " scale " << k;
      EXPECT_LT(relative_rmse(images[k].indirect, images[0].indirect, images[0].covered), 0.01)
          << to_string(mode) << (k == 1 ? " at 1 mm" : " at 1 km");
    }
  }
}

// Texture detail survives the filter: a checkered floor under a uniform sky (E = pi L_sky exactly
// everywhere) comes out as the texture times the sky in every pixel, in every mode, with the
// checker's contrast intact; the texels are sRGB-decoded and multiplied by the base colour.
TEST(OfflineRenderer, TexturesSurviveTheFilter) {
  World world;
  Entity floor = add_mesh(world, make_quad(4.0f, 4.0f),
                          glm::rotate(glm::mat4(1.0f), glm::radians(-90.0f), glm::vec3(1.0f, 0.0f, 0.0f)), glm::vec3(1.0f));
  auto texture = std::make_shared<Texture>();
  texture->width = texture->height = 2;
  texture->rgba8 = {255, 255, 255, 255, 64, 64, 64, 255, 64, 64, 64, 255, 255, 255, 255, 255};
  texture->average_linear = glm::vec3(0.5f * (1.0f + 0.0513f));
  Material m = world.get<Material>(floor);
  m.base_color = glm::vec4(0.8f, 0.8f, 0.8f, 1.0f);
  m.base_color_texture = texture;
  world.add<Material>(floor, m);
  const glm::vec3 sky(0.5f);
  world.add<Environment>(world.create(), Environment{sky});
  const SurfaceTextures textures = SurfaceTextures::gather(world);
  EXPECT_EQ(textures.textured_entities(), 1u);
  auto scene = RayScene::build(world);
  ASSERT_TRUE(scene.ok());
  const CameraView camera = look_at(glm::vec3(0.0f, 3.0f, 0.01f), glm::vec3(0.0f), 1.0f);
  for (const OfflineMode mode : {OfflineMode::MonteCarlo, OfflineMode::IrradianceFilter, OfflineMode::IrradianceCache}) {
    OfflineSettings s;
    s.mode = mode;
    s.width = s.height = 32;
    s.spp = mode == OfflineMode::IrradianceCache ? 16 : 4;
    JobContext jobs;
    auto image = render_offline(*scene, {}, camera, s, jobs, &textures);
    ASSERT_TRUE(image.ok());
    float lo = 1e9f, hi = 0.0f;
    for (std::size_t i = 0; i < image->indirect.size(); ++i) {
      if (!image->covered[i]) continue;
      EXPECT_NEAR(image->indirect[i].x, image->albedo[i].x * sky.x, 1e-5f) << to_string(mode) << " pixel " << i;
      lo = std::min(lo, image->albedo[i].x);
      hi = std::max(hi, image->albedo[i].x);
    }
    // White texels x 0.8 and sRGB 64 (linear 0.0513) x 0.8, blended bilinearly between: the
    // extremes near the texel centres, and the checker's contrast kept.
    EXPECT_LE(hi, 0.8f + 1e-4f) << to_string(mode);
    EXPECT_GT(hi, 0.75f) << to_string(mode);
    EXPECT_GE(lo, 0.8f * 0.0513f - 1e-4f) << to_string(mode);
    EXPECT_LT(lo, 0.1f) << to_string(mode);
  }
}

// Bit-identical at 1 and 2 threads (every pass draws per pixel and the filter gathers in order).
TEST(OfflineRenderer, ThreadCountDoesNotChangeABit) {
  World world;
  ASSERT_TRUE(load_builtin(world, "cornell").ok());
  update_world_transforms(world);
  const CameraView camera = framing_camera_view(world, 1.0f);
  OfflineSettings s;
  s.width = s.height = 20;
  s.spp = 4;
  for (const OfflineMode mode : {OfflineMode::IrradianceFilter, OfflineMode::IrradianceCache}) {
    s.mode = mode;
    s.spp = mode == OfflineMode::IrradianceCache ? 32 : 4;
    const OfflineImage one = render(world, camera, s, 1), two = render(world, camera, s, 2);
    ASSERT_GT(one.covered_pixels, 150u);
    ASSERT_EQ(one.lit.size(), two.lit.size());
    EXPECT_EQ(std::memcmp(one.lit.data(), two.lit.data(), one.lit.size() * sizeof(glm::vec3)), 0) << to_string(mode);
    EXPECT_EQ(one.indirect_samples, two.indirect_samples);
    EXPECT_EQ(one.cache_records, two.cache_records);
  }
}

// Irradiance gradients (Ward & Heckbert 1992) predict how a record's irradiance changes: on a
// floor beside a bright wall under a dark sky, E rises towards the wall; the translational
// gradient's prediction over a short step agrees with records made there, and the rotational one
// with records whose normal tilts towards the wall.
TEST(IrradianceCache, GradientsPredictNearbyRecords) {
  World world;
  add_mesh(world, make_quad(40.0f, 40.0f),
           glm::rotate(glm::mat4(1.0f), glm::radians(-90.0f), glm::vec3(1.0f, 0.0f, 0.0f)), glm::vec3(0.5f));
  // An emissive wall at x = 2 facing -X.
  add_mesh(world, make_quad(40.0f, 10.0f),
           glm::rotate(glm::translate(glm::mat4(1.0f), glm::vec3(2.0f, 0.0f, 0.0f)), glm::radians(-90.0f),
                       glm::vec3(0.0f, 1.0f, 0.0f)),
           glm::vec3(0.0f), glm::vec3(1.0f));
  auto scene = RayScene::build(world);
  ASSERT_TRUE(scene.ok());
  IrradianceSettings path;
  path.reference = true;
  const IncidentFn incident = [&](glm::vec3 x, glm::vec3 n, glm::vec3 dir, Rng& rng) {
    const glm::vec3 origin = x + scene->ray_epsilon(x) * n;
    Hit hit;
    if (!scene->intersect(Ray{origin, 0.0f, dir}, hit)) return IncidentSample{glm::vec3(0.0f), INFINITY};
    glm::vec3 v = hit.material.albedo * irradiance_sample(*scene, {}, origin + hit.t * dir,
                                                          hit.back_face ? -hit.normal : hit.normal, path, rng);
    if (!hit.back_face) v += kPi * hit.material.emissive;
    return IncidentSample{v, hit.t};
  };
  const glm::vec3 up(0.0f, 1.0f, 0.0f);
  const auto record = [&](glm::vec3 x, glm::vec3 n) {
    Rng rng = Rng::stream(3, 0);
    return make_cache_record(x, n, 16384, rng, incident);
  };
  const CacheRecord r = record(glm::vec3(0.0f), up);
  EXPECT_GT(r.irradiance.x, 0.1f);
  // The harmonic mean counts the escaping rays as infinitely far: the wall 2-3 m away, met by a
  // fraction of the rays, gives a few times its distance.
  EXPECT_GT(r.radius, 2.0f);
  EXPECT_LT(r.radius, 30.0f);
  EXPECT_GT(r.translational[0].x, 0.0f) << "E grows towards the wall";
  EXPECT_NEAR(r.translational[0].z, 0.0f, 0.02f * r.translational[0].x) << "the wall is uniform along z";
  EXPECT_NEAR(r.translational[0].y, 0.0f, 1e-6f) << "the gradient lies in the tangent plane";
  for (const float step : {0.1f, -0.1f}) {
    const CacheRecord moved = record(glm::vec3(step, 0.0f, 0.0f), up);
    const float predicted = cache_extrapolate(r, glm::vec3(step, 0.0f, 0.0f), up).x;
    EXPECT_NEAR(predicted, moved.irradiance.x, 0.15f * std::abs(moved.irradiance.x - r.irradiance.x) + 0.003f)
        << "step " << step;
  }
  const glm::vec3 tilted = glm::normalize(glm::vec3(0.1f, 1.0f, 0.0f));
  const float predicted = cache_extrapolate(r, glm::vec3(0.0f), tilted).x;
  EXPECT_NEAR(predicted, record(glm::vec3(0.0f), tilted).irradiance.x,
              0.2f * std::abs(record(glm::vec3(0.0f), tilted).irradiance.x - r.irradiance.x) + 0.003f);
}

// The cache converges: on the Cornell box, a tighter accuracy with more rays per record is closer to
// the reference, and every surface pixel gets a value.
TEST(IrradianceCache, ErrorShrinksWithAccuracyOnTheCornellBox) {
  World world;
  ASSERT_TRUE(load_builtin(world, "cornell").ok());
  update_world_transforms(world);
  const CameraView camera = camera_view(world, world.view<const Camera>().sorted_entities().front(), 1.0f);
  OfflineSettings s;
  s.width = s.height = 32;
  s.mode = OfflineMode::Reference;
  s.spp = 1024;
  const OfflineImage ref = render(world, camera, s);
  s.mode = OfflineMode::IrradianceCache;
  s.spp = 64;
  s.cache.accuracy = 0.5f;
  const OfflineImage coarse = render(world, camera, s);
  s.spp = 512;
  s.cache.accuracy = 0.15f;
  const OfflineImage fine = render(world, camera, s);
  EXPECT_GT(fine.cache_records, coarse.cache_records);
  const double e_coarse = relative_rmse(coarse.indirect, ref.indirect, ref.covered);
  const double e_fine = relative_rmse(fine.indirect, ref.indirect, ref.covered);
  EXPECT_LT(e_fine, 0.7 * e_coarse) << "coarse " << e_coarse << " fine " << e_fine;
  for (std::size_t i = 0; i < fine.indirect.size(); ++i) {
    if (fine.covered[i]) {
      EXPECT_GT(fine.indirect[i].x + fine.indirect[i].y + fine.indirect[i].z, 0.0f) << i;
    }
  }
}

// On the Cornell box: plain Monte Carlo converges (4x the rays, about half the error), and
// irradiance filtering at the first pass's ray count has well under MC's error against the
// reference (the paper's claim, here on a small frame).
TEST(OfflineRenderer, CornellErrorsShrinkWithRaysAndTheFilterBeatsMonteCarlo) {
  World world;
  ASSERT_TRUE(load_builtin(world, "cornell").ok());
  update_world_transforms(world);
  Entity cam = world.view<const Camera>().sorted_entities().front();
  const CameraView camera = camera_view(world, cam, 1.0f);
  OfflineSettings s;
  s.width = s.height = 32;
  s.mode = OfflineMode::Reference;
  s.spp = 1024;
  const OfflineImage ref = render(world, camera, s);
  double se2 = 0.0, norm = 0.0;
  for (std::size_t i = 0; i < ref.lit.size(); ++i) {
    if (!ref.covered[i]) continue;
    se2 += glm::dot(glm::dvec3(ref.lit_std_error[i]), glm::dvec3(ref.lit_std_error[i]));
    norm += glm::dot(glm::dvec3(ref.indirect[i]), glm::dvec3(ref.indirect[i]));
  }
  const double ref_rel_se = std::sqrt(se2 / norm);
  s.mode = OfflineMode::MonteCarlo;
  s.spp = 4;
  const double mc4 = relative_rmse(render(world, camera, s).indirect, ref.indirect, ref.covered);
  s.spp = 16;
  const double mc16 = relative_rmse(render(world, camera, s).indirect, ref.indirect, ref.covered);
  s.mode = OfflineMode::IrradianceFilter;
  s.spp = 4;
  const OfflineImage filtered = render(world, camera, s);
  const double if4 = relative_rmse(filtered.indirect, ref.indirect, ref.covered);
  EXPECT_LT(ref_rel_se, 0.25 * mc16) << "the reference must be far less noisy than what it judges";
  EXPECT_LT(mc16, 0.65 * mc4) << "mc4 " << mc4 << " mc16 " << mc16;
  EXPECT_LT(if4, 0.5 * mc4) << "filter " << if4 << " mc4 " << mc4;
  EXPECT_LE(filtered.indirect_samples, 16u * 4u * filtered.covered_pixels);
}

// At one ray per pixel the filter's predictor pools the rays of each pixel's 3x3 neighbourhood on
// its surface. With each pixel's own ray alone, whether that ray escaped decided how widely the
// pixel blurred, and the courtyard's sunlit walls came out under-weighted: a dark bias.
TEST(OfflineRenderer, APooledPredictorCutsTheErrorAtOneRayPerPixel) {
  World world;
  ASSERT_TRUE(load_builtin(world, "courtyard").ok());
  update_world_transforms(world);
  Entity cam = world.view<const Camera>().sorted_entities().front();
  OfflineSettings s;
  s.width = 96;
  s.height = 54;
  const CameraView camera = camera_view(world, cam, float(s.width) / float(s.height));
  s.mode = OfflineMode::Reference;
  s.spp = 512;
  const OfflineImage ref = render(world, camera, s);
  const auto errors = [&](const OfflineImage& image) {
    double err = 0.0, bias = 0.0, norm = 0.0, total = 0.0;
    for (std::size_t i = 0; i < image.indirect.size(); ++i) {
      if (!ref.covered[i]) continue;
      const glm::dvec3 d = glm::dvec3(image.indirect[i]) - glm::dvec3(ref.indirect[i]);
      err += glm::dot(d, d);
      bias += d.x + d.y + d.z;
      norm += glm::dot(glm::dvec3(ref.indirect[i]), glm::dvec3(ref.indirect[i]));
      total += double(ref.indirect[i].x) + ref.indirect[i].y + ref.indirect[i].z;
    }
    return std::pair{std::sqrt(err / norm), bias / total};
  };
  s.mode = OfflineMode::IrradianceFilter;
  s.spp = 1;
  s.filter.predictor_radius = 0;
  const auto [own_error, own_bias] = errors(render(world, camera, s));
  s.filter.predictor_radius = 1;
  const auto [pooled_error, pooled_bias] = errors(render(world, camera, s));
  EXPECT_LT(pooled_error, 0.6 * own_error) << "own " << own_error << " pooled " << pooled_error;
  EXPECT_LT(std::abs(pooled_bias), 0.5 * std::abs(own_bias)) << "own " << own_bias << " pooled " << pooled_bias;
  EXPECT_LT(own_bias, 0.0) << "the pixel's own ray makes the frame too dark";
}

// Samples that come out non-finite (a light of infinite intensity) are dropped and counted; no
// pixel turns NaN.
TEST(OfflineRenderer, NonFiniteSamplesAreCountedAndDropped) {
  World world;
  add_mesh(world, make_quad(10.0f, 10.0f),
           glm::rotate(glm::mat4(1.0f), glm::radians(-90.0f), glm::vec3(1.0f, 0.0f, 0.0f)), glm::vec3(0.5f));
  Entity lamp = world.create();
  Light light;
  light.type = Light::Type::Point;
  light.intensity = std::numeric_limits<float>::infinity();
  world.add<Light>(lamp, light);
  world.add<WorldTransform>(lamp, WorldTransform{glm::translate(glm::mat4(1.0f), glm::vec3(0.0f, 1.0f, 0.0f))});
  OfflineSettings s;
  s.width = s.height = 8;
  s.spp = 2;
  const OfflineImage image = render(world, look_at(glm::vec3(0.0f, 3.0f, 0.01f), glm::vec3(0.0f), 1.0f), s);
  ASSERT_GT(image.covered_pixels, 0u);
  EXPECT_GT(image.nonfinite_samples, 0u);
  for (const glm::vec3& v : image.lit) EXPECT_TRUE(std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z));
}

TEST(OfflineRenderer, SettingsOutOfRangeAreRefusedByName) {
  World world;
  add_mesh(world, make_quad(1.0f, 1.0f), glm::mat4(1.0f), glm::vec3(0.5f));
  auto scene = RayScene::build(world);
  ASSERT_TRUE(scene.ok());
  JobContext jobs;
  const CameraView camera = look_at(glm::vec3(0.0f, 0.0f, 2.0f), glm::vec3(0.0f), 1.0f);
  OfflineSettings s;
  s.width = 0;
  auto r = render_offline(*scene, {}, camera, s, jobs);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("1..16384"), std::string::npos) << r.error().message;
  s = OfflineSettings{};
  s.mode = OfflineMode::Reference;
  s.spp = 1;
  r = render_offline(*scene, {}, camera, s, jobs);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("spp >= 2"), std::string::npos) << r.error().message;
  s = OfflineSettings{};
  s.filter.predictor_radius = kMaxPredictorRadius + 1;
  r = render_offline(*scene, {}, camera, s, jobs);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("predictor_radius"), std::string::npos) << r.error().message;
  s.filter.predictor_radius = 1;
  s.filter.a = 0.0f;
  EXPECT_FALSE(render_offline(*scene, {}, camera, s, jobs).ok());
  EXPECT_EQ(parse_offline_mode("irradiance-filter"), OfflineMode::IrradianceFilter);
  EXPECT_FALSE(parse_offline_mode("path-tracer").has_value());
}

}  // namespace
}  // namespace penumbra
