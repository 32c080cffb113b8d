// Judging an image against a reference of the same frame (the offline reference, or any other):
// error figures over the pixels both cover, and a false-colour map of where they differ.
#pragma once

#include <cstdint>
#include <limits>

#include "penumbra/core/result.h"
#include "penumbra/image/image.h"

namespace penumbra {

struct ImageComparison {
  std::uint64_t pixels = 0;  // compared: alpha > 0 and finite R, G, B in both
  // sqrt(sum |a - r|^2 / sum |r|^2) over R, G, B of the compared pixels.
  double rel_rmse = 0.0;
  // sum (a - r) / sum r over R, G, B: the relative bias (positive: the image is brighter).
  double mean_signed_error = 0.0;
  // Mean SSIM (Wang et al. 2004) of the display luminance (display_colour, exposure 1) over 7 x 7
  // windows of compared pixels: 1 for identical structure.
  double ssim = 0.0;
  // With the reference's per-pixel standard error: sqrt(sum se^2 / sum |r|^2), the part of
  // rel_rmse that the reference's own noise can explain; NaN without it.
  double reference_rel_stderr = std::numeric_limits<double>::quiet_NaN();
};

// Compares `image` with `reference` (both float images of one size; `reference_error`, when given,
// too). InvalidArgument naming what differs when the sizes or formats do not match, or when no
// pixel is covered by both. Cost: O(pixels x 49).
Result<ImageComparison> compare_images(const Image& image, const Image& reference, const Image* reference_error = nullptr);

// An 8-bit false-colour map of the relative luminance difference (a - r) / r at each compared
// pixel: red where the image is brighter, blue where darker, full at +-50 %, black where equal;
// pixels not compared are dark grey. Preconditions as compare_images (an empty image otherwise).
Image difference_image(const Image& image, const Image& reference);

}  // namespace penumbra
