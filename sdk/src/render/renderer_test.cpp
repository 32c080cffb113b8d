// Renderer tests, all with the Vulkan validation layer on (any message fails the test):
// golden images of the built-in scenes in every debug view, the one-pixel-shift sensitivity of
// the golden comparison, GPU skinning, the shader's probe irradiance against the CPU's, and the
// AO passes: AO fields per pixel (shader against evaluate_packed, a moving crate's contact shadow,
// the pass compiled out without casters) and pose-AO as the VertexAO attribute.
#include "penumbra/render/renderer.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <map>
#include <numbers>

#include <glm/gtc/quaternion.hpp>
#include <glm/ext/matrix_transform.hpp>

#include "penumbra/ao_field/ao_field_baker.h"
#include "penumbra/ao_field/ao_field_gpu.h"
#include "penumbra/ao_field/ao_field_system.h"
#include "penumbra/bake/baker.h"
#include "penumbra/core/jobs.h"
#include "penumbra/core/log.h"
#include "penumbra/ecs/transform.h"
#include "penumbra/indirect_transport/indirect_transport_baker.h"
#include "penumbra/indirect_transport/indirect_transport_system.h"
#include "penumbra/probe_grid/probe_grid.h"
#include "penumbra/pose_ao/pose_ao_baker.h"
#include "penumbra/pose_ao/pose_ao_system.h"
#include "penumbra/probe_grid/probe_grid_baker.h"
#include "penumbra/probe_grid/probe_grid_system.h"
#include "penumbra/probe_grid/probe_grid_render.h"
#include "penumbra/ao_field/ao_field_render.h"
#include "penumbra/scene/animation.h"
#include "penumbra/scene/builtin.h"
#include "shared/layout.h"
#include "stb_image.h"
#include "test_device.h"
#include "checkout_paths.h"

namespace penumbra {
namespace {

// The AO-field buffer of a World's baked casters in entity order: the renderer's caster records.
Result<AOFieldGpuBuffer> pack_world_casters(World& w) {
  std::vector<AOFieldGpuCaster> baked;
  for (Entity e : w.view<AOFieldCaster, WorldTransform>().sorted_entities())
    if (const AOFieldCaster& c = w.get<AOFieldCaster>(e); c.data)
      baked.push_back({c.data.get(), w.get<WorldTransform>(e).matrix});
  return pack_ao_fields_gpu(baked);
}

constexpr std::uint32_t kWidth = 160, kHeight = 120;
const std::filesystem::path kGoldenDir = std::filesystem::path(checkout::kSourceDir) / "sdk/src/render/golden";

// A built-in scene with a draft probe grid baked in place (deterministic: seed 1); optionally draft
// AO fields on its movable meshes (add_default_ao_field_casters) and draft pose-AO on its skinned
// meshes, baked with it.
struct BakedScene {
  World world;
  Entity camera;
};
struct SceneOptions {
  bool ao_fields = false;
  bool pose_ao = false;
};
std::unique_ptr<BakedScene> bake_scene(std::string_view name, SceneOptions options = {}) {
  auto s = std::make_unique<BakedScene>();
  register_scene_systems(s->world);
  register_probe_grid_system(s->world);
  register_probe_grid_baker(s->world);
  if (options.ao_fields) {
    register_ao_field_system(s->world);
    register_ao_field_baker(s->world);
  }
  if (options.pose_ao) {
    register_pose_ao_system(s->world);
    register_pose_ao_baker(s->world);
  }
  auto loaded = load_builtin(s->world, name);
  EXPECT_TRUE(loaded.ok());
  if (!loaded.ok()) return nullptr;
  s->camera = loaded->camera;
  s->world.update(0.0);
  auto grid = add_default_probe_grid(s->world, Preset::Draft);
  EXPECT_TRUE(grid.ok()) << (grid.ok() ? "" : grid.error().message);
  std::vector<std::string> bakers = {"probe-grid"};
  if (options.ao_fields) {
    EXPECT_GT(add_default_ao_field_casters(s->world, Preset::Draft), 0u);
    bakers.push_back("ao-field");
  }
  if (options.pose_ao) {
    EXPECT_GT(add_default_pose_ao(s->world, Preset::Draft), 0u);
    bakers.push_back("pose-ao");
  }
  BakeSettings settings;
  settings.preset = Preset::Draft;
  JobContext jobs;
  auto baked = bake_world(s->world, bakers, settings, jobs);
  EXPECT_TRUE(baked.ok()) << (baked.ok() ? "" : baked.error().message);
  s->world.update(0.0);
  return s;
}

// Per-pixel comparison: a pixel differs when a channel is off by more than 24/255; the images
// match when at most 0.05% of the pixels differ (9 of 160 x 120) and the mean absolute error is
// at most 1/255. A one-pixel shift of any edge moves at least a full edge of pixels.
struct Comparison {
  std::size_t differing = 0;
  double mean_abs = 0.0;
  bool match() const { return differing <= kWidth * kHeight / 2000 && mean_abs <= 1.0 / 255.0; }
};
Comparison compare(const std::vector<std::uint8_t>& a, const std::vector<std::uint8_t>& b) {
  Comparison c;
  if (a.size() != b.size()) return {a.size() + b.size(), 1.0};
  double sum = 0.0;
  for (std::size_t p = 0; p < a.size(); p += 4) {
    int worst = 0;
    for (std::size_t k = 0; k < 3; ++k) {
      const int d = std::abs(int(a[p + k]) - int(b[p + k]));
      worst = std::max(worst, d);
      sum += d / 255.0;
    }
    if (worst > 24) ++c.differing;
  }
  c.mean_abs = sum / double(a.size() / 4 * 3);
  return c;
}

std::vector<std::uint8_t> read_png(const std::filesystem::path& path, int& w, int& h) {
  int channels = 0;
  unsigned char* data = stbi_load(path.string().c_str(), &w, &h, &channels, 4);
  if (!data) return {};
  std::vector<std::uint8_t> out(data, data + std::size_t(w) * std::size_t(h) * 4);
  stbi_image_free(data);
  return out;
}

// Compares `image` with golden/<name>.png, or rewrites the golden when PENUMBRA_UPDATE_GOLDEN=1.
void expect_golden(const Image& image, const std::string& name) {
  const auto path = kGoldenDir / (name + ".png");
  if (const char* update = std::getenv("PENUMBRA_UPDATE_GOLDEN"); update && std::string(update) == "1") {
    std::filesystem::create_directories(kGoldenDir);
    Status s = write_image(image, path.string());
    ASSERT_TRUE(s.ok()) << s.error().message;
    return;
  }
  int w = 0, h = 0;
  const auto golden = read_png(path, w, h);
  ASSERT_FALSE(golden.empty()) << path << " is missing; run the test with PENUMBRA_UPDATE_GOLDEN=1";
  ASSERT_EQ(std::uint32_t(w), image.width);
  ASSERT_EQ(std::uint32_t(h), image.height);
  const Comparison c = compare(image.rgba8, golden);
  EXPECT_TRUE(c.match()) << name << ": " << c.differing << " pixels differ, mean abs error " << c.mean_abs * 255.0
                         << "/255; if the change is intended, rerun with PENUMBRA_UPDATE_GOLDEN=1 and look at "
                         << path;
}

class RendererTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    device_ = test::validated_device().release();
    ASSERT_NE(device_, nullptr);
    auto renderer = Renderer::create(*device_);
    ASSERT_TRUE(renderer.ok()) << renderer.error().message;
    renderer_ = renderer->release();
    scenes_ = new std::map<std::string, std::unique_ptr<BakedScene>>();
  }
  static void TearDownTestSuite() {
    delete renderer_;
    delete scenes_;
    delete device_;
  }
  void TearDown() override { EXPECT_NO_VALIDATION_MESSAGES(*device_); }

  static BakedScene& scene(const std::string& name) {
    auto& s = (*scenes_)[name];
    if (!s) s = bake_scene(name);
    return *s;
  }
  static CameraView camera(BakedScene& s) {
    return camera_view(s.world, s.camera, float(kWidth) / float(kHeight));
  }
  // The entity of the world's baked IrradianceProbeGrid (the last in iteration order), or none.
  static Entity baked_probe_grid(World& world) {
    Entity grid;
    world.view<const IrradianceProbeGrid>().each([&](Entity e, const IrradianceProbeGrid& g) {
      if (g.data) grid = e;
    });
    return grid;
  }
  // A debug view of `world` as linear floats (RGBA per pixel) at w x h and the given ambient step.
  static std::vector<float> linear_view(World& world, const CameraView& cam, std::uint32_t w, std::uint32_t h,
                                        const std::string& view, std::uint32_t ambient_step) {
    RenderSettings settings;
    settings.view = view;
    settings.ambient_step = ambient_step;
    auto image = renderer_->render_image(world, cam, w, h, settings, true);
    EXPECT_TRUE(image.ok()) << (image.ok() ? "" : image.error().message);
    return image.ok() ? std::move(image->rgba32f) : std::vector<float>{};
  }

