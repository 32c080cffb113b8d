// CPU images: the renderer's read-backs and the offline renderer's frames, PNG and OpenEXR files,
// and the one display transform (tone mapping) every path shares.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include <glm/vec3.hpp>

#include "penumbra/core/result.h"

namespace penumbra {

// The display colour the renderer writes for scene-referred radiance into 8-bit targets
// (shaders/output.glsl): radiance x exposure through the ACES filmic fit of Narkowicz (2015), then
// the sRGB transfer when `encode_srgb` (UNORM targets; sRGB formats encode in hardware). O(1).
glm::vec3 display_colour(glm::vec3 radiance, float exposure, bool encode_srgb);

// A CPU image read back from a target: RGBA, 8-bit sRGB or 32-bit float linear.
struct Image {
  std::uint32_t width = 0, height = 0;
  std::vector<std::uint8_t> rgba8;  // when read as 8-bit
  std::vector<float> rgba32f;       // when read as float
};
// The linear RGB of pixel i (row-major from the top row) of a float image. Precondition: rgba32f
// holds it. O(1).
inline glm::vec3 pixel_rgb(const Image& image, std::size_t i) {
  return {image.rgba32f[4 * i], image.rgba32f[4 * i + 1], image.rgba32f[4 * i + 2]};
}

// PNG (8-bit; from rgba8) or OpenEXR (32-bit float RGBA; from rgba32f) by the extension of `path`;
// atomic (temporary file, then rename). Errors name the path and the fix (unknown extension, the
// image lacks the pixels the format needs, the directory is not writable).
Status write_image(const Image& image, const std::string& path);

// Reads an OpenEXR file into rgba32f (R, G, B as stored, converted to float; A, or 1 when the file
// has none). An untrusted-file loader: every failure is an error naming the path and the fix (not
// an EXR, damaged, no R/G/B channels, larger than 16384 x 16384 or 2^26 pixels), never a crash.
// Cost: O(pixels).
Result<Image> read_exr(const std::string& path);

}  // namespace penumbra
