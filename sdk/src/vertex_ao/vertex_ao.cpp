// Vertex-AO settings and data (see vertex_ao.h).
#include "penumbra/vertex_ao/vertex_ao.h"

namespace penumbra {

VertexAoSettings VertexAoSettings::preset(Preset preset) {
  VertexAoSettings s;
  s.rays = preset == Preset::Draft ? 64u : preset == Preset::Medium ? 256u : 1024u;
  return s;
}

std::uint64_t VertexAoData::bytes() const {
  std::uint64_t n = sizeof(*this);
  for (const Entry& e : entries) n += sizeof(Entry) + e.key.capacity() + e.ao.capacity() * sizeof(float);
  return n;
}

}  // namespace penumbra