  static Device* device_;
  static Renderer* renderer_;
  static std::map<std::string, std::unique_ptr<BakedScene>>* scenes_;
};
Device* RendererTest::device_ = nullptr;
Renderer* RendererTest::renderer_ = nullptr;
std::map<std::string, std::unique_ptr<BakedScene>>* RendererTest::scenes_ = nullptr;

// The views are the renderer's own, then each render feature's; an unknown one is refused naming
// them all.
TEST_F(RendererTest, ViewsAreTheRenderersThenEachFeatures) {
  std::vector<std::string> names;
  for (const ViewInfo& v : renderer_->views()) names.emplace_back(v.name);
  EXPECT_EQ(names, (std::vector<std::string>{"lit", "direct", "indirect", "ao", "albedo", "position", "normal",
                                             "validity", "irradiance", "lightmap", "patches", "bounce-probes"}));
  BakedScene& s = scene("cornell");
  RenderSettings settings;
  settings.view = "shiny";
  auto image = renderer_->render_image(s.world, camera(s), 16, 16, settings);
  ASSERT_FALSE(image.ok());
  EXPECT_NE(image.error().message.find("irradiance"), std::string::npos) << image.error().message;
}

// Two features of one name (or sharing a view's name) are refused by Renderer::create.
TEST_F(RendererTest, FeaturesAreUniqueByName) {
  RenderFeatures features;
  features.push_back(make_probe_grid_render_feature());
  features.push_back(make_probe_grid_render_feature());
  auto r = Renderer::create(*device_, std::move(features));
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("probe-grid"), std::string::npos) << r.error().message;
}

// The renderer draws only what its features add: without the probe grid's feature the indirect
// view is black, without the AO-field feature the casters occlude nothing, and the direct view is
// the same with or without them.
TEST_F(RendererTest, TheAmbientImageHoldsOnlyWhatItsFeaturesAdd) {
  auto baked = bake_scene("courtyard", {.ao_fields = true});
  ASSERT_NE(baked, nullptr);
  BakedScene& s = *baked;
  RenderFeatures only_ao;
  only_ao.push_back(make_ao_field_render_feature());
  auto bare = Renderer::create(*device_, RenderFeatures{});
  auto ao_only = Renderer::create(*device_, std::move(only_ao));
  ASSERT_TRUE(bare.ok()) << bare.error().message;
  ASSERT_TRUE(ao_only.ok()) << ao_only.error().message;
  auto frame = [&](Renderer& r, const std::string& view) {
    RenderSettings settings;
    settings.view = view;
    auto image = r.render_image(s.world, camera(s), kWidth, kHeight, settings, true);
    EXPECT_TRUE(image.ok()) << (image.ok() ? "" : image.error().message);
    return image.ok() ? std::move(image->rgba32f) : std::vector<float>{};
  };
  auto sum = [](const std::vector<float>& px) {
    double total = 0.0;
    for (std::size_t i = 0; i < px.size(); i += 4) total += px[i] + px[i + 1] + px[i + 2];
    return total;
  };
  EXPECT_EQ(sum(frame(**bare, "indirect")), 0.0);
  EXPECT_GT(sum(frame(*renderer_, "indirect")), 0.0);
  EXPECT_EQ((**bare).views().size(), std::size_t{PENUMBRA_VIEW_COUNT}) << "no feature, no feature views";
  // AO: 1 everywhere without the AO-field feature; the casters darken some pixels with it.
  const auto bare_ao = frame(**bare, "ao"), with_ao = frame(**ao_only, "ao");
  ASSERT_EQ(bare_ao.size(), with_ao.size());
  EXPECT_LT(sum(with_ao), sum(bare_ao));
  EXPECT_EQ((**ao_only).stats().counter("ao-field.casters"), 4u);
  EXPECT_EQ((**bare).stats().counter("ao-field.casters"), 0u);
  EXPECT_EQ(frame(**bare, "direct"), frame(*renderer_, "direct"));
}

class GoldenTest : public RendererTest, public ::testing::WithParamInterface<std::tuple<std::string, std::string>> {};

TEST_P(GoldenTest, MatchesGolden) {
  const auto& [name, view] = GetParam();
  BakedScene& s = scene(name);
  RenderSettings settings;
  settings.view = view;
  settings.shadow_map_size = 512;
  auto image = renderer_->render_image(s.world, camera(s), kWidth, kHeight, settings);
  ASSERT_TRUE(image.ok()) << image.error().message;
  expect_golden(*image, name + "_" + view);
}

INSTANTIATE_TEST_SUITE_P(
    Scenes, GoldenTest,
    ::testing::Combine(::testing::Values("cornell", "courtyard"),
                       ::testing::Values("lit", "direct", "indirect",
                                         "ao", "albedo", "validity")),
    [](const auto& test_param) {
      return std::get<0>(test_param.param) + "_" + std::get<1>(test_param.param);
    });

// The comparison is strict enough: each golden matches itself and fails when shifted by one pixel.
TEST_F(RendererTest, GoldenComparisonRejectsAOnePixelShift) {
  for (const char* name : {"cornell_lit", "courtyard_lit", "cornell_albedo", "courtyard_direct"}) {
    int w = 0, h = 0;
    const auto golden = read_png(kGoldenDir / (std::string(name) + ".png"), w, h);
    ASSERT_FALSE(golden.empty()) << name;
    EXPECT_TRUE(compare(golden, golden).match());
    for (int axis = 0; axis < 2; ++axis) {
      std::vector<std::uint8_t> shifted(golden.size());
      for (int y = 0; y < h; ++y) {
        for (int x = 0; x < w; ++x) {
          const int sx = axis == 0 ? std::max(x - 1, 0) : x, sy = axis == 1 ? std::max(y - 1, 0) : y;
          for (int k = 0; k < 4; ++k) shifted[(std::size_t(y) * w + x) * 4 + k] = golden[(std::size_t(sy) * w + sx) * 4 + k];
        }
      }
      const Comparison c = compare(shifted, golden);
      EXPECT_FALSE(c.match()) << name << " shifted along " << (axis ? "y" : "x") << ": only " << c.differing
                              << " pixels differ";
    }
  }
}

// GPU skinning: the courtyard's walker at two animation times gives two different images (the
// CPU mesh never changes; only the joint matrices do), each matching its golden.
TEST_F(RendererTest, SkinningMovesTheWalkerOnTheGpu) {
  auto s = bake_scene("courtyard");
  ASSERT_TRUE(s);
  RenderSettings settings;
  settings.view = "albedo";
  const CameraView cam = camera(*s);
  auto first = renderer_->render_image(s->world, cam, kWidth, kHeight, settings);
  ASSERT_TRUE(first.ok()) << first.error().message;
  s->world.update(0.4);
  auto second = renderer_->render_image(s->world, cam, kWidth, kHeight, settings);
  ASSERT_TRUE(second.ok()) << second.error().message;
  const Comparison c = compare(first->rgba8, second->rgba8);
  EXPECT_GE(c.differing, 20u) << "the pose did not change the image";
  expect_golden(*first, "courtyard_walker_t0");
  expect_golden(*second, "courtyard_walker_t04");
}

// The Cornell box's rect light is drawn as its emitter: the lit view at its centre shows its
// radiance (linear, exact), the direct view there is no light at all (the emitter reflects
// nothing), and a sky gives the lit view's background its radiance, leaving the direct one black.
TEST_F(RendererTest, RectLightEmittersAndTheSkyAreDrawn) {
  auto s = bake_scene("cornell");
  ASSERT_TRUE(s);
  const CameraView cam = camera(*s);
  const std::vector<WorldLight> lights = gather_lights(s->world);
  ASSERT_EQ(lights.size(), 1u);
  const WorldLight& light = lights[0];
  const glm::vec4 clip = cam.projection * cam.view * glm::vec4(light.position, 1.0f);
  const glm::vec2 ndc = glm::vec2(clip) / clip.w;
  const auto px = static_cast<std::size_t>((ndc.x * 0.5f + 0.5f) * float(kWidth));
  const auto py = static_cast<std::size_t>((ndc.y * 0.5f + 0.5f) * float(kHeight));
  ASSERT_LT(px, kWidth);
  ASSERT_LT(py, kHeight);
  const std::size_t at = 4 * (py * kWidth + px);
  const glm::vec3 radiance = light.light.color * light.light.intensity;
  const auto lit = linear_view(s->world, cam, kWidth, kHeight, "lit", 2);
  const auto direct = linear_view(s->world, cam, kWidth, kHeight, "direct", 2);
  ASSERT_FALSE(lit.empty() || direct.empty());
  for (int c = 0; c < 3; ++c) {
    EXPECT_NEAR(lit[at + c], radiance[c], 1e-4f * radiance[c]) << c;
    EXPECT_EQ(direct[at + c], 0.0f) << c;
  }
  // The top-left corner sees past the box: black without a sky, the sky's radiance with one.
  EXPECT_EQ(lit[0], 0.0f);
  const Entity sky = s->world.create();
  s->world.add<Environment>(sky, Environment{{0.1f, 0.2f, 0.3f}});
  const auto with_sky = linear_view(s->world, cam, kWidth, kHeight, "lit", 2);
  const auto direct_sky = linear_view(s->world, cam, kWidth, kHeight, "direct", 2);
  s->world.destroy(sky);
  ASSERT_FALSE(with_sky.empty() || direct_sky.empty());
  EXPECT_NEAR(with_sky[0], 0.1f, 1e-6f);
  EXPECT_NEAR(with_sky[1], 0.2f, 1e-6f);
  EXPECT_NEAR(with_sky[2], 0.3f, 1e-6f);
  EXPECT_EQ(direct_sky[0], 0.0f);
  // 8-bit targets get the same colour through display_colour (exposure, ACES, sRGB).
  const glm::vec3 shown = display_colour({0.1f, 0.2f, 0.3f}, 1.0f, true);
  EXPECT_GT(shown.b, shown.g);
  EXPECT_GT(shown.g, shown.r);
}

