// The probe grid's GPU layout (see probe_grid_gpu.h).
#include "penumbra/probe_grid/probe_grid_gpu.h"

#include <cstring>

namespace penumbra {

ProbeGridTextures pack_probe_grid_textures(const ProbeGridData& data) {
  ProbeGridTextures t;
  t.extent = data.layout.resolution;
  t.world_to_grid = data.layout.world_to_grid;
  const std::size_t count = static_cast<std::size_t>(sh_coefficients(data.sh_order));
  const std::size_t slots = count * 3;
  t.textures = static_cast<std::uint32_t>((slots + 3) / 4);
  const std::size_t nodes = data.node_count();
  t.data.resize(t.textures * nodes * t.texel_bytes());
  for (std::size_t tex = 0; tex < t.textures; ++tex) {
    for (std::size_t n = 0; n < nodes; ++n) {
      float texel[4] = {0.0f, 0.0f, 0.0f, 0.0f};
      for (std::size_t k = 0; k < 4; ++k) {
        const std::size_t s = tex * 4 + k;  // slot: coefficient s / 3, channel s % 3
        if (s < slots) texel[k] = data.coefficients[n * count + s / 3][static_cast<int>(s % 3)];
      }
      std::byte* dst = t.data.data() + (tex * nodes + n) * t.texel_bytes();
      std::memcpy(dst, texel, sizeof texel);
    }
  }
  return t;
}

std::vector<glm::vec4> pack_probe_node_texels(const ProbeGridData& data) {
  std::vector<glm::vec4> texels(data.node_count(), glm::vec4(0.0f));
  for (std::size_t n = 0; n < texels.size(); ++n) {
    if (n < data.validity.size()) texels[n].r = data.validity[n];
    if (data.reach.empty()) continue;
    const std::uint8_t* r = &data.reach[6 * n];
    texels[n].g = float(r[0] + 256u * r[1] + 65536u * r[2]);
    texels[n].b = float(r[3] + 256u * r[4] + 65536u * r[5]);
  }
  return texels;
}

}  // namespace penumbra
