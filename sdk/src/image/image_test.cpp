#include "penumbra/image/image.h"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>

#include "penumbra/image/image_compare.h"

namespace penumbra {
namespace {

std::filesystem::path temp(const char* name) { return std::filesystem::temp_directory_path() / name; }

Image ramp(std::uint32_t w, std::uint32_t h, float scale = 1.0f) {
  Image image;
  image.width = w;
  image.height = h;
  for (std::uint32_t y = 0; y < h; ++y)
    for (std::uint32_t x = 0; x < w; ++x)
      for (float v : {0.1f + 0.02f * float(x), 0.2f + 0.01f * float(y), 0.3f, 1.0f})
        image.rgba32f.push_back(image.rgba32f.size() % 4 == 3 ? v : v * scale);
  return image;
}

TEST(ImageIo, ExrRoundTripsBitExactly) {
  const Image image = ramp(13, 7);
  const auto path = temp("penumbra_image_test.exr");
  ASSERT_TRUE(write_image(image, path.string()).ok());
  auto back = read_exr(path.string());
  ASSERT_TRUE(back.ok()) << back.error().message;
  EXPECT_EQ(back->width, 13u);
  EXPECT_EQ(back->height, 7u);
  EXPECT_EQ(back->rgba32f, image.rgba32f);
  std::filesystem::remove(path);
}

TEST(ImageIo, BadExrFilesAreErrorsNamingThePath) {
  const auto missing = temp("penumbra_no_such_image.exr");
  auto r = read_exr(missing.string());
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().message.rfind(missing.string(), 0), 0u) << r.error().message;
  const auto garbage = temp("penumbra_garbage.exr");
  std::ofstream(garbage, std::ios::binary) << "v/1\x01 not an image at all";
  r = read_exr(garbage.string());
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("OpenEXR"), std::string::npos) << r.error().message;
  // A truncated real file.
  const auto truncated = temp("penumbra_truncated.exr");
  ASSERT_TRUE(write_image(ramp(64, 64), truncated.string()).ok());
  std::filesystem::resize_file(truncated, std::filesystem::file_size(truncated) / 2);
  r = read_exr(truncated.string());
  EXPECT_FALSE(r.ok());
  for (const auto& p : {garbage, truncated}) std::filesystem::remove(p);
}

TEST(ImageCompare, FiguresOfKnownDifferences) {
  const Image ref = ramp(16, 16);
  auto same = compare_images(ref, ref);
  ASSERT_TRUE(same.ok());
  EXPECT_EQ(same->pixels, 256u);
  EXPECT_EQ(same->rel_rmse, 0.0);
  EXPECT_EQ(same->mean_signed_error, 0.0);
  EXPECT_NEAR(same->ssim, 1.0, 1e-12);
  EXPECT_TRUE(std::isnan(same->reference_rel_stderr));
  // 10 % brighter everywhere: relative RMSE and bias are both 0.1.
  auto brighter = compare_images(ramp(16, 16, 1.1f), ref);
  ASSERT_TRUE(brighter.ok());
  EXPECT_NEAR(brighter->rel_rmse, 0.1, 1e-6);
  EXPECT_NEAR(brighter->mean_signed_error, 0.1, 1e-6);
  EXPECT_LT(brighter->ssim, 1.0);
  // Pixels with alpha 0 (not covered) and non-finite pixels are left out.
  Image holes = ramp(16, 16, 1.1f);
  holes.rgba32f[3] = 0.0f;
  holes.rgba32f[4] = NAN;
  auto partial = compare_images(holes, ref);
  ASSERT_TRUE(partial.ok());
  EXPECT_EQ(partial->pixels, 254u);
  EXPECT_NEAR(partial->rel_rmse, 0.1, 1e-6);
  // The reference's own error: a uniform 5 % of it.
  Image error = ramp(16, 16, 0.05f);
  auto noisy = compare_images(ref, ref, &error);
  ASSERT_TRUE(noisy.ok());
  EXPECT_NEAR(noisy->reference_rel_stderr, 0.05, 1e-6);
  // The map: red where brighter, blue where darker, grey where not compared.
  const Image map = difference_image(holes, ref);
  ASSERT_EQ(map.rgba8.size(), 256u * 4);
  EXPECT_EQ(map.rgba8[0], 48);
  EXPECT_GT(map.rgba8[8], 40);
  EXPECT_EQ(map.rgba8[10], 0);
}

TEST(ImageCompare, MismatchesAreRefusedByName) {
  auto r = compare_images(ramp(8, 8), ramp(8, 9));
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("8x9"), std::string::npos) << r.error().message;
  Image none = ramp(4, 4);
  for (std::size_t i = 3; i < none.rgba32f.size(); i += 4) none.rgba32f[i] = 0.0f;
  EXPECT_FALSE(compare_images(none, ramp(4, 4)).ok());
  Image eight;
  eight.width = eight.height = 4;
  eight.rgba8.assign(64, 0);
  EXPECT_FALSE(compare_images(eight, ramp(4, 4)).ok());
}

}  // namespace
}  // namespace penumbra