// An environment map is drawn behind the scene in the lit view as the CPU looks it up
// (sample_environment_map): every pixel that is background without a sky shows the map toward its
// direction (a map that varies along every axis, so a turned or mirrored lookup fails), within
// half-float and filtering precision; the direct view stays black there.
TEST_F(RendererTest, TheEnvironmentMapIsTheBackgroundAsTheCpuSeesIt) {
  auto s = bake_scene("cornell");
  ASSERT_TRUE(s);
  const CameraView cam = camera(*s);
  const std::uint32_t w = 64, h = 32;
  std::vector<glm::vec3> texels(std::size_t{w} * h);
  for (std::uint32_t y = 0; y < h; ++y)
    for (std::uint32_t x = 0; x < w; ++x) {
      const float pi = std::numbers::pi_v<float>;
      const float phi = ((float(x) + 0.5f) / float(w) - 0.5f) * 2.0f * pi, theta = (float(y) + 0.5f) / float(h) * pi;
      const glm::vec3 d(std::sin(theta) * std::sin(phi), std::cos(theta), -std::sin(theta) * std::cos(phi));
      texels[std::size_t{y} * w + x] = 0.3f * (0.5f + 0.5f * glm::vec3(d.x, d.y, -d.z)) + 0.01f;
    }
  auto map = make_environment_map(w, h, std::move(texels), "test map");
  ASSERT_TRUE(map.ok()) << map.error().message;
  const auto without = linear_view(s->world, cam, kWidth, kHeight, "lit", 2);
  const Entity sky = s->world.create();
  Environment env;
  env.map_data = *map;
  env.map_scale = 2.0f;
  s->world.add<Environment>(sky, env);
  const auto lit = linear_view(s->world, cam, kWidth, kHeight, "lit", 2);
  const auto direct = linear_view(s->world, cam, kWidth, kHeight, "direct", 2);
  s->world.destroy(sky);
  ASSERT_FALSE(without.empty() || lit.empty() || direct.empty());
  const glm::mat4 clip_to_world = glm::inverse(cam.projection * cam.view);
  std::size_t background = 0;
  for (std::uint32_t py = 0; py < kHeight; ++py)
    for (std::uint32_t px = 0; px < kWidth; ++px) {
      const std::size_t at = 4 * (std::size_t{py} * kWidth + px);
      if (without[at] != 0.0f || without[at + 1] != 0.0f || without[at + 2] != 0.0f) continue;
      ++background;
      const glm::vec2 ndc = (glm::vec2(float(px), float(py)) + 0.5f) / glm::vec2(kWidth, kHeight) * 2.0f - 1.0f;
      const glm::vec4 n = clip_to_world * glm::vec4(ndc, 0.0f, 1.0f), f = clip_to_world * glm::vec4(ndc, 1.0f, 1.0f);
      const glm::vec3 d = glm::normalize(glm::vec3(f) / f.w - glm::vec3(n) / n.w);
      const glm::vec3 expected = env.toward(d);
      for (int c = 0; c < 3; ++c) {
        EXPECT_NEAR(lit[at + c], expected[c], 0.01f * expected[c] + 1e-3f) << px << ", " << py << " channel " << c;
        EXPECT_EQ(direct[at + c], 0.0f);
      }
    }
  EXPECT_GT(background, kWidth * kHeight / 50) << "the camera sees too little past the box to test the sky";
}

// Up to PENUMBRA_UNROLLED_LIGHTS lights the forward pipeline is specialised on their count; more
// loop over the frame's count. Cornell with its light and with eight more point lights that reach
// nothing it sees (range 1 cm, 50 m away): 1 and 9 lights, the two paths, the same image.
TEST_F(RendererTest, TheUnrolledAndTheLoopedLightPathsAgree) {
  auto s = bake_scene("cornell");
  ASSERT_TRUE(s);
  RenderSettings settings;
  settings.view = "direct";
  settings.shadow_map_size = 256;
  auto one = renderer_->render_image(s->world, camera(*s), kWidth, kHeight, settings);
  ASSERT_TRUE(one.ok()) << one.error().message;
  const std::uint32_t layers = renderer_->stats().shadow_layers;  // the rect light's six
  for (int i = 0; i < PENUMBRA_UNROLLED_LIGHTS; ++i) {
    const Entity e = s->world.create();
    Transform t;
    t.translation = glm::vec3(50.0f + float(i), 50.0f, 50.0f);
    s->world.add<Transform>(e, t);
    Light far;
    far.type = Light::Type::Point;
    far.intensity = 1.0f;
    far.range = 0.01f;
    s->world.add<Light>(e, far);
  }
  s->world.update(0.0);
  auto nine = renderer_->render_image(s->world, camera(*s), kWidth, kHeight, settings);
  ASSERT_TRUE(nine.ok()) << nine.error().message;
  EXPECT_EQ(renderer_->stats().shadow_layers, layers + 6u * PENUMBRA_UNROLLED_LIGHTS);
  EXPECT_EQ(one->rgba8, nine->rgba8);
}

// The shadow filter's trade: on the courtyard's direct view one bilinear tap and the four-tap tent
// differ only along shadow edges (some pixels, a mean under 1/255), and without shadows the
// shadowed ground is lit.
TEST_F(RendererTest, ShadowTapsChangeOnlyShadowEdges) {
  BakedScene& s = scene("courtyard");
  RenderSettings settings;
  settings.view = "direct";
  auto draw = [&]() {
    auto image = renderer_->render_image(s.world, camera(s), kWidth, kHeight, settings);
    EXPECT_TRUE(image.ok()) << (image.ok() ? "" : image.error().message);
    return image.ok() ? std::move(image->rgba8) : std::vector<std::uint8_t>{};
  };
  const auto tent = draw();
  settings.shadow_taps = 1;
  const auto bilinear = draw();
  settings.shadows = false;
  const auto unshadowed = draw();
  const Comparison taps = compare(tent, bilinear), none = compare(tent, unshadowed);
  std::size_t changed = 0;
  for (std::size_t p = 0; p < tent.size(); p += 4) changed += std::memcmp(&tent[p], &bilinear[p], 3) != 0;
  EXPECT_GE(changed, 20u) << "one tap drew the same image as four";
  EXPECT_LT(taps.mean_abs, 1.0 / 255.0);
  EXPECT_GE(none.differing, 200u) << "without shadows the shadowed ground should be lit";
}

// At 16 taps a rect light's shadows soften with the distance to their blocker (percentage-closer
// soft shadows), and nothing else changes: on the Cornell box's direct view (its ceiling rect) the
// pixels partly in shadow (10-90 % of the unshadowed light) at least double against the 4-tap
// tent, the frame's mean light stays within 3 % (the filter neither shadows lit surfaces by
// themselves nor lights the umbra), and the courtyard (sun and point lamp, no rect) is the same
// image bit for bit.
TEST_F(RendererTest, SixteenTapsSoftenOnlyTheRectLightsShadows) {
  auto draw = [&](BakedScene& s, std::uint32_t taps, bool shadows) {
    RenderSettings settings;
    settings.view = "direct";
    settings.shadow_taps = taps;
    settings.shadows = shadows;
    auto image = renderer_->render_image(s.world, camera(s), kWidth, kHeight, settings, true);
    EXPECT_TRUE(image.ok()) << (image.ok() ? "" : image.error().message);
    return image.ok() ? std::move(image->rgba32f) : std::vector<float>{};
  };
  BakedScene& cornell = scene("cornell");
  const auto open = draw(cornell, 4, false), tent = draw(cornell, 4, true), soft = draw(cornell, 16, true);
  ASSERT_FALSE(open.empty() || tent.empty() || soft.empty());
  std::size_t partial_tent = 0, partial_soft = 0;
  double sum_tent = 0.0, sum_soft = 0.0;
  for (std::size_t p = 0; p < open.size(); p += 4) {
    sum_tent += tent[p + 1];
    sum_soft += soft[p + 1];
    if (open[p + 1] < 1e-4f) continue;
    const float v_tent = tent[p + 1] / open[p + 1], v_soft = soft[p + 1] / open[p + 1];
    partial_tent += v_tent > 0.1f && v_tent < 0.9f;
    partial_soft += v_soft > 0.1f && v_soft < 0.9f;
  }
  EXPECT_GE(partial_soft, 2 * partial_tent) << "tent " << partial_tent << ", soft " << partial_soft;
  EXPECT_NEAR(sum_soft / sum_tent, 1.0, 0.03);
  BakedScene& courtyard = scene("courtyard");
  EXPECT_EQ(draw(courtyard, 16, true), draw(courtyard, 4, true));
}

