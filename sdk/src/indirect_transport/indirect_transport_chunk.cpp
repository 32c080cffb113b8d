// The WRTO chunk of indirect transport (see indirect_transport.h).
#include <cmath>
#include <span>
#include <string>

#include "penumbra/indirect_transport/indirect_transport.h"
#include "penumbra/lighting/module.h"

namespace penumbra {

namespace {

constexpr std::uint32_t kMaxLevel = 6;
constexpr std::uint32_t kMaxPatches = 1u << 20;

bool finite(glm::vec3 v) { return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z); }

}  // namespace

BakeChunk write_transport_chunk(const std::string& key, const TransportData& data) {
  ByteWriter w;
  w.write_string(key);
  w.write(data.refinement_threshold);
  w.write(data.finest_level);
  w.write(data.links);
  w.write(data.direct_nonzeros);
  w.write(data.terms);
  w.write(data.last_term_ratio);
  w.write(static_cast<std::uint8_t>(data.converged ? 1 : 0));
  w.write(static_cast<std::uint32_t>(data.patches.size()));
  for (const TransportPatch& p : data.patches) {
    w.write_string(p.key);
    w.write(p.origin);
    w.write(p.edge_u);
    w.write(p.edge_v);
    w.write(p.normal);
    w.write(p.albedo);
    w.write(p.level);
    w.write_vector(p.coverage);
  }
  w.write(data.global.size);
  w.write_vector(data.global.begin);
  w.write_vector(data.global.row);
  w.write_vector(data.global.value);
  w.write(static_cast<std::uint8_t>(data.moving_lights ? 1 : 0));
  w.write_vector(data.fixed_direct);
  w.write_vector(data.fixed_indirect);
  const TransportProbes& probes = data.probes;
  w.write(probes.origin);
  w.write(probes.spacing);
  w.write(probes.count);
  w.write(probes.rays);
  w.write_vector(probes.open);
  w.write_vector(probes.reach);
  w.write_vector(probes.begin);
  w.write_vector(probes.entries);
  w.write_vector(data.fixed_probes);
  return BakeChunk{kTransportChunkType, kTransportChunkVersion, chunk_label("indirect-transport", key), w.take()};
}

