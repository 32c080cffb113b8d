// The AOFC chunk of an ambient-occlusion field (see ao_field.h).
#include <cmath>
#include <cstdio>
#include <numbers>
#include <string>

#include <glm/geometric.hpp>

#include "penumbra/ao_field/ao_field.h"
#include "penumbra/core/memory.h"
#include "penumbra/lighting/module.h"

namespace penumbra {

void write_ao_field_description(ByteWriter& w, const AOFieldData& data) {
  w.write(static_cast<std::uint32_t>(data.representation));
  w.write(data.resolution);
  w.write(data.grid_size);
  w.write(data.centre);
  w.write(data.bounding_radius);
  w.write(data.r_far);
  w.write(data.fade_start);
  w.write(data.inside_occlusion);
  w.write(data.inside_exponent);
}

Status read_ao_field_description(ByteReader& r, AOFieldData& d) {
  std::uint32_t representation = 0;
  PENUMBRA_TRY(r.read(representation));
  PENUMBRA_TRY(r.read(d.resolution));
  PENUMBRA_TRY(r.read(d.grid_size));
  PENUMBRA_TRY(r.read(d.centre));
  PENUMBRA_TRY(r.read(d.bounding_radius));
  PENUMBRA_TRY(r.read(d.r_far));
  PENUMBRA_TRY(r.read(d.fade_start));
  PENUMBRA_TRY(r.read(d.inside_occlusion));
  PENUMBRA_TRY(r.read(d.inside_exponent));
  d.representation = static_cast<AOFieldRepresentation>(representation);
  return {};
}

BakeChunk write_ao_field_chunk(const AOFieldData& data) {
  ByteWriter w;
  w.write_string(data.key);
  write_ao_field_description(w, data);
  w.write(data.clamped_fits);
  w.write_vector(data.texels);
  w.write_vector(data.nodes);
  return BakeChunk{kAOFieldChunkType, kAOFieldChunkVersion, chunk_label("ao-field", data.key), w.take()};
}

Result<AOFieldData> read_ao_field_chunk(const BakeChunk& chunk) {
  const std::string context = "chunk 'AOFC' (" + chunk.label + ")";
  const auto bad = [&](const std::string& what) {
    return make_error(ErrorCode::InvalidInput, context + ": " + what + "; re-bake the ao fields");
  };
  PENUMBRA_TRY(check_chunk(chunk, kAOFieldChunkType, kAOFieldChunkVersion, context));
  AOFieldData d;
  ByteReader r(chunk.payload, context);
  PENUMBRA_TRY(r.read_string(d.key));
  PENUMBRA_TRY(read_ao_field_description(r, d));
  PENUMBRA_TRY(r.read(d.clamped_fits));
  const auto representation = static_cast<std::uint32_t>(d.representation);
  if (representation > static_cast<std::uint32_t>(AOFieldRepresentation::Grid))
    return bad("representation " + std::to_string(representation) + " is unknown");
  const bool grid = d.representation == AOFieldRepresentation::Grid;
  if (grid ? (d.resolution != 0 || d.grid_size < 4 || d.grid_size > 128)
           : (d.resolution < 1 || d.resolution > 256 || d.grid_size != 0))
    return bad("resolution " + std::to_string(d.resolution) + " / grid_size " + std::to_string(d.grid_size) +
               " do not fit the " + to_string(d.representation) + " representation");
  const std::size_t count = 6 * std::size_t{d.resolution} * d.resolution;
  const std::size_t node_count = std::size_t{d.grid_size} * d.grid_size * d.grid_size;
  PENUMBRA_TRY(r.read_vector(d.texels, count));
  PENUMBRA_TRY(r.read_vector(d.nodes, node_count));
  PENUMBRA_TRY(r.finish());
  if (d.texels.size() != count || d.nodes.size() != node_count)
    return bad("it holds " + std::to_string(d.texels.size()) + " texels and " + std::to_string(d.nodes.size()) +
               " grid vertices, not " + std::to_string(count) + " and " + std::to_string(node_count));
  const bool finite_centre = std::isfinite(d.centre.x) && std::isfinite(d.centre.y) && std::isfinite(d.centre.z);
  // Distances in the mesh's units, within the field list's falloff range (1e6).
  if (!finite_centre || !(d.bounding_radius >= 0.0f && d.bounding_radius <= 1e6f) ||
      !(d.r_far > 0.0f && d.r_far <= 1e6f))
    return bad("the centre, bounding radius or falloff distance is not finite and positive, or above 1e6");
  if (!(d.fade_start > 0.0f && d.fade_start < 1.0f) || !(d.inside_occlusion >= 0.0f && d.inside_occlusion <= 1.0f) ||
      !(d.inside_exponent > 0.0f && std::isfinite(d.inside_exponent)))
    return bad("the fade or inside settings are out of range");
  for (std::size_t i = 0; i < count; ++i) {
    const AOFieldTexel& t = d.texels[i];
    const bool ok = std::isfinite(t.a) && std::isfinite(t.b) && std::isfinite(t.c) && t.r0 >= 0.0f &&
                    std::isfinite(t.r0) && std::isfinite(t.c0.x) && std::isfinite(t.c0.y) && std::isfinite(t.c0.z);
    if (!ok) return bad("texel " + std::to_string(i) + " has a non-finite or negative value");
  }
  constexpr float kFourPi = 4.0f * std::numbers::pi_v<float>;
  for (std::size_t i = 0; i < node_count; ++i) {
    const AOFieldGridNode& n = d.nodes[i];
    const float len = glm::length(n.weighted_direction);
    if (!(n.omega >= 0.0f && n.omega <= kFourPi) || !(len <= n.omega * 1.0001f + 1e-6f))
      return bad("grid vertex " + std::to_string(i) + " has a solid angle outside [0, 4 pi] or a direction longer "
                 "than it");
  }
  return d;
}

std::vector<std::string> describe_ao_field_chunk(const BakeChunk& chunk) {
  auto d = read_ao_field_chunk(chunk);
  if (!d) return {d.error().message};
  char line[240];
  if (d->representation == AOFieldRepresentation::Grid)
    std::snprintf(line, sizeof line, "ao field grid %u^3, falloff %.3g (bounding radius %.3g), %s", d->grid_size,
                  static_cast<double>(d->r_far), static_cast<double>(d->bounding_radius),
                  format_bytes(d->bytes()).c_str());
  else
    std::snprintf(line, sizeof line,
                  "ao field radial fit %ux%u per face, falloff %.3g (bounding radius %.3g), %s, %u clamped fits",
                  d->resolution, d->resolution, static_cast<double>(d->r_far),
                  static_cast<double>(d->bounding_radius), format_bytes(d->bytes()).c_str(), d->clamped_fits);
  return {line};
}

}  // namespace penumbra