// The ambient image holds probe irradiance in half floats scaled by 1 / a bound over the grid, so
// a grid a million times brighter (lights of 1e6 intensity) draws the same indirect view times 1e6
// (linear floats, within 0.5 %), finite everywhere, instead of overflowing half floats at 65504.
TEST_F(RendererTest, AmbientImageHoldsAMillionTimesBrighterGrid) {
  BakedScene& s = scene("cornell");
  const Entity grid = baked_probe_grid(s.world);
  ASSERT_TRUE(grid);
  const auto original = s.world.get<IrradianceProbeGrid>(grid).data;
  auto draw = [&]() { return linear_view(s.world, camera(s), kWidth, kHeight, "indirect", 2); };
  const auto base = draw();
  auto bright = std::make_shared<ProbeGridData>(*original);
  for (glm::vec3& c : bright->coefficients) c *= 1e6f;
  s.world.patch<IrradianceProbeGrid>(grid).data = bright;
  const auto scaled = draw();
  s.world.patch<IrradianceProbeGrid>(grid).data = original;
  ASSERT_EQ(base.size(), scaled.size());
  std::size_t lit = 0;
  for (std::size_t p = 0; p < base.size(); p += 4) {
    for (int c = 0; c < 3; ++c) {
      ASSERT_TRUE(std::isfinite(scaled[p + c])) << "pixel " << p / 4;
      if (base[p + c] < 1e-3f) continue;
      EXPECT_NEAR(scaled[p + c] / base[p + c], 1e6, 5e3) << "pixel " << p / 4 << " channel " << c;
      ++lit;
    }
  }
  EXPECT_GE(lit, std::size_t{kWidth} * kHeight);
}

// Shadow layers are drawn again only when what they see changed: on the courtyard (sun: 1 layer,
// lamp: 6) the first frame draws all 7, an unchanged frame none, a frame in which the walker moved
// those that see it (the sun's and some of the lamp's faces), and that frame is bit-identical to
// the same world drawn by a fresh renderer; so is a frame after the sun turned.
TEST_F(RendererTest, ShadowLayersAreKeptWhileWhatTheySeeIsUnchanged) {
  auto s = bake_scene("courtyard");
  ASSERT_TRUE(s);
  auto own = Renderer::create(*device_);
  ASSERT_TRUE(own.ok()) << own.error().message;
  Renderer& renderer = **own;
  RenderSettings settings;
  settings.shadow_map_size = 512;
  const CameraView cam = camera(*s);
  auto draw = [&](Renderer& r) {
    auto image = r.render_image(s->world, cam, kWidth, kHeight, settings);
    EXPECT_TRUE(image.ok()) << (image.ok() ? "" : image.error().message);
    return image.ok() ? std::move(image->rgba8) : std::vector<std::uint8_t>{};
  };
  auto fresh = [&]() {
    auto other = Renderer::create(*device_);
    EXPECT_TRUE(other.ok());
    return other.ok() ? draw(**other) : std::vector<std::uint8_t>{};
  };
  draw(renderer);
  EXPECT_EQ(renderer.stats().shadow_layers, 7u);
  EXPECT_EQ(renderer.stats().shadow_layers_rendered, 7u);
  draw(renderer);
  EXPECT_EQ(renderer.stats().shadow_layers_rendered, 0u);
  s->world.update(0.4);  // the walker steps on
  const auto moved = draw(renderer);
  EXPECT_GE(renderer.stats().shadow_layers_rendered, 1u);
  EXPECT_LE(renderer.stats().shadow_layers_rendered, 5u) << "layers that cannot see the walker were drawn again";
  std::printf("shadow layers drawn after the walker moved: %u of %u\n", renderer.stats().shadow_layers_rendered,
              renderer.stats().shadow_layers);
  EXPECT_EQ(moved, fresh());
  Entity sun;
  s->world.each<Light>([&](Entity e, Light& l) { if (l.type == Light::Type::Directional) sun = e; });
  ASSERT_TRUE(sun);
  s->world.patch<Transform>(sun).rotation =
      glm::quatLookAt(glm::normalize(glm::vec3(0.5f, -1.0f, -0.2f)), glm::vec3(0, 0, -1));
  s->world.update(0.0);
  const auto turned = draw(renderer);
  EXPECT_GE(renderer.stats().shadow_layers_rendered, 1u);
  EXPECT_EQ(turned, fresh());
  EXPECT_NE(turned, moved);
}

// The shader adds the probe grid to its own direct light: a grid that stores all light (direct
// included) is drawn as it is, with one logged warning per upload of such a grid.
TEST_F(RendererTest, AnAllLightProbeGridIsDrawnWithOneWarning) {
  BakedScene& s = scene("cornell");
  const Entity grid = baked_probe_grid(s.world);
  ASSERT_TRUE(grid);
  const std::shared_ptr<const ProbeGridData> indirect = s.world.get<IrradianceProbeGrid>(grid).data;
  ASSERT_EQ(indirect->lighting, LightingContent::Indirect);  // the scenes' default grid
  int warnings = 0;
  set_log_sink([&](LogLevel level, std::string_view message) {
    if (level == LogLevel::Warning && message.find("counts twice") != std::string_view::npos) ++warnings;
  });
  RenderSettings settings;
  const auto draw = [&] {
    auto image = renderer_->render_image(s.world, camera(s), kWidth, kHeight, settings);
    EXPECT_TRUE(image.ok()) << (image.ok() ? "" : image.error().message);
    return image.ok() ? image->rgba8 : std::vector<std::uint8_t>{};
  };
  const auto before = draw();
  EXPECT_EQ(warnings, 0);
  auto all = std::make_shared<ProbeGridData>(*indirect);
  all->lighting = LightingContent::All;
  s.world.patch<IrradianceProbeGrid>(grid).data = all;
  const auto with_all = draw();
  draw();
  EXPECT_EQ(warnings, 1);
  EXPECT_EQ(with_all, before);  // the same coefficients: nothing is subtracted
  s.world.patch<IrradianceProbeGrid>(grid).data = indirect;
  draw();
  EXPECT_EQ(warnings, 1);
  set_log_sink({});
}

