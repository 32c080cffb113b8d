// The probe grid's GPU layout: the textures a renderer samples for per-pixel lookups, with the
// same interpolation as the CPU evaluation (probe_grid.h).
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include <glm/mat4x4.hpp>
#include <glm/vec3.hpp>
#include <glm/vec4.hpp>

#include "penumbra/probe_grid/probe_grid.h"

namespace penumbra {

// GPU layout for per-pixel lookups: `textures` 3D textures of resolution.x x .y x .z RGBA texels.
// Texel value slot s (0..4 x textures - 1) of node n holds channel s % 3 of coefficient s / 3, so
// L1 needs 3 textures (12 slots) and L2 7 (27 slots, the last padded with 0). data holds texture
// 0 slice z = 0 row y = 0 first, x fastest, then rows, slices, textures. The shader computes
// uvw = ((world_to_grid * x).xyz * (resolution - 1) + 0.5) / resolution and lets the sampler's
// trilinear filter do the interpolation, then evaluates the SH as sh_evaluate and clamps at 0.
// Texels are RGBA32F: the sampler's trilinear filter is then the CPU's interpolation.
struct ProbeGridTextures {
  glm::uvec3 extent{0u};
  std::uint32_t textures = 0;
  glm::mat4 world_to_grid{1.0f};
  std::vector<std::byte> data;
  static constexpr std::size_t texel_bytes() { return 16; }
};
// Packs the data into that layout. Cost: O(nodes x coefficients). Thread-safe.
ProbeGridTextures pack_probe_grid_textures(const ProbeGridData& data);

// The node texture beside them (one RGBA32F texel per node, same order): r the validity; g and b
// the leak guard's reach bytes as exact integers below 2^24, g = +x + 256 (-x) + 65536 (+y),
// b = -y + 256 (+z) + 65536 (-z), both 0 without reach data; a 0. The shader fetches the eight
// corners unfiltered. Cost: O(nodes). Thread-safe.
std::vector<glm::vec4> pack_probe_node_texels(const ProbeGridData& data);

}  // namespace penumbra
