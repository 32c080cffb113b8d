// Renderer tests, all with the Vulkan validation layer on (any message fails the test):
// golden images of the built-in scenes in every debug view, the one-pixel-shift sensitivity of
// the golden comparison, GPU skinning, and the shader's probe irradiance against the CPU's.
#include "penumbra/render/renderer.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <map>

#include "penumbra/bake/baker.h"
#include "penumbra/core/jobs.h"
#include "penumbra/probe_grid/probe_grid.h"
#include "penumbra/probe_grid/probe_system.h"
#include "penumbra/scene/animation.h"
#include "penumbra/scene/builtin.h"
#include "stb_image.h"
#include "test_device.h"

namespace penumbra {
namespace {

constexpr std::uint32_t kWidth = 160, kHeight = 120;
const std::filesystem::path kGoldenDir = std::filesystem::path(PENUMBRA_SOURCE_DIR) / "sdk/src/render/golden";

// A built-in scene with a draft probe grid baked in place (deterministic: seed 1).
struct BakedScene {
  World world;
  Entity camera;
};
std::unique_ptr<BakedScene> bake_scene(std::string_view name) {
  auto s = std::make_unique<BakedScene>();
  register_scene_systems(s->world);
  register_probe_grid(s->world);
  auto loaded = load_builtin(s->world, name);
  EXPECT_TRUE(loaded.ok());
  if (!loaded.ok()) return nullptr;
  s->camera = loaded->camera;
  s->world.update(0.0);
  auto grid = add_default_probe_grid(s->world, Preset::Draft);
  EXPECT_TRUE(grid.ok()) << (grid.ok() ? "" : grid.error().message);
  BakeSettings settings;
  settings.preset = Preset::Draft;
  JobContext jobs;
  auto baked = bake_world(s->world, {"probes"}, settings, jobs);
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

  static Device* device_;
  static Renderer* renderer_;
  static std::map<std::string, std::unique_ptr<BakedScene>>* scenes_;
};
Device* RendererTest::device_ = nullptr;
Renderer* RendererTest::renderer_ = nullptr;
std::map<std::string, std::unique_ptr<BakedScene>>* RendererTest::scenes_ = nullptr;

TEST_F(RendererTest, DebugViewNamesRoundTrip) {
  for (int v = 0; v < kDebugViewCount; ++v) {
    const auto view = static_cast<DebugView>(v);
    auto parsed = parse_debug_view(debug_view_name(view));
    ASSERT_TRUE(parsed.ok());
    EXPECT_EQ(*parsed, view);
  }
  auto bad = parse_debug_view("shiny");
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(bad.error().message.find("albedo"), std::string::npos);
}

class GoldenTest : public RendererTest, public ::testing::WithParamInterface<std::tuple<std::string, DebugView>> {};

TEST_P(GoldenTest, MatchesGolden) {
  const auto& [name, view] = GetParam();
  BakedScene& s = scene(name);
  RenderSettings settings;
  settings.view = view;
  settings.shadow_map_size = 512;
  auto image = renderer_->render_image(s.world, camera(s), kWidth, kHeight, settings);
  ASSERT_TRUE(image.ok()) << image.error().message;
  expect_golden(*image, name + "_" + std::string(debug_view_name(view)));
}

INSTANTIATE_TEST_SUITE_P(
    Scenes, GoldenTest,
    ::testing::Combine(::testing::Values("cornell", "courtyard"),
                       ::testing::Values(DebugView::Lit, DebugView::DirectOnly, DebugView::IndirectOnly,
                                         DebugView::AoOnly, DebugView::Albedo, DebugView::ProbeValidity)),
    [](const auto& test_param) {
      return std::get<0>(test_param.param) + "_" + std::string(debug_view_name(std::get<1>(test_param.param)));
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
  settings.view = DebugView::Albedo;
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

// The shader's probe irradiance (Irradiance view, linear float) equals evaluate() on the CPU at the
// pixel's world position and normal (Position and Normal views) within 1%.
TEST_F(RendererTest, ProbeIrradianceMatchesTheCpuEvaluation) {
  for (const char* name : {"cornell", "courtyard"}) {
    BakedScene& s = scene(name);
    const ProbeGridData* data = nullptr;
    s.world.view<const IrradianceProbeGrid>().each([&](const IrradianceProbeGrid& g) {
      if (g.data) data = g.data.get();
    });
    ASSERT_NE(data, nullptr);
    auto render = [&](DebugView view) {
      RenderSettings settings;
      settings.view = view;
      auto image = renderer_->render_image(s.world, camera(s), kWidth, kHeight, settings, true);
      EXPECT_TRUE(image.ok()) << (image.ok() ? "" : image.error().message);
      return image.ok() ? std::move(image->rgba32f) : std::vector<float>{};
    };
    const auto irradiance = render(DebugView::Irradiance);
    const auto position = render(DebugView::Position);
    const auto normal = render(DebugView::Normal);
    ASSERT_EQ(irradiance.size(), std::size_t{kWidth} * kHeight * 4);
    int checked = 0;
    double worst = 0.0;
    for (std::uint32_t y = 2; y < kHeight; y += 7) {
      for (std::uint32_t x = 3; x < kWidth; x += 7) {
        const std::size_t p = (std::size_t{y} * kWidth + x) * 4;
        const glm::vec3 n(normal[p], normal[p + 1], normal[p + 2]);
        if (glm::length(n) < 0.5f) continue;  // background
        const glm::vec3 pos(position[p], position[p + 1], position[p + 2]);
        const glm::vec3 gpu(irradiance[p], irradiance[p + 1], irradiance[p + 2]);
        const glm::vec3 cpu = evaluate(*data, pos, glm::normalize(n));
        const float scale = std::max({cpu.x, cpu.y, cpu.z, 1e-3f});
        for (int k = 0; k < 3; ++k) {
          const double rel = std::abs(gpu[k] - cpu[k]) / scale;
          worst = std::max(worst, rel);
          EXPECT_LE(rel, 0.01) << name << " pixel (" << x << ", " << y << ") channel " << k << ": gpu " << gpu[k]
                               << " cpu " << cpu[k];
        }
        ++checked;
      }
    }
    EXPECT_GE(checked, 100) << name;
    RecordProperty(std::string(name) + "_worst_relative_error", std::to_string(worst));
  }
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
  ASSERT_TRUE(renderer_->render_image(s.world, camera(s), kWidth, kHeight, settings).ok());
  EXPECT_GT(renderer_->stats().gpu_bytes, std::uint64_t{kWidth} * kHeight * 4);
  EXPECT_GT(renderer_->stats().draws, 0u);
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