// The shader's probe irradiance (Irradiance view, linear float) equals evaluate() on the CPU at the
// pixel's world position and normal (Position and Normal views) within 1%, up to the GPU's filter
// precision: a texture unit weighs the trilinear lookup's texels at a fraction rounded to
// subTexelPrecisionBits (8 on NVIDIA's, Vulkan's limits), so the shader's value may be the CPU's
// interpolation anywhere within 2^-bits of a cell of the leak guard's lookup fraction; the test
// takes the range over that box's corners (the expansion is multilinear in the fraction). Without
// the allowance an H200 missed by 1.6% where the Cornell box's SH terms change fast; llvmpipe
// filters in float and needs none. Both receiver kinds: every mesh tagged Static (the G-buffer's
// static flag, ProbeReceiver::Static on the CPU), then none (ProbeReceiver::Moving).
TEST_F(RendererTest, ProbeIrradianceMatchesTheCpuEvaluation) {
  for (const char* name : {"cornell", "courtyard"}) {
    for (const ProbeReceiver kind : {ProbeReceiver::Static, ProbeReceiver::Moving}) {
      BakedScene& s = scene(name);
      const ProbeGridData* data = nullptr;
      s.world.view<const IrradianceProbeGrid>().each([&](const IrradianceProbeGrid& g) {
        if (g.data) data = g.data.get();
      });
      ASSERT_NE(data, nullptr);
      // Every mesh of this kind for the three renders, then the scene as it was.
      std::vector<Entity> meshes, statics;
      s.world.view<const Mesh>().each([&](Entity e, const Mesh&) {
        meshes.push_back(e);
        if (s.world.has<Static>(e)) statics.push_back(e);
      });
      const auto tag = [&](bool all_static, const std::vector<Entity>& keep) {
        for (Entity e : meshes) {
          const bool want = all_static || std::find(keep.begin(), keep.end(), e) != keep.end();
          if (want && !s.world.has<Static>(e)) s.world.add<Static>(e);
          if (!want && s.world.has<Static>(e)) s.world.remove<Static>(e);
        }
      };
      tag(kind == ProbeReceiver::Static, {});
      auto render = [&](const std::string& view) {
        RenderSettings settings;
        settings.view = view;
        auto image = renderer_->render_image(s.world, camera(s), kWidth, kHeight, settings, true);
        EXPECT_TRUE(image.ok()) << (image.ok() ? "" : image.error().message);
        return image.ok() ? std::move(image->rgba32f) : std::vector<float>{};
      };
      const auto irradiance = render("irradiance");
      const auto position = render("position");
      const auto normal = render("normal");
      const auto albedo = render("albedo");
      tag(false, statics);
      ASSERT_EQ(irradiance.size(), std::size_t{kWidth} * kHeight * 4);
      // The same grid without the leak guard's reach: pixels where the two differ exercise the
      // shader's guarded lookup.
      ASSERT_FALSE(data->reach.empty()) << name << ": the scenes' default grid has the leak guard";
      ProbeGridData plain = *data;
      plain.reach.clear();
      VkPhysicalDeviceProperties props{};
      vkGetPhysicalDeviceProperties(device_->physical_device(), &props);
      const float step = device_->is_software() ? 0.0f : std::ldexp(1.0f, -int(props.limits.subTexelPrecisionBits));
      const ProbeGridLayout& layout = data->layout;
      const glm::vec3 cells(layout.resolution - 1u);
      const glm::mat4 grid_to_world = glm::inverse(layout.world_to_grid);
      int checked = 0, guarded = 0, kind_decides = 0;
      double worst = 0.0;
      for (std::uint32_t y = 2; y < kHeight; y += 7) {
        for (std::uint32_t x = 3; x < kWidth; x += 7) {
          const std::size_t p = (std::size_t{y} * kWidth + x) * 4;
          const glm::vec3 n(normal[p], normal[p + 1], normal[p + 2]);
          if (glm::length(n) < 0.5f) continue;  // background
          // A rect light's emitter: drawn, but a light, not a mesh the test tags as static.
          if (albedo[p] == 0.0f && albedo[p + 1] == 0.0f && albedo[p + 2] == 0.0f) continue;
          const glm::vec3 pos(position[p], position[p + 1], position[p + 2]), unit = glm::normalize(n);
          const glm::vec3 gpu(irradiance[p], irradiance[p + 1], irradiance[p + 2]);
          const glm::vec3 cpu = evaluate(*data, pos, unit, kind);
          const float scale = std::max({cpu.x, cpu.y, cpu.z, 1e-3f});
          if (glm::length(evaluate(plain, pos, unit) - cpu) > 0.05f * scale) ++guarded;
          const ProbeReceiver other = kind == ProbeReceiver::Static ? ProbeReceiver::Moving : ProbeReceiver::Static;
          if (glm::length(evaluate(*data, pos, unit, other) - cpu) > 0.05f * scale) ++kind_decides;
          // The CPU's range over the lookup fractions the filter may use (interpolate()'s steps).
          glm::vec3 lo = cpu, hi = cpu;
          if (step > 0.0f) {
            const glm::vec3 u = glm::clamp(glm::vec3(layout.world_to_grid * glm::vec4(pos, 1.0f)), 0.0f, 1.0f) * cells;
            const glm::uvec3 base = glm::min(glm::uvec3(u), layout.resolution - 2u);
            const glm::vec3 f = probe_lookup_fraction(*data, base, u - glm::vec3(base),
                                                      glm::mat3(layout.world_to_grid) * unit * cells, kind);
            for (int corner = 0; corner < 8; ++corner) {
              const glm::vec3 sign(corner & 1 ? 1.0f : -1.0f, corner & 2 ? 1.0f : -1.0f, corner & 4 ? 1.0f : -1.0f);
              const glm::vec3 g = (glm::vec3(base) + glm::clamp(f + step * sign, 0.0f, 1.0f)) / cells;
              const glm::vec3 e = evaluate(plain, glm::vec3(grid_to_world * glm::vec4(g, 1.0f)), unit);
              lo = glm::min(lo, e);
              hi = glm::max(hi, e);
            }
          }
          for (int k = 0; k < 3; ++k) {
            const double rel = std::max({0.0f, lo[k] - gpu[k], gpu[k] - hi[k]}) / scale;
            worst = std::max(worst, rel);
            EXPECT_LE(rel, 0.01) << name << " pixel (" << x << ", " << y << ") channel " << k << ": gpu " << gpu[k]
                                 << " cpu " << cpu[k] << " (" << lo[k] << " to " << hi[k] << " within the filter's "
                                 << step << " of a cell)";
          }
          ++checked;
        }
      }
      EXPECT_GE(checked, 100) << name;
      EXPECT_GE(guarded, 10) << name << ": too few pixels where the leak guard changes the lookup";
      // The Cornell box's turned blocks: pixels on their faces where the receiver kind decides.
      if (std::string(name) == "cornell") {
        EXPECT_GE(kind_decides, 5) << "too few pixels where the G-buffer's static flag matters";
      }
      const std::string label = std::string(name) + (kind == ProbeReceiver::Static ? "_static" : "_moving");
      RecordProperty(label + "_guarded_pixels", std::to_string(guarded));
      RecordProperty(label + "_kind_decides_pixels", std::to_string(kind_decides));
      RecordProperty(label + "_worst_relative_error", std::to_string(worst));
    }
  }
}

// Overlapping grids blend per pixel as the CPU blends them (probe_grid_weights): a second,
// brighter grid of higher priority over the courtyard grid's -x half, fading over a sixth of its
// width. The irradiance view equals the CPU blend of evaluate() within 1% where a grid covers the
// pixel, and pixels see the base grid alone, the fade, and mostly the second grid.
TEST_F(RendererTest, OverlappingProbeGridsBlendAsOnTheCpu) {
  BakedScene& s = scene("courtyard");
  std::shared_ptr<const ProbeGridData> base;
  s.world.view<const IrradianceProbeGrid>().each([&](const IrradianceProbeGrid& g) {
    if (g.data) base = g.data;
  });
  ASSERT_NE(base, nullptr);
  auto half = std::make_shared<ProbeGridData>(*base);
  half->layout.grid_to_world = base->layout.grid_to_world * glm::scale(glm::mat4(1.0f), glm::vec3(0.5f, 1.0f, 1.0f));
  half->layout.world_to_grid = glm::inverse(half->layout.grid_to_world);
  half->layout.spacing.x *= 0.5f;
  for (glm::vec3& c : half->coefficients) c *= 2.0f;
  const Entity second = s.world.create();
  IrradianceProbeGrid g;
  g.priority = 1;
  g.blend_distance = half->layout.spacing.x * float(half->layout.resolution.x - 1) / 6.0f;
  g.data = half;
  s.world.add<IrradianceProbeGrid>(second, g);
  s.world.add<Transform>(second, Transform{});
  s.world.update(0.0);
  const auto irradiance = linear_view(s.world, camera(s), kWidth, kHeight, "irradiance", 2);
  EXPECT_EQ(renderer_->stats().counter("probe-grid.grids"), 2u);
  const auto position = linear_view(s.world, camera(s), kWidth, kHeight, "position", 2);
  const auto normal = linear_view(s.world, camera(s), kWidth, kHeight, "normal", 2);
  const std::vector<BlendedProbeGrid> grids = blended_probe_grids(s.world);
  ASSERT_EQ(grids.size(), 2u);
  ASSERT_EQ(grids[0].data, half);
  std::vector<float> weights;
  int checked = 0, mostly_half = 0, only_base = 0, fading = 0;
  for (std::uint32_t y = 2; y < kHeight; y += 5) {
    for (std::uint32_t x = 3; x < kWidth; x += 5) {
      const std::size_t p = (std::size_t{y} * kWidth + x) * 4;
      const glm::vec3 n(normal[p], normal[p + 1], normal[p + 2]);
      if (glm::length(n) < 0.5f) continue;  // background
      const glm::vec3 pos(position[p], position[p + 1], position[p + 2]);
      if (!probe_grid_weights(grids, pos, weights)) continue;
      glm::vec3 cpu(0.0f);
      for (std::size_t i = 0; i < grids.size(); ++i) cpu += weights[i] * evaluate(*grids[i].data, pos, glm::normalize(n));
      const glm::vec3 gpu(irradiance[p], irradiance[p + 1], irradiance[p + 2]);
      const float scale = std::max({cpu.x, cpu.y, cpu.z, 1e-3f});
      for (int k = 0; k < 3; ++k)
        EXPECT_LE(std::abs(gpu[k] - cpu[k]) / scale, 0.01)
            << "pixel (" << x << ", " << y << ") channel " << k << ": gpu " << gpu[k] << " cpu " << cpu[k]
            << " weights " << weights[0] << ", " << weights[1];
      mostly_half += weights[0] >= 0.5f;
      only_base += weights[1] == 1.0f;
      fading += weights[0] > 0.0f && weights[0] < 1.0f;
      ++checked;
    }
  }
  EXPECT_GE(checked, 100);
  EXPECT_GE(mostly_half, 10);
  EXPECT_GE(only_base, 10);
  EXPECT_GE(fading, 10);
  s.world.destroy(second);
  s.world.update(0.0);
}

