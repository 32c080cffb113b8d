// Vertex-AO settings and data (see vertex_ao.h).
#include "penumbra/vertex_ao/vertex_ao.h"

namespace penumbra {

VertexAoSettings VertexAoSettings::preset(Preset preset) {
  VertexAoSettings s;
  s.rays = preset == Preset::Draft ? 64u : preset == Preset::Medium ? 256u : 1024u;
  return s;
}

float vertex_ao_distance(const VertexAoSettings& settings, float scene_diagonal) {
  if (settings.max_distance > 0.0f) return settings.max_distance;
  const float d = kVertexAoDistanceFraction * scene_diagonal;
  return d > 0.0f && d <= 1e6f ? d : 1.0f;  // NaN, 0 and the empty scene's -inf bounds: 1 m
}

std::uint64_t VertexAoData::bytes() const {
  std::uint64_t n = sizeof(*this);
  for (const Entry& e : entries) n += sizeof(Entry) + e.key.capacity() + e.ao.capacity() * sizeof(float);
  return n;
}

}  // namespace penumbra
