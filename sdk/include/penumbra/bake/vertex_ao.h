// Per-vertex ambient occlusion of static meshes: the classic baked vertex AO, and the simplest
// baker that shows the pattern every technique follows (settings with presets, deterministic
// parallel bake, a versioned .pbake chunk, a reader for it).
//
// A(x, n) = (1/pi) \int V(x, w) max(0, w.n) dw within max_distance (1 = open), at every vertex of
// every entity with Static + Mesh, from the vertex's position and normal in world space.
#pragma once

#include <cstdint>
#include <vector>

#include "penumbra/bake/baker.h"

namespace penumbra {

struct VertexAoSettings {
  float max_distance = 1.0f;  // metres; occluders farther away do not darken
  std::uint32_t rays = 256;   // per vertex
  static VertexAoSettings preset(Preset preset);  // draft 64, medium 256, high 1024 rays
};

// The baked data: one AO value per vertex for each baked entity.
struct VertexAoData {
  struct Entry {
    std::uint32_t entity_index = 0;  // Entity::index at bake time
    std::vector<float> ao;           // one per vertex of the entity's MeshData
  };
  float max_distance = 0.0f;
  std::uint32_t rays = 0;
  std::vector<Entry> entries;

  std::uint64_t bytes() const;
};

inline constexpr std::uint32_t kVertexAoChunkVersion = 1;

// Serialises to / reads from the "VXAO" chunk. read() checks sizes and value ranges and names the
// chunk in its errors.
BakeChunk write_vertex_ao_chunk(const VertexAoData& data);
Result<VertexAoData> read_vertex_ao_chunk(const BakeChunk& chunk);

// Adds the "vertex-ao" baker to world.resource<BakerRegistry>().
void register_vertex_ao(World& world);

// Gives each entity named by the VXAO chunks of `file` its values as VertexAO (scene/components.h;
// added, or replaced with World::patch), which the renderer multiplies into the ambient light.
// Fails with InvalidInput for a corrupt chunk and NotFound, naming the entity index, when the
// entity is gone or its mesh has another vertex count (re-bake the scene). Cost: O(values).
Status attach_vertex_ao(World& world, const BakeFile& file);

}  // namespace penumbra