// The maze with a draft indirect transport (the only light is the moving lantern, so the probe
// grid has nothing to bake): the bounce light follows the lantern. Goldens of the lit view at two
// lantern positions; the lightmap view (the lightmap on the patches, the bounce probes elsewhere)
// and the probes view against the CPU lookups at the pixels' points.
TEST_F(RendererTest, IndirectTransportFollowsTheLanternAndMatchesTheCpu) {
  BakedScene s;
  register_scene_systems(s.world);
  register_indirect_transport_system(s.world);
  register_indirect_transport_baker(s.world);
  auto loaded = load_builtin(s.world, "maze");
  ASSERT_TRUE(loaded.ok());
  s.camera = loaded->camera;
  s.world.update(0.0);
  ASSERT_GT(add_default_indirect_transport(s.world, Preset::Draft), 0u);
  BakeSettings settings;
  settings.preset = Preset::Draft;
  JobContext jobs;
  auto baked = bake_world(s.world, {"indirect-transport"}, settings, jobs);
  ASSERT_TRUE(baked.ok()) << baked.error().message;
  Entity lantern, owner;
  for (Entity e : s.world.view<DynamicLight>().sorted_entities()) lantern = e;
  for (Entity e : s.world.view<IndirectTransport>().sorted_entities()) owner = e;
  ASSERT_TRUE(lantern && owner);
  s.world.remove<Animator>(lantern);
  std::vector<std::vector<float>> lightmaps;
  for (const glm::vec3 at : {glm::vec3(2.0f, 1.6f, 2.0f), glm::vec3(6.0f, 1.6f, 6.8f)}) {
    s.world.patch<Transform>(lantern).translation = at;
    s.world.update(0.0);
    ASSERT_TRUE(s.world.has<IndirectLightmap>(owner));
    RenderSettings lit;
    lit.shadow_map_size = 512;
    auto image = renderer_->render_image(s.world, camera(s), kWidth, kHeight, lit);
    ASSERT_TRUE(image.ok()) << image.error().message;
    expect_golden(*image, "maze_lit_" + std::to_string(lightmaps.size()));
    EXPECT_GT(renderer_->stats().counter("indirect-transport.patches"), 0u);
    lightmaps.push_back(linear_view(s.world, camera(s), kWidth, kHeight, "lightmap", 1));
    const std::vector<float> probes = linear_view(s.world, camera(s), kWidth, kHeight, "bounce-probes", 1);
    // CPU/GPU: the lookups at the pixels' points and normals.
    const auto position = linear_view(s.world, camera(s), kWidth, kHeight, "position", 1);
    const auto normal = linear_view(s.world, camera(s), kWidth, kHeight, "normal", 1);
    const TransportData& data = *s.world.get<IndirectTransport>(owner).data;
    const IndirectLightmap& map = s.world.get<IndirectLightmap>(owner);
    int checked = 0, close = 0, probes_lit = 0, probes_close = 0;
    const auto within = [](const std::vector<float>& gpu, std::size_t p, glm::vec3 cpu) {
      const float scale = std::max({cpu.x, cpu.y, cpu.z, 1e-3f});
      float worst = 0.0f;
      for (int k = 0; k < 3; ++k) worst = std::max(worst, std::abs(gpu[p + std::size_t(k)] - cpu[k]) / scale);
      return worst <= 0.01f;
    };
    for (std::uint32_t y = 2; y < kHeight; y += 4)
      for (std::uint32_t x = 3; x < kWidth; x += 4) {
        const std::size_t p = (std::size_t{y} * kWidth + x) * 4;
        const glm::vec3 n(normal[p], normal[p + 1], normal[p + 2]);
        if (glm::length(n) < 0.5f) continue;
        const glm::vec3 point(position[p], position[p + 1], position[p + 2]);
        ++checked;
        close += within(lightmaps.back(), p, sample_transport_irradiance(data, map, point, glm::normalize(n)));
        const glm::vec3 cpu_probes = sample_bounce_probes(data.probes, map.probes, point, glm::normalize(n));
        probes_close += within(probes, p, cpu_probes);
        probes_lit += cpu_probes.y > 1e-3f;
      }
    EXPECT_GE(checked, 500);
    EXPECT_GE(probes_lit, checked / 2) << "pixels the bounce probes light";
    EXPECT_GE(close, checked * 99 / 100) << "pixels within 1% of the CPU lookup";
    EXPECT_GE(probes_close, checked * 99 / 100) << "pixels of the probes view within 1% of the CPU lookup";
  }
  // The lantern moved from the first corridor to the far one: the bounce light moved with it.
  ASSERT_EQ(lightmaps[0].size(), lightmaps[1].size());
  double moved = 0.0, total = 0.0;
  for (std::size_t i = 0; i < lightmaps[0].size(); i += 4) {
    moved += std::abs(lightmaps[0][i] - lightmaps[1][i]);
    total += lightmaps[0][i];
  }
  EXPECT_GT(moved, 0.3 * total);
}

TEST_F(RendererTest, RejectsBadSizesAndReportsMemory) {
  BakedScene& s = scene("cornell");
  RenderSettings settings;
  auto zero = renderer_->render_image(s.world, camera(s), 0, kHeight, settings);
  ASSERT_FALSE(zero.ok());
  EXPECT_EQ(zero.error().code, ErrorCode::InvalidArgument);
  settings.shadow_map_size = 3;
  auto tiny = renderer_->render_image(s.world, camera(s), kWidth, kHeight, settings);
  ASSERT_FALSE(tiny.ok());
  EXPECT_NE(tiny.error().message.find("shadow_map_size"), std::string::npos);
  settings.shadow_map_size = 256;
  for (std::uint32_t step : {0u, 3u}) {
    settings.ambient_step = step;
    auto bad_step = renderer_->render_image(s.world, camera(s), kWidth, kHeight, settings);
    ASSERT_FALSE(bad_step.ok());
    EXPECT_NE(bad_step.error().message.find("ambient_step"), std::string::npos);
  }
  settings.ambient_step = 2;
  settings.shadow_taps = 2;
  auto bad_taps = renderer_->render_image(s.world, camera(s), kWidth, kHeight, settings);
  ASSERT_FALSE(bad_taps.ok());
  EXPECT_NE(bad_taps.error().message.find("shadow_taps"), std::string::npos);
  settings.shadow_taps = 4;
  ASSERT_TRUE(renderer_->render_image(s.world, camera(s), kWidth, kHeight, settings).ok());
  EXPECT_GT(renderer_->stats().gpu_bytes, std::uint64_t{kWidth} * kHeight * 4);
  EXPECT_GT(renderer_->stats().draws, 0u);
}

// A camera entity at `eye` looking at `target`: a close-up for the AO goldens.
CameraView look_at(World& world, glm::vec3 eye, glm::vec3 target) {
  const Entity e = world.create();
  Transform t;
  t.translation = eye;
  t.rotation = glm::quatLookAt(glm::normalize(target - eye), glm::vec3(0.0f, 1.0f, 0.0f));
  world.add<Transform>(e, t);
  world.add<Camera>(e, Camera{});
  update_world_transforms(world);
  return camera_view(world, e, float(kWidth) / float(kHeight));
}

// The AO-field pass's occlusion (AO view, linear float) on the courtyard's ground against
// 1 - evaluate_packed(), the CPU reference of the shader, at each pixel's world position and
// normal, where the crates darken it, at 640x480. At ambient_step 1 within 0.01 (half floats) on
// 99.9 % of the pixels and 0.015 on every one (an H200 put one of 113,558 pixels, on the contact
// shadow's steepest edge, 0.0125 off: Vulkan allows GPUs less precise division and transcendentals
// than llvmpipe's, which stays within 0.002). At step 2 the same on the
// pixels whose sample the pass computed (even coordinates); upsampled, within 0.01 on 99 % of all
// pixels and 0.3 on every one (the step's error is largest where the contact shadow changes within
// two pixels).
TEST_F(RendererTest, AoFieldPassMatchesTheCpuReference) {
  auto s = bake_scene("courtyard", {.ao_fields = true});
  ASSERT_TRUE(s);
  auto packed = pack_world_casters(s->world);
  ASSERT_TRUE(packed.ok()) << packed.error().message;
  ASSERT_EQ(packed->casters, 4u);
  constexpr std::uint32_t kW = 640, kH = 480;
  const CameraView view = camera_view(s->world, s->camera, float(kW) / float(kH));
  for (std::uint32_t step : {1u, 2u}) {
    auto render = [&](const std::string& debug_view) { return linear_view(s->world, view, kW, kH, debug_view, step); };
    const auto ao = render("ao");
    EXPECT_EQ(renderer_->stats().counter("ao-field.casters"), 4u);
    const auto position = render("position");
    const auto normal = render("normal");
    ASSERT_EQ(ao.size(), std::size_t{kW} * kH * 4);
    int ground = 0, occluded = 0, sampled = 0, within = 0, sampled_within = 0;
    double worst = 0.0, worst_sampled = 0.0;
    for (std::size_t p = 0; p < ao.size(); p += 4) {
      const glm::vec3 pos(position[p], position[p + 1], position[p + 2]);
      const glm::vec3 n(normal[p], normal[p + 1], normal[p + 2]);
      if (std::abs(pos.y) > 1e-3f || n.y < 0.99f) continue;  // the ground only (a Surface receiver)
      const float cpu = evaluate_packed(*packed, pos, glm::normalize(n));
      const double err = std::abs((1.0 - double(ao[p])) - double(cpu));
      const std::size_t x = p / 4 % kW, y = p / 4 / kW;
      const bool own_sample = x % step == 0 && y % step == 0;
      if (own_sample) {
        ++sampled;
        sampled_within += err <= 0.01;
        worst_sampled = std::max(worst_sampled, err);
      }
      EXPECT_LE(err, own_sample ? 0.015 : 0.3) << "step " << step << ", pixel (" << x << ", " << y << ") at ("
                                              << pos.x << ", " << pos.z << "): gpu " << 1.0f - ao[p] << " cpu "
                                              << cpu;
      worst = std::max(worst, err);
      ++ground;
      within += err <= 0.01;
      occluded += cpu > 0.05f;
    }
    EXPECT_GE(sampled, 10000);
    EXPECT_GE(sampled_within, 0.999 * sampled) << sampled_within << " of " << sampled << " own samples within 0.01";
    EXPECT_GE(within, 0.99 * ground) << within << " of " << ground << " ground pixels within 0.01";
    EXPECT_GE(occluded, 2000) << "too few ground pixels near the crates to test the pass";
    std::printf("AO-field pass at step %u against evaluate_packed on %d ground pixels: worst %.4f (own samples "
                "%.4f), %.2f %% within 0.01\n", step, ground, worst, worst_sampled, 100.0 * within / ground);
  }
}

