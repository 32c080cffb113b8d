// Environment maps from files: an equirectangular OpenEXR sky for Environment::map_data
// (scene/components.h).
#pragma once

#include <filesystem>
#include <memory>

#include "penumbra/core/result.h"
#include "penumbra/scene/components.h"

namespace penumbra {

// Reads an equirectangular OpenEXR file (R, G, B as linear radiance, W/(m^2 sr); A ignored; +Y up,
// the top row looking up: EnvironmentMap) into a map. An untrusted-file loader: errors name the
// path and the fix (read_exr's: missing, not an EXR, damaged, no R/G/B, too large; then a texel
// that is negative, NaN or infinite, naming its x, y). Cost: O(texels); 12 bytes per texel.
Result<std::shared_ptr<const EnvironmentMap>> load_environment_map(const std::filesystem::path& path);

}  // namespace penumbra
