// The PRBG chunk of a probe grid (see probe_grid.h).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>

#include <glm/matrix.hpp>

#include "penumbra/core/memory.h"
#include "penumbra/lighting/module.h"
#include "penumbra/probe_grid/probe_grid.h"

namespace penumbra {

BakeChunk write_probe_grid_chunk(const ProbeGridData& data) {
  ByteWriter w;
  w.write_string(data.key);
  w.write(data.layout.resolution);
  w.write(data.layout.grid_to_world);
  w.write(static_cast<std::uint32_t>(data.sh_order));
  w.write(static_cast<std::uint32_t>(data.sampling));
  w.write(static_cast<std::uint32_t>(data.lighting));
  w.write(data.bounces);
  w.write(data.noise);
  w.write(data.refined_nodes);
  w.write(data.ray_factor);
  w.write_vector(data.coefficients);
  w.write_vector(data.validity);
  w.write_vector(data.filled);
  w.write_vector(data.reach);  // empty without the leak guard
  return BakeChunk{kProbeGridChunkType, kProbeGridChunkVersion, chunk_label("probe-grid", data.key), w.take()};
}

Result<ProbeGridData> read_probe_grid_chunk(const BakeChunk& chunk) {
  const std::string context = "chunk 'PRBG' (" + chunk.label + ")";
  const auto bad = [&](const std::string& what) {
    return make_error(ErrorCode::InvalidInput, context + ": " + what + "; re-bake the probe grid");
  };
  PENUMBRA_TRY(check_chunk(chunk, kProbeGridChunkType, kProbeGridChunkVersion, context));
  ProbeGridData data;
  ByteReader r(chunk.payload, context);
  std::uint32_t order = 0, sampling = 0, lighting = 0;
  PENUMBRA_TRY(r.read_string(data.key));
  PENUMBRA_TRY(r.read(data.layout.resolution));
  PENUMBRA_TRY(r.read(data.layout.grid_to_world));
  PENUMBRA_TRY(r.read(order));
  PENUMBRA_TRY(r.read(sampling));
  PENUMBRA_TRY(r.read(lighting));
  PENUMBRA_TRY(r.read(data.bounces));
  PENUMBRA_TRY(r.read(data.noise));
  PENUMBRA_TRY(r.read(data.refined_nodes));
  PENUMBRA_TRY(r.read(data.ray_factor));
  const glm::uvec3 res = data.layout.resolution;
  if (res.x < 2 || res.y < 2 || res.z < 2 || std::uint64_t{res.x} * res.y * res.z > kMaxProbeNodes)
    return bad("resolution " + std::to_string(res.x) + "x" + std::to_string(res.y) + "x" + std::to_string(res.z) +
               " is outside 2.." + std::to_string(kMaxProbeNodes) + " nodes");
  if (order != 1 && order != 2) return bad("SH order " + std::to_string(order) + " is not L1 or L2");
  if (sampling > 2) return bad("sampling mode " + std::to_string(sampling) + " is unknown");
  if (lighting > 1) return bad("lighting " + std::to_string(lighting) + " is neither all (0) nor indirect (1)");
  data.lighting = static_cast<LightingContent>(lighting);
  data.sh_order = static_cast<ProbeShOrder>(order);
  data.sampling = static_cast<ProbeSampling>(sampling);
  const glm::mat4& m = data.layout.grid_to_world;
  const glm::mat3 axes(m);
  const float det = glm::determinant(axes);
  bool finite_matrix = std::isfinite(det) && det != 0.0f;
  for (int c = 0; c < 4; ++c)
    for (int k = 0; k < 4; ++k) finite_matrix = finite_matrix && std::isfinite(m[c][k]);
  if (!finite_matrix) return bad("the grid transform is singular or not finite");
  data.layout.world_to_grid = glm::inverse(m);
  data.layout.spacing =
      glm::vec3(glm::length(axes[0]), glm::length(axes[1]), glm::length(axes[2])) / glm::vec3(res - 1u);
  const std::size_t nodes = data.node_count();
  if (!(data.noise >= 0.0f && data.noise <= 1.0f) || data.refined_nodes > nodes ||
      !(data.ray_factor >= 1.0f && data.ray_factor <= float(kProbeMaxRayFactor)))
    return bad("noise target " + std::to_string(data.noise) + ", " + std::to_string(data.refined_nodes) +
               " refined nodes or a ray factor of " + std::to_string(data.ray_factor) + " is outside 0..1, the grid's " +
               std::to_string(nodes) + " nodes or 1.." + std::to_string(kProbeMaxRayFactor));
  const std::size_t count = static_cast<std::size_t>(sh_coefficients(data.sh_order));
  PENUMBRA_TRY(r.read_vector(data.coefficients, nodes * count));
  PENUMBRA_TRY(r.read_vector(data.validity, nodes));
  PENUMBRA_TRY(r.read_vector(data.filled, nodes));
  PENUMBRA_TRY(r.read_vector(data.reach, nodes * 6));
  PENUMBRA_TRY(r.finish());
  if (data.coefficients.size() != nodes * count || data.validity.size() != nodes || data.filled.size() != nodes ||
      (!data.reach.empty() && data.reach.size() != nodes * 6))
    return bad("array sizes do not match " + std::to_string(nodes) + " nodes");
  for (std::size_t i = 0; i < data.coefficients.size(); ++i)
    for (int c = 0; c < 3; ++c)
      if (!std::isfinite(data.coefficients[i][c]))
        return bad("node " + std::to_string(i / count) + " has a non-finite coefficient");
  for (std::size_t n = 0; n < nodes; ++n)
    if (!(data.validity[n] >= 0.0f && data.validity[n] <= 1.0f) || data.filled[n] > 1)
      return bad("node " + std::to_string(n) + " has validity or fill flag out of range");
  return data;
}

std::vector<std::string> describe_probe_grid_chunk(const BakeChunk& chunk) {
  auto data = read_probe_grid_chunk(chunk);
  if (!data) return {data.error().message};
  const glm::uvec3 r = data->layout.resolution;
  const auto filled = std::count(data->filled.begin(), data->filled.end(), std::uint8_t{1});
  char line[240];
  const std::string bounces = data->bounces == kProbeAllBounces ? "all" : std::to_string(data->bounces);
  std::snprintf(line, sizeof line,
                "grid %ux%ux%u (%zu nodes), spacing %.3g x %.3g x %.3g m, %s, %s, %s lighting, %s bounces", r.x, r.y,
                r.z, data->node_count(), static_cast<double>(data->layout.spacing.x),
                static_cast<double>(data->layout.spacing.y), static_cast<double>(data->layout.spacing.z),
                to_string(data->sh_order), to_string(data->sampling), to_string(data->lighting), bounces.c_str());
  std::vector<std::string> out{line};
  std::snprintf(line, sizeof line,
                "valid %.1f%% of nodes, %ld filled from neighbours, leak guard %s, %s (%llu B per node)",
                100.0 * static_cast<double>(data->valid_fraction()), static_cast<long>(filled),
                data->reach.empty() ? "off" : "on",
                format_bytes(data->node_count() * data->bytes_per_node()).c_str(),
                static_cast<unsigned long long>(data->bytes_per_node()));
  out.emplace_back(line);
  if (data->noise > 0.0f) {
    if (data->refined_nodes > 0)
      std::snprintf(line, sizeof line, "noise target %.3g%%: %u nodes (%.1f%%) traced more rays, %.2fx the rays on average",
                    100.0 * static_cast<double>(data->noise), data->refined_nodes,
                    100.0 * double(data->refined_nodes) / double(data->node_count()),
                    static_cast<double>(data->ray_factor));
    else
      std::snprintf(line, sizeof line, "noise target %.3g%%: every node met it with its rays_per_sample",
                    100.0 * static_cast<double>(data->noise));
    out.emplace_back(line);
  }
  return out;
}

}  // namespace penumbra
