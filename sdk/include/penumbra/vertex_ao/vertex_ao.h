// Per-vertex ambient occlusion of static meshes (module "vertex-ao"): the classic baked vertex AO,
// and the simplest module that shows the pattern every technique follows (settings with presets,
// deterministic parallel bake, a versioned .pbake chunk keyed by entity, a reader for it).
//
// A(x, n) = (1/pi) \int V(x, w) max(0, w.n) dw within max_distance (1 = open), at every vertex of
// every entity with Static + Mesh, from the vertex's position and normal in world space; and at
// every vertex of every skinned mesh (Skin + Mesh) in its bind pose, occluded by its character's
// meshes alone (scene/animation.h, character_meshes; no distance limit): the AO of a character
// that carries no pose-AO, or before its pose-AO is baked (a mesh's pose-AO, when attached,
// replaces it every frame). The values reach the renderer as VertexAO (scene/components.h).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "penumbra/core/pbake.h"
#include "penumbra/core/result.h"
#include "penumbra/lighting/settings.h"

namespace penumbra {

struct VertexAoSettings {
  // Metres; occluders farther away do not darken. 0: follows the scene's scale,
  // kVertexAoDistanceFraction of the diagonal of the static geometry's bounds (vertex_ao_distance).
  float max_distance = 0.0f;
  std::uint32_t rays = 256;   // per vertex
  static VertexAoSettings preset(Preset preset);  // draft 64, medium 256, high 1024 rays; distance 0
};

inline constexpr float kVertexAoDistanceFraction = 0.05f;
// The distance a bake uses: max_distance, or (0) kVertexAoDistanceFraction x `scene_diagonal`
// (1 m for an empty or degenerate scene). O(1).
float vertex_ao_distance(const VertexAoSettings& settings, float scene_diagonal);

// The baked data: one AO value per vertex for each baked entity.
struct VertexAoData {
  struct Entry {
    std::string key;        // the entity's stable key (scene/entity_key.h)
    std::vector<float> ao;  // one per vertex of the entity's MeshData
  };
  float max_distance = 0.0f;
  std::uint32_t rays = 0;
  std::vector<Entry> entries;

  std::uint64_t bytes() const;
};

inline constexpr std::uint32_t kVertexAoChunkType = fourcc("VXAO");
inline constexpr std::uint32_t kVertexAoChunkVersion = 2;  // 2: entries keyed by entity key

// Serialises to / reads from the "VXAO" chunk (one per bake, label "vertex-ao"). read() checks
// sizes and value ranges and names the chunk in its errors.
BakeChunk write_vertex_ao_chunk(const VertexAoData& data);
Result<VertexAoData> read_vertex_ao_chunk(const BakeChunk& chunk);

}  // namespace penumbra
