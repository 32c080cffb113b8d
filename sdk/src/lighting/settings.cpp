// Presets and lighting content names (see settings.h).
#include "penumbra/lighting/settings.h"

#include <string>

namespace penumbra {

const char* to_string(Preset preset) {
  switch (preset) {
    case Preset::Draft: return "draft";
    case Preset::Medium: return "medium";
    case Preset::High: return "high";
  }
  return "medium";
}

Result<Preset> parse_preset(std::string_view text) {
  if (text == "draft") return Preset::Draft;
  if (text == "medium") return Preset::Medium;
  if (text == "high") return Preset::High;
  return make_error(ErrorCode::InvalidArgument,
                    "unknown preset '" + std::string(text) + "'; use draft, medium or high");
}

const char* to_string(LightingContent content) {
  return content == LightingContent::Indirect ? "indirect" : "all";
}

}  // namespace penumbra
