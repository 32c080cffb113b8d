// compare_images and difference_image (image/image_compare.h).
#include "penumbra/image/image_compare.h"

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "penumbra/core/colour.h"

namespace penumbra {
namespace {

bool compared(const Image& a, std::size_t i) {
  const float* p = &a.rgba32f[4 * i];
  return p[3] > 0.0f && std::isfinite(p[0]) && std::isfinite(p[1]) && std::isfinite(p[2]);
}

Status check_pair(const Image& a, const Image& b, const char* what) {
  if (a.width != b.width || a.height != b.height)
    return make_error(ErrorCode::InvalidArgument, std::string(what) + " is " + std::to_string(b.width) + "x" +
                                                      std::to_string(b.height) + " but the image is " +
                                                      std::to_string(a.width) + "x" + std::to_string(a.height) +
                                                      "; render both at one size");
  const std::size_t n = std::size_t(a.width) * a.height;
  if (n == 0 || a.rgba32f.size() != 4 * n || b.rgba32f.size() != 4 * n)
    return make_error(ErrorCode::InvalidArgument, std::string(what) + ": both images must be float (OpenEXR) images");
  return {};
}

}  // namespace

Result<ImageComparison> compare_images(const Image& image, const Image& reference, const Image* reference_error) {
  PENUMBRA_TRY(check_pair(image, reference, "the reference"));
  if (reference_error) PENUMBRA_TRY(check_pair(image, *reference_error, "the reference's error image"));
  const std::uint32_t w = image.width, h = image.height;
  const std::size_t n = std::size_t(w) * h;
  std::vector<std::uint8_t> both(n);
  ImageComparison c;
  double err2 = 0.0, ref2 = 0.0, diff = 0.0, sum = 0.0, se2 = 0.0;
  for (std::size_t i = 0; i < n; ++i) {
    both[i] = compared(image, i) && compared(reference, i);
    if (!both[i]) continue;
    ++c.pixels;
    for (int k = 0; k < 3; ++k) {
      const double a = image.rgba32f[4 * i + k], r = reference.rgba32f[4 * i + k];
      err2 += (a - r) * (a - r);
      ref2 += r * r;
      diff += a - r;
      sum += r;
      if (reference_error) {
        const double se = reference_error->rgba32f[4 * i + k];
        if (std::isfinite(se)) se2 += se * se;
      }
    }
  }
  if (c.pixels == 0)
    return make_error(ErrorCode::InvalidArgument, "no pixel is covered by both images (alpha > 0 and finite colour)");
  c.rel_rmse = ref2 > 0.0 ? std::sqrt(err2 / ref2) : (err2 > 0.0 ? INFINITY : 0.0);
  c.mean_signed_error = sum > 0.0 ? diff / sum : (diff != 0.0 ? INFINITY : 0.0);
  if (reference_error) c.reference_rel_stderr = ref2 > 0.0 ? std::sqrt(se2 / ref2) : 0.0;

  // SSIM of the display luminance over 7 x 7 windows (Wang, Bovik, Sheikh & Simoncelli 2004).
  std::vector<float> ya(n), yr(n);
  for (std::size_t i = 0; i < n; ++i) {
    if (!both[i]) continue;
    ya[i] = luminance(display_colour(pixel_rgb(image, i), 1.0f, true));
    yr[i] = luminance(display_colour(pixel_rgb(reference, i), 1.0f, true));
  }
  constexpr double kC1 = 0.01 * 0.01, kC2 = 0.03 * 0.03;
  constexpr int kRadius = 3;
  double ssim_sum = 0.0;
  std::uint64_t windows = 0;
  for (std::uint32_t y = 0; y < h; ++y) {
    for (std::uint32_t x = 0; x < w; ++x) {
      if (!both[std::size_t(y) * w + x]) continue;
      double sa = 0, sr = 0, saa = 0, srr = 0, sar = 0;
      int m = 0;
      for (int dy = -kRadius; dy <= kRadius; ++dy) {
        for (int dx = -kRadius; dx <= kRadius; ++dx) {
          const long qx = long(x) + dx, qy = long(y) + dy;
          if (qx < 0 || qy < 0 || qx >= long(w) || qy >= long(h)) continue;
          const std::size_t q = std::size_t(qy) * w + std::size_t(qx);
          if (!both[q]) continue;
          sa += ya[q];
          sr += yr[q];
          saa += double(ya[q]) * ya[q];
          srr += double(yr[q]) * yr[q];
          sar += double(ya[q]) * yr[q];
          ++m;
        }
      }
      if (m < 9) continue;  // too few compared neighbours for local statistics
      const double ma = sa / m, mr = sr / m;
      const double va = std::max(saa / m - ma * ma, 0.0), vr = std::max(srr / m - mr * mr, 0.0), cov = sar / m - ma * mr;
      ssim_sum += ((2 * ma * mr + kC1) * (2 * cov + kC2)) / ((ma * ma + mr * mr + kC1) * (va + vr + kC2));
      ++windows;
    }
  }
  c.ssim = windows ? ssim_sum / double(windows) : std::numeric_limits<double>::quiet_NaN();
  return c;
}

Image difference_image(const Image& image, const Image& reference) {
  Image out;
  if (!check_pair(image, reference, "the reference").ok()) return out;
  out.width = image.width;
  out.height = image.height;
  const std::size_t n = std::size_t(image.width) * image.height;
  out.rgba8.assign(4 * n, 255);
  for (std::size_t i = 0; i < n; ++i) {
    std::uint8_t* p = &out.rgba8[4 * i];
    if (!compared(image, i) || !compared(reference, i)) {
      p[0] = p[1] = p[2] = 48;
      continue;
    }
    const float a = luminance(pixel_rgb(image, i)), r = luminance(pixel_rgb(reference, i));
    const float rel = r > 0.0f ? (a - r) / r : (a > 0.0f ? 1.0f : 0.0f);
    const auto level = static_cast<std::uint8_t>(std::lround(std::clamp(std::abs(rel) / 0.5f, 0.0f, 1.0f) * 255.0f));
    p[0] = rel > 0.0f ? level : 0;
    p[1] = 0;
    p[2] = rel < 0.0f ? level : 0;
  }
  return out;
}

}  // namespace penumbra