// The ambient passes against the forward pass's own per-pixel terms on the courtyard with AO
// fields at 640x480 (linear float views): the indirect view is albedo / pi x the probe irradiance
// (the irradiance view, evaluated per pixel) x the AO view (vertex AO x open fraction), within 1 %
// (+0.002 W/m^2) on 99.9 % of the lit pixels at ambient_step 1, and at step 2 on 99.9 % of the
// pixels whose sample the passes computed and 98 % of all (the rest: edges the upsampling cannot
// follow).
TEST_F(RendererTest, AmbientPassesMatchThePerPixelTerms) {
  auto s = bake_scene("courtyard", {.ao_fields = true});
  ASSERT_TRUE(s);
  constexpr std::uint32_t kW = 640, kH = 480;
  const CameraView view = camera_view(s->world, s->camera, float(kW) / float(kH));
  for (std::uint32_t step : {1u, 2u}) {
    auto render = [&](const std::string& debug_view) { return linear_view(s->world, view, kW, kH, debug_view, step); };
    const auto indirect = render("indirect");
    const auto albedo = render("albedo");
    const auto irradiance = render("irradiance");
    const auto ao = render("ao");
    ASSERT_EQ(indirect.size(), std::size_t{kW} * kH * 4);
    std::size_t lit = 0, lit_ok = 0, sampled = 0, sampled_ok = 0;
    for (std::size_t p = 0; p < indirect.size(); p += 4) {
      if (irradiance[p] + irradiance[p + 1] + irradiance[p + 2] <= 0.0f) continue;  // background
      bool ok = true;
      for (int c = 0; c < 3; ++c) {
        const double expected = double(albedo[p + c]) / 3.14159265358979 * irradiance[p + c] * ao[p];
        ok = ok && std::abs(double(indirect[p + c]) - expected) <= 0.01 * expected + 0.002;
      }
      const std::size_t x = p / 4 % kW, y = p / 4 / kW;
      ++lit;
      lit_ok += ok;
      if (x % step == 0 && y % step == 0) {
        ++sampled;
        sampled_ok += ok;
      }
    }
    ASSERT_GE(lit, std::size_t{kW} * kH / 2);
    const double lit_fraction = double(lit_ok) / double(lit), sampled_fraction = double(sampled_ok) / double(sampled);
    EXPECT_GE(sampled_fraction, 0.999) << "step " << step << ": " << sampled_ok << " of " << sampled;
    EXPECT_GE(lit_fraction, step == 1 ? 0.999 : 0.98) << "step " << step << ": " << lit_ok << " of " << lit;
    std::printf("ambient step %u: %.3f %% of %zu lit pixels and %.3f %% of the %zu sampled ones within 1 %%\n", step,
                100.0 * lit_fraction, lit, 100.0 * sampled_fraction, sampled);
  }
}

// A moving crate (the courtyard's far one, (-3, 0.4, -6)) at two positions: from the scene's
// camera the AO images differ near the crate and are identical wherever both positions are beyond
// the crate's reach; close-ups in the AO and lit views match their goldens; moving it uploads only
// the caster records; an unchanged frame uploads nothing.
TEST_F(RendererTest, AoFieldShadowFollowsAMovingCrate) {
  auto s = bake_scene("courtyard", {.ao_fields = true});
  ASSERT_TRUE(s);
  World& w = s->world;
  Entity crate;
  std::size_t record = 0, casters = 0;
  for (Entity e : w.view<const AOFieldCaster, const WorldTransform>().sorted_entities()) {
    if (glm::distance(glm::vec3(w.get<WorldTransform>(e).matrix[3]), glm::vec3(-3.0f, 0.4f, -6.0f)) < 1e-3f) {
      crate = e;
      record = casters;
    }
    ++casters;
  }
  ASSERT_TRUE(crate);
  const CameraView cam = camera(*s);
  struct Frame {
    std::string golden;
    Image ao, lit;
    std::vector<float> position;
    glm::vec3 centre{0.0f};
    float reach = 0.0f;
  };
  const CameraView close_up = look_at(w, glm::vec3(-2.2f, 2.6f, -1.8f), glm::vec3(-2.2f, 0.2f, -5.6f));
  auto render = [&](Frame& f) {
    RenderSettings settings;
    settings.view = "ao";
    auto ao = renderer_->render_image(w, cam, kWidth, kHeight, settings);
    ASSERT_TRUE(ao.ok());
    auto ao_close = renderer_->render_image(w, close_up, kWidth, kHeight, settings);
    ASSERT_TRUE(ao_close.ok());
    expect_golden(*ao_close, f.golden + "_ao");
    settings.view = "lit";
    settings.shadow_map_size = 512;
    auto lit = renderer_->render_image(w, close_up, kWidth, kHeight, settings);
    ASSERT_TRUE(lit.ok());
    expect_golden(*lit, f.golden + "_lit");
    settings.view = "position";
    auto position = renderer_->render_image(w, cam, kWidth, kHeight, settings, true);
    ASSERT_TRUE(ao.ok() && lit.ok() && position.ok());
    f.ao = std::move(*ao);
    f.lit = std::move(*lit);
    f.position = std::move(position->rgba32f);
    auto packed = pack_world_casters(w);
    ASSERT_TRUE(packed.ok());
    const glm::vec4 reach = packed->data[1 + 7 * record + 6];  // world centre, world reach
    f.centre = glm::vec3(reach);
    f.reach = reach.w;
  };
  Frame a, b;
  a.golden = "courtyard_crate_a";
  b.golden = "courtyard_crate_b";
  render(a);
  EXPECT_EQ(renderer_->stats().counter("ao-field.bytes_uploaded"), 0u) << "nothing changed since the previous frame";
  // Moving the crate uploads the caster records (its transform), not the fields.
  w.patch<Transform>(crate).translation = glm::vec3(-1.5f, 0.4f, -5.0f);
  w.update(0.0);
  RenderSettings first_frame;
  first_frame.view = "ao";
  ASSERT_TRUE(renderer_->render_image(w, cam, kWidth, kHeight, first_frame).ok());
  EXPECT_EQ(renderer_->stats().counter("ao-field.bytes_uploaded"), (1 + 7 * casters) * sizeof(glm::vec4));
  render(b);
  ASSERT_GT(glm::distance(a.centre, b.centre), 1.0f);

  std::size_t near_changed = 0, far_pixels = 0, far_changed = 0;
  for (std::size_t p = 0; p < a.ao.rgba8.size(); p += 4) {
    bool far = true;
    for (const Frame* f : {&a, &b}) {
      const glm::vec3 pos(f->position[p], f->position[p + 1], f->position[p + 2]);
      far = far && glm::distance(pos, a.centre) > a.reach && glm::distance(pos, b.centre) > b.reach;
    }
    const bool changed = std::memcmp(&a.ao.rgba8[p], &b.ao.rgba8[p], 4) != 0;
    far_pixels += far;
    far_changed += far && changed;
    near_changed += !far && changed;
  }
  EXPECT_GE(near_changed, 50u) << "the crate's contact shadow did not move";
  EXPECT_GE(far_pixels, 1000u);
  EXPECT_EQ(far_changed, 0u) << "pixels beyond the crate's reach changed";
  EXPECT_GE(compare(a.lit.rgba8, b.lit.rgba8).differing, 50u);
}

