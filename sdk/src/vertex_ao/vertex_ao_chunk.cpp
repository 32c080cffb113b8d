// The VXAO chunk of vertex AO (see vertex_ao.h).
#include <string>

#include "penumbra/vertex_ao/vertex_ao.h"

namespace penumbra {

BakeChunk write_vertex_ao_chunk(const VertexAoData& data) {
  ByteWriter w;
  w.write(data.max_distance);
  w.write(data.rays);
  w.write(static_cast<std::uint32_t>(data.entries.size()));
  for (const auto& e : data.entries) {
    w.write_string(e.key);
    w.write_vector(e.ao);
  }
  return BakeChunk{kVertexAoChunkType, kVertexAoChunkVersion, "vertex-ao", w.take()};
}

Result<VertexAoData> read_vertex_ao_chunk(const BakeChunk& chunk) {
  const std::string context = "chunk 'VXAO'";
  PENUMBRA_TRY(check_chunk(chunk, kVertexAoChunkType, kVertexAoChunkVersion, context));
  VertexAoData data;
  ByteReader r(chunk.payload, context);
  std::uint32_t count = 0;
  PENUMBRA_TRY(r.read(data.max_distance));
  PENUMBRA_TRY(r.read(data.rays));
  PENUMBRA_TRY(r.read(count));
  if (!(data.max_distance > 0.0f && data.max_distance <= 1e6f) || data.rays == 0)
    return make_error(ErrorCode::InvalidInput, context + ": max distance " + std::to_string(data.max_distance) +
                                                   " m or " + std::to_string(data.rays) +
                                                   " rays per vertex is out of range; re-bake");
  for (std::uint32_t i = 0; i < count; ++i) {
    VertexAoData::Entry e;
    PENUMBRA_TRY(r.read_string(e.key));
    PENUMBRA_TRY(r.read_vector(e.ao));
    for (std::size_t v = 0; v < e.ao.size(); ++v)
      if (!(e.ao[v] >= 0.0f && e.ao[v] <= 1.0f))
        return make_error(ErrorCode::InvalidInput, context + ": entity '" + e.key + "' vertex " + std::to_string(v) +
                                                       ": AO outside [0, 1]; re-bake");
    data.entries.push_back(std::move(e));
  }
  PENUMBRA_TRY(r.finish());
  return data;
}

}  // namespace penumbra
