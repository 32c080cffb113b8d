// Colour as the SDK treats it everywhere (bakes, the renderer, images, the benches' error figures):
// linear RGB with Rec. 709 (sRGB) primaries.
#pragma once

#include <glm/vec3.hpp>

namespace penumbra {

// The Rec. 709 luminance weights: Y = dot(kLuminanceWeights, rgb).
inline constexpr float kLuminanceWeights[3] = {0.2126f, 0.7152f, 0.0722f};

// The relative luminance Y of a linear Rec. 709 colour. O(1).
inline float luminance(glm::vec3 c) {
  return kLuminanceWeights[0] * c.x + kLuminanceWeights[1] * c.y + kLuminanceWeights[2] * c.z;
}

}  // namespace penumbra