Result<TransportChunk> read_transport_chunk(const BakeChunk& chunk) {
  const std::string context = "chunk 'WRTO'";
  PENUMBRA_TRY(check_chunk(chunk, kTransportChunkType, kTransportChunkVersion, context));
  ByteReader r(chunk.payload, context);
  TransportChunk out;
  TransportData& d = out.data;
  std::uint8_t converged = 0;
  std::uint32_t count = 0;
  PENUMBRA_TRY(r.read_string(out.key));
  PENUMBRA_TRY(r.read(d.refinement_threshold));
  PENUMBRA_TRY(r.read(d.finest_level));
  PENUMBRA_TRY(r.read(d.links));
  PENUMBRA_TRY(r.read(d.direct_nonzeros));
  PENUMBRA_TRY(r.read(d.terms));
  PENUMBRA_TRY(r.read(d.last_term_ratio));
  PENUMBRA_TRY(r.read(converged));
  PENUMBRA_TRY(r.read(count));
  d.converged = converged != 0;
  const auto bad = [&](const std::string& what) {
    return make_error(ErrorCode::InvalidInput, context + " '" + out.key + "': " + what + "; re-bake");
  };
  if (count > kMaxPatches) return bad(std::to_string(count) + " patches is more than a bake makes");
  std::uint64_t first = 0;
  for (std::uint32_t i = 0; i < count; ++i) {
    TransportPatch p;
    PENUMBRA_TRY(r.read_string(p.key));
    PENUMBRA_TRY(r.read(p.origin));
    PENUMBRA_TRY(r.read(p.edge_u));
    PENUMBRA_TRY(r.read(p.edge_v));
    PENUMBRA_TRY(r.read(p.normal));
    PENUMBRA_TRY(r.read(p.albedo));
    PENUMBRA_TRY(r.read(p.level));
    const std::string where = "patch " + std::to_string(i) + " (receiver '" + p.key + "')";
    if (p.level > kMaxLevel) return bad(where + ": level " + std::to_string(p.level) + " exceeds 6");
    PENUMBRA_TRY(r.read_vector(p.coverage, p.leaves()));
    if (p.coverage.size() != p.leaves()) return bad(where + ": coverage does not have one value per leaf");
    if (!finite(p.origin) || !finite(p.edge_u) || !finite(p.edge_v) || !finite(p.normal) || !(p.area() > 0.0f))
      return bad(where + ": non-finite or zero-area rectangle");
    for (int c = 0; c < 3; ++c)
      if (!(p.albedo[c] >= 0.0f && p.albedo[c] <= 1.0f)) return bad(where + ": albedo outside [0, 1]");
    for (float f : p.coverage)
      if (!(f >= 0.0f && f <= 1.0f)) return bad(where + ": leaf coverage outside [0, 1]");
    p.first = static_cast<std::uint32_t>(first);
    first += p.leaves();
    if (first > (1u << 30)) return bad("more leaves than a bake makes");
    d.patches.push_back(std::move(p));
  }
  SparseTransport& g = d.global;
  PENUMBRA_TRY(r.read(g.size));
  if (g.size != first) return bad("operator of size " + std::to_string(g.size) + " for " + std::to_string(first) +
                                  " leaves");
  PENUMBRA_TRY(r.read_vector(g.begin, std::uint64_t{g.size} + 1));
  PENUMBRA_TRY(r.read_vector(g.row));
  PENUMBRA_TRY(r.read_vector(g.value, g.row.size()));
  std::uint8_t moving = 0;
  PENUMBRA_TRY(r.read(moving));
  if (moving > 1) return bad("the moving-lights flag is neither 0 nor 1");
  d.moving_lights = moving != 0;
  PENUMBRA_TRY(r.read_vector(d.fixed_direct, g.size));
  PENUMBRA_TRY(r.read_vector(d.fixed_indirect, g.size));
  if ((!d.fixed_direct.empty() && d.fixed_direct.size() != g.size) ||
      d.fixed_indirect.size() != d.fixed_direct.size())
    return bad("the fixed lights' lightmap does not have one value per leaf");
  // Direct light is never negative; the indirect light's Haar truncation may dip just below 0.
  for (const glm::vec3& v : d.fixed_direct)
    if (!finite(v) || v.x < 0.0f || v.y < 0.0f || v.z < 0.0f)
      return bad("the fixed lights' direct irradiance is negative or not finite");
  for (const glm::vec3& v : d.fixed_indirect)
    if (!finite(v)) return bad("the fixed lights' indirect irradiance is not finite");
  if (!d.moving_lights && !g.row.empty()) return bad("an operator is stored for a bake without moving lights");
  if (!d.moving_lights && d.fixed_direct.empty()) return bad("a bake without moving lights has no fixed ones");
  TransportProbes& probes = d.probes;
  PENUMBRA_TRY(r.read(probes.origin));
  PENUMBRA_TRY(r.read(probes.spacing));
  PENUMBRA_TRY(r.read(probes.count));
  PENUMBRA_TRY(r.read(probes.rays));
  const std::uint64_t nodes = std::uint64_t{probes.count.x} * probes.count.y * probes.count.z;
  if (nodes > kMaxBounceProbes) return bad(std::to_string(nodes) + " bounce probes is more than a bake makes");
  if (!finite(probes.origin) || !std::isfinite(probes.spacing) || !(probes.spacing >= 0.0f) ||
      (nodes > 0) != (probes.spacing > 0.0f))
    return bad("bounce probes with a non-finite origin or a spacing that does not match their count");
  PENUMBRA_TRY(r.read_vector(probes.open, nodes));
  PENUMBRA_TRY(r.read_vector(probes.reach, nodes));
  PENUMBRA_TRY(r.read_vector(probes.begin, nodes + 1));
  PENUMBRA_TRY(r.read_vector(probes.entries));
  PENUMBRA_TRY(r.read_vector(d.fixed_probes, 6 * nodes));
  PENUMBRA_TRY(r.finish());
  if (d.fixed_probes.size() != (d.fixed_direct.empty() ? 0 : 6 * nodes))
    return bad("the fixed lights' bounce probes do not have six values per probe");
  for (const glm::vec3& v : d.fixed_probes)
    if (!finite(v)) return bad("the fixed lights' bounce probes hold a non-finite irradiance");
  if (probes.open.size() != nodes || probes.reach.size() != nodes || probes.begin.size() != nodes + 1 ||
      probes.begin.front() != 0 ||
      probes.begin.back() != probes.entries.size())
    return bad("bounce probes' lists do not match their count");
  // Every probe's entries lie within the list before any is read (begin never decreases).
  for (std::size_t n = 0; n < nodes; ++n)
    if (probes.begin[n] > probes.begin[n + 1])
      return bad("bounce probe " + std::to_string(n) + "'s entries end before they begin");
  const std::uint32_t cells = d.cell_count();
  for (std::size_t n = 0; n < nodes; ++n) {
    const std::span<const BounceProbeEntry> entries(probes.entries.data() + probes.begin[n],
                                                    probes.begin[n + 1] - probes.begin[n]);
    if (!bounce_probe_in_range(probes.open[n], probes.reach[n], entries, cells))
      return bad("bounce probe " + std::to_string(n) +
                 " has a flag other than 0 or 1, a reach outside [0, 1], a cell out of range or a weight outside "
                 "[0, 4 pi]");
  }
  if (g.begin.size() != std::size_t{g.size} + 1 || g.begin.front() != 0 || g.begin.back() != g.row.size() ||
      g.value.size() != g.row.size())
    return bad("operator columns do not match its entries");
  for (std::size_t j = 0; j + 1 < g.begin.size(); ++j)
    if (g.begin[j] > g.begin[j + 1]) return bad("operator column " + std::to_string(j) + " ends before it begins");
  for (std::size_t k = 0; k < g.row.size(); ++k)
    if (g.row[k] >= g.size || !finite(g.value[k]))
      return bad("operator entry " + std::to_string(k) + " has a row out of range or a non-finite value");
  return out;
}

}  // namespace penumbra
