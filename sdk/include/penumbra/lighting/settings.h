// The vocabulary every lighting module shares: quality presets and what a lighting quantity holds.
#pragma once

#include <cstdint>
#include <string_view>

#include "penumbra/core/result.h"

namespace penumbra {

// Quality presets shared by every technique: each maps them to its own sample counts.
enum class Preset : std::uint8_t { Draft, Medium, High };
const char* to_string(Preset preset);
Result<Preset> parse_preset(std::string_view text);  // "draft", "medium", "high"

// Which light an irradiance quantity counts (the split of a path at its first surface hit):
//   All: direct + indirect, the whole E(x, n).
//   Indirect: the light that reflected at least once on its way to x, i.e. E minus the lights'
//     direct light at x and minus the emission of the surfaces x sees. What a renderer that draws
//     direct light itself (shadow maps) adds from a probe grid; note that such a renderer must then
//     draw emissive surfaces' light on others itself too (the SDK's renderer does not).
enum class LightingContent : std::uint8_t { All, Indirect };
const char* to_string(LightingContent content);  // "all", "indirect"

}  // namespace penumbra
