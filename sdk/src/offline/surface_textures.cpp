// Base colour textures at primary hits (offline/surface_textures.h).
#include "penumbra/offline/surface_textures.h"

#include <array>
#include <cmath>

#include <glm/vec2.hpp>

namespace penumbra {
namespace {

// sRGB -> linear for each 8-bit value.
const std::array<float, 256>& srgb_to_linear() {
  static const std::array<float, 256> table = [] {
    std::array<float, 256> t{};
    for (int i = 0; i < 256; ++i) {
      const float c = float(i) / 255.0f;
      t[std::size_t(i)] = c <= 0.04045f ? c / 12.92f : std::pow((c + 0.055f) / 1.055f, 2.4f);
    }
    return t;
  }();
  return table;
}

glm::vec3 texel(const Texture& t, int x, int y) {
  // Repeat addressing.
  x = ((x % t.width) + t.width) % t.width;
  y = ((y % t.height) + t.height) % t.height;
  const std::uint8_t* p = &t.rgba8[(std::size_t(y) * std::size_t(t.width) + std::size_t(x)) * 4];
  const auto& lut = srgb_to_linear();
  return {lut[p[0]], lut[p[1]], lut[p[2]]};
}

glm::vec3 sample_bilinear(const Texture& t, glm::vec2 uv) {
  const float fx = uv.x * float(t.width) - 0.5f, fy = uv.y * float(t.height) - 0.5f;
  const float x0 = std::floor(fx), y0 = std::floor(fy);
  const float ax = fx - x0, ay = fy - y0;
  // Far-off uvs lose precision in float; wrap them into one period first.
  const int ix = static_cast<int>(std::fmod(x0, float(t.width))), iy = static_cast<int>(std::fmod(y0, float(t.height)));
  return (1.0f - ay) * ((1.0f - ax) * texel(t, ix, iy) + ax * texel(t, ix + 1, iy)) +
         ay * ((1.0f - ax) * texel(t, ix, iy + 1) + ax * texel(t, ix + 1, iy + 1));
}

}  // namespace

SurfaceTextures SurfaceTextures::gather(World& world) {
  SurfaceTextures out;
  world.view<const Mesh, const Material>().each([&](Entity e, const Mesh& mesh, const Material& m) {
    const Texture* t = m.base_color_texture.get();
    if (!t || !mesh.data || mesh.data->uvs.size() != mesh.data->positions.size() || t->width <= 0 || t->height <= 0 ||
        t->rgba8.size() != std::size_t(t->width) * std::size_t(t->height) * 4)
      return;
    out.entries_[e.index] = Entry{mesh.data, m.base_color_texture, glm::vec3(m.base_color)};
  });
  return out;
}

glm::vec3 SurfaceTextures::albedo(const Hit& hit) const {
  const auto it = entries_.find(hit.entity.index);
  if (it == entries_.end()) return hit.material.albedo;
  const MeshData& mesh = *it->second.mesh;
  if (std::size_t{hit.primitive} * 3 + 2 >= mesh.indices.size()) return hit.material.albedo;
  const std::uint32_t* tri = &mesh.indices[std::size_t{hit.primitive} * 3];
  const glm::vec2 uv = (1.0f - hit.barycentrics.x - hit.barycentrics.y) * mesh.uvs[tri[0]] +
                       hit.barycentrics.x * mesh.uvs[tri[1]] + hit.barycentrics.y * mesh.uvs[tri[2]];
  if (!std::isfinite(uv.x) || !std::isfinite(uv.y)) return hit.material.albedo;
  return it->second.base * sample_bilinear(*it->second.texture, uv);
}

}  // namespace penumbra