// Entity receivers (the walker) take AOFieldReceiver::occlusion for the whole draw, and a caster
// that is also a Surface receiver is not shadowed by its own field (the far crate, alone within
// its reach, stays open on every face while the ground beside it darkens).
TEST_F(RendererTest, AoFieldEntityReceiversAndNoSelfShadow) {
  auto s = bake_scene("courtyard", {.ao_fields = true});
  ASSERT_TRUE(s);
  World& w = s->world;
  const std::vector<Entity> walkers = w.view<const AOFieldReceiver, const Skin>().sorted_entities();
  ASSERT_EQ(walkers.size(), 1u);
  const Entity walker = walkers[0];
  ASSERT_EQ(w.get<AOFieldReceiver>(walker).mode, AOFieldReceiver::Mode::Entity);
  const float system = w.get<AOFieldReceiver>(walker).occlusion;
  EXPECT_GT(system, 0.001f) << "the crates 2 m away should occlude the walker a little";
  const CameraView cam = look_at(w, glm::vec3(3.2f, 1.2f, 6.4f), glm::vec3(2.0f, 0.8f, 4.0f));
  RenderSettings settings;
  settings.view = "ao";
  auto render = [&](const CameraView& view) {
    auto image = renderer_->render_image(w, view, kWidth, kHeight, settings, true);
    EXPECT_TRUE(image.ok()) << (image.ok() ? "" : image.error().message);
    return image.ok() ? std::move(image->rgba32f) : std::vector<float>{};
  };
  const auto with_system = render(cam);
  w.patch<AOFieldReceiver>(walker).occlusion = 0.0f;
  const auto open = render(cam);
  w.patch<AOFieldReceiver>(walker).occlusion = 0.5f;
  const auto half = render(cam);
  ASSERT_EQ(open.size(), std::size_t{kWidth} * kHeight * 4);
  std::size_t walker_pixels = 0;
  for (std::size_t p = 0; p < open.size(); p += 4) {
    if (half[p] == open[p]) {
      EXPECT_EQ(with_system[p], open[p]) << "pixel " << p / 4;
      continue;
    }
    ++walker_pixels;
    EXPECT_NEAR(half[p], 0.5f * open[p], 1e-6f) << "pixel " << p / 4;
    EXPECT_NEAR(with_system[p], (1.0f - system) * open[p], 1e-5f) << "pixel " << p / 4;
  }
  EXPECT_GE(walker_pixels, 200u);

  // The far crate receives per pixel too, but skips its own record.
  Entity crate;
  for (Entity e : w.view<const AOFieldCaster, const WorldTransform>().sorted_entities())
    if (glm::distance(glm::vec3(w.get<WorldTransform>(e).matrix[3]), glm::vec3(-3.0f, 0.4f, -6.0f)) < 1e-3f) crate = e;
  ASSERT_TRUE(crate);
  AOFieldReceiver surface;
  surface.mode = AOFieldReceiver::Mode::Surface;
  w.add<AOFieldReceiver>(crate, surface);
  // At step 1 every crate pixel stays open; at step 2 those whose own sample lies on the crate do
  // (the rest, at the silhouette, may take a ground sample: none of the four is on their surface).
  const CameraView close_up = look_at(w, glm::vec3(-1.6f, 1.6f, -4.2f), glm::vec3(-3.0f, 0.3f, -6.0f));
  for (std::uint32_t step : {1u, 2u}) {
    settings.ambient_step = step;
    settings.view = "ao";
    const auto ao = render(close_up);
    settings.view = "position";
    const auto position = render(close_up);
    auto on_crate = [&](std::size_t p) {
      const glm::vec3 pos(position[p], position[p + 1], position[p + 2]);
      const glm::vec3 d = glm::abs(pos - glm::vec3(-3.0f, 0.4f, -6.0f));
      const float box = std::max({d.x, d.y, d.z});
      return box > 0.399f && box < 0.401f && position[p + 1] > 1e-3f;  // on the crate's faces
    };
    std::size_t crate_pixels = 0, ground_darkened = 0;
    for (std::size_t p = 0; p < ao.size(); p += 4) {
      const std::size_t x = p / 4 % kWidth, y = p / 4 / kWidth;
      const std::size_t own = 4 * ((y - y % step) * kWidth + (x - x % step));
      if (on_crate(p) && on_crate(own)) {
        ++crate_pixels;
        EXPECT_NEAR(ao[p], 1.0f, 1e-6f) << "the crate shadows itself at pixel " << p / 4 << ", step " << step;
      } else if (position[p + 1] < 1e-3f && ao[p] < 0.9f) {
        ++ground_darkened;
      }
    }
    EXPECT_GE(crate_pixels, 250u) << "step " << step;
    EXPECT_GE(ground_darkened, 50u) << "step " << step;
  }
}

// Without baked casters the pass is compiled out and costs nothing: the courtyard with its
// casters removed renders bit-identically to the courtyard that never had any (AO and lit views),
// and with them it renders differently.
TEST_F(RendererTest, AoFieldPassIsCompiledOutWithoutCasters) {
  auto s = bake_scene("courtyard", {.ao_fields = true});
  ASSERT_TRUE(s);
  BakedScene& plain = scene("courtyard");
  RenderSettings ao_view, lit_view;
  ao_view.view = "ao";
  lit_view.shadow_map_size = 512;
  auto with = renderer_->render_image(s->world, camera(*s), kWidth, kHeight, ao_view);
  ASSERT_TRUE(with.ok()) << with.error().message;
  EXPECT_EQ(renderer_->stats().counter("ao-field.casters"), 4u);
  for (Entity e : s->world.view<const AOFieldCaster>().sorted_entities()) s->world.remove<AOFieldCaster>(e);
  s->world.update(0.0);
  for (const RenderSettings& settings : {ao_view, lit_view}) {
    auto without = renderer_->render_image(s->world, camera(*s), kWidth, kHeight, settings);
    ASSERT_TRUE(without.ok()) << without.error().message;
    EXPECT_EQ(renderer_->stats().counter("ao-field.casters"), 0u);
    auto never = renderer_->render_image(plain.world, camera(plain), kWidth, kHeight, settings);
    ASSERT_TRUE(never.ok()) << never.error().message;
    EXPECT_EQ(renderer_->stats().counter("ao-field.bytes_uploaded"), 0u);
    EXPECT_EQ(without->rgba8, never->rgba8) << settings.view;
    if (settings.view == "ao") {
      EXPECT_GE(compare(with->rgba8, without->rgba8).differing, 50u);
    }
  }
}

// Pose-AO through VertexAO: the courtyard walker's per-vertex AO (draft bake) differs between two
// times of the walk cycle, the renderer uploads it only in frames where it changed, and the AO
// view at both times matches its golden and shows it (no other AO in this scene).
TEST_F(RendererTest, PoseAoChangesWithTheWalkCycle) {
  auto s = bake_scene("courtyard", {.pose_ao = true});
  ASSERT_TRUE(s);
  World& w = s->world;
  const std::vector<Entity> walkers = w.view<const SkinnedPoseAO, const VertexAO>().sorted_entities();
  ASSERT_EQ(walkers.size(), 1u);
  const Entity walker = walkers[0];
  const CameraView cam = look_at(w, glm::vec3(3.2f, 1.2f, 6.4f), glm::vec3(2.0f, 0.8f, 4.0f));
  RenderSettings settings;
  settings.view = "ao";
  auto darkened = [](const Image& image) {
    std::size_t n = 0;
    for (std::size_t p = 0; p < image.rgba8.size(); p += 4) n += image.rgba8[p] < 230;
    return n;
  };

  const std::vector<float> first_ao = w.get<VertexAO>(walker).ao;
  auto first = renderer_->render_image(w, cam, kWidth, kHeight, settings);
  ASSERT_TRUE(first.ok()) << first.error().message;
  EXPECT_GE(renderer_->stats().vertex_ao_uploads, 1u);
  ASSERT_TRUE(renderer_->render_image(w, cam, kWidth, kHeight, settings).ok());
  EXPECT_EQ(renderer_->stats().vertex_ao_uploads, 0u) << "an unchanged VertexAO was uploaded again";

  w.update(0.4);
  const std::vector<float>& second_ao = w.get<VertexAO>(walker).ao;
  ASSERT_EQ(first_ao.size(), second_ao.size());
  float change = 0.0f;
  for (std::size_t v = 0; v < first_ao.size(); ++v) change = std::max(change, std::abs(first_ao[v] - second_ao[v]));
  EXPECT_GT(change, 0.05f) << "the walk cycle did not change the per-vertex AO";
  auto second = renderer_->render_image(w, cam, kWidth, kHeight, settings);
  ASSERT_TRUE(second.ok()) << second.error().message;
  EXPECT_EQ(renderer_->stats().vertex_ao_uploads, 1u);

  EXPECT_GE(darkened(*first), 10u);
  EXPECT_GE(darkened(*second), 10u);
  expect_golden(*first, "courtyard_poseao_t0");
  expect_golden(*second, "courtyard_poseao_t04");
}

TEST(WriteImage, RejectsUnknownExtensionAndMissingPixels) {
  Image image;
  image.width = 2;
  image.height = 1;
  image.rgba8.assign(8, 255);
  const auto dir = std::filesystem::temp_directory_path();
  auto bad_ext = write_image(image, (dir / "penumbra_test.bmp").string());
  ASSERT_FALSE(bad_ext.ok());
  EXPECT_NE(bad_ext.error().message.find(".png"), std::string::npos);
  EXPECT_FALSE(write_image(image, (dir / "penumbra_test.exr").string()).ok());  // no float pixels
  ASSERT_TRUE(write_image(image, (dir / "penumbra_test.png").string()).ok());
  int w = 0, h = 0;
  const auto back = read_png(dir / "penumbra_test.png", w, h);
  EXPECT_EQ(w, 2);
  EXPECT_EQ(back, image.rgba8);
  image.rgba32f = {0.5f, 1.0f, 2.0f, 1.0f, 0.0f, 0.25f, 1e3f, 1.0f};
  EXPECT_TRUE(write_image(image, (dir / "penumbra_test.exr").string()).ok());
  std::filesystem::remove(dir / "penumbra_test.png");
  std::filesystem::remove(dir / "penumbra_test.exr");
}

}  // namespace
}  // namespace penumbra
