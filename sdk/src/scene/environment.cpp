// The World's environment and equirectangular maps (scene/components.h, Environment).
#include <algorithm>
#include <cmath>
#include <numbers>

#include "penumbra/core/hash.h"
#include "penumbra/scene/components.h"

namespace penumbra {

Result<std::shared_ptr<const EnvironmentMap>> make_environment_map(std::uint32_t width, std::uint32_t height,
                                                                   std::vector<glm::vec3> texels,
                                                                   std::string_view context) {
  const std::string where(context);
  if (width == 0 || height == 0 || width > 16384 || height > 16384)
    return make_error(ErrorCode::InvalidArgument, where + ": an environment map of " + std::to_string(width) + " x " +
                                                      std::to_string(height) +
                                                      " texels; give 1 to 16384 texels on each side (2:1 for "
                                                      "an equirectangular sky)");
  if (texels.size() != std::size_t{width} * height)
    return make_error(ErrorCode::InvalidArgument, where + ": " + std::to_string(texels.size()) +
                                                      " texels for a map of " + std::to_string(width) + " x " +
                                                      std::to_string(height));
  for (std::size_t i = 0; i < texels.size(); ++i) {
    const glm::vec3 t = texels[i];
    if (!(std::isfinite(t.x) && std::isfinite(t.y) && std::isfinite(t.z) && t.x >= 0.0f && t.y >= 0.0f &&
          t.z >= 0.0f))
      return make_error(ErrorCode::InvalidArgument,
                        where + ": texel (" + std::to_string(i % width) + ", " + std::to_string(i / width) +
                            ") is negative, NaN or infinite; radiance must be finite and >= 0 (fix the image, "
                            "e.g. clamp it in the tool that wrote it)");
  }
  auto map = std::make_shared<EnvironmentMap>();
  map->width = width;
  map->height = height;
  map->texels = std::move(texels);
  Hasher h;
  h.add(width);
  h.add(height);
  h.add(map->texels);
  map->digest = h.digest();
  return std::shared_ptr<const EnvironmentMap>(std::move(map));
}

glm::vec3 sample_environment_map(const EnvironmentMap& map, glm::vec3 d) {
  // Texel coordinates with texel centres at integers + 0.5.
  const float u = 0.5f + std::atan2(d.x, -d.z) * (0.5f * std::numbers::inv_pi_v<float>);
  const float v = std::acos(std::clamp(d.y, -1.0f, 1.0f)) * std::numbers::inv_pi_v<float>;
  if (!(std::isfinite(u) && std::isfinite(v))) return glm::vec3(0.0f);  // a NaN direction sees nothing
  const float x = u * static_cast<float>(map.width) - 0.5f;
  const float y = std::clamp(v * static_cast<float>(map.height) - 0.5f, 0.0f, static_cast<float>(map.height - 1));
  const float fx = std::floor(x), fy = std::floor(y);
  const float tx = x - fx, ty = y - fy;
  const auto w = static_cast<std::int64_t>(map.width);
  const std::int64_t x0 = ((static_cast<std::int64_t>(fx) % w) + w) % w, x1 = (x0 + 1) % w;
  const auto y0 = static_cast<std::size_t>(fy);
  const std::size_t y1 = std::min<std::size_t>(y0 + 1, map.height - 1);
  auto at = [&](std::int64_t xi, std::size_t yi) { return map.texels[yi * map.width + static_cast<std::size_t>(xi)]; };
  return (1.0f - ty) * ((1.0f - tx) * at(x0, y0) + tx * at(x1, y0)) + ty * ((1.0f - tx) * at(x0, y1) + tx * at(x1, y1));
}

Environment world_environment(World& world) {
  const std::vector<Entity> skies = world.view<const Environment>().sorted_entities();
  return skies.empty() ? Environment{} : world.get<Environment>(skies.front());
}

}  // namespace penumbra
