// The PSAO chunk of a pose-AO mesh (see pose_ao.h).
#include <cmath>
#include <cstdio>
#include <string>

#include "penumbra/core/memory.h"
#include "penumbra/lighting/module.h"
#include "penumbra/pose_ao/pose_ao.h"

namespace penumbra {

const char* to_string(PoseSpaceSource source) {
  switch (source) {
    case PoseSpaceSource::JointRanges: return "joint_ranges";
    case PoseSpaceSource::Clips: return "the clips";
    case PoseSpaceSource::Default: return "+-default_range (no clip)";
    case PoseSpaceSource::DegenerateClips: return "+-default_range (the clips barely move)";
    case PoseSpaceSource::Roles: return "the joints' roles";
    case PoseSpaceSource::DegenerateClipsRoles: return "the joints' roles (the clips barely move)";
  }
  return "?";
}

BakeChunk write_pose_ao_chunk(const PoseAOData& d) {
  ByteWriter w;
  w.write_string(d.key);
  w.write(d.vertex_count);
  w.write(d.joint_count);
  w.write(d.poses);
  w.write(d.rays_per_vertex);
  w.write(d.requested_locality);
  w.write(d.locality);
  w.write(d.lambda);
  w.write(d.training_rmse);
  w.write(static_cast<std::uint8_t>(d.pose_space));
  w.write(d.moving_joints);
  w.write(d.widest_range);
  w.write(d.requested_clusters);
  w.write(d.clusters);
  w.write_vector(d.joint_parents);
  w.write(static_cast<std::uint64_t>(d.groups.size()));
  // The chunk holds each group's halves without the blocks' padding, cluster by cluster and
  // coefficient by coefficient over the group's vertices; its offsets count those.
  std::vector<std::uint16_t> halves;
  for (const PoseAOGroup& g : d.groups) {
    w.write(g.joints);
    w.write(g.joint_count);
    w.write(g.first);
    w.write(g.count);
    w.write(static_cast<std::uint64_t>(halves.size()));
    for (std::uint32_t m = 0; m < g.cluster_count; ++m)
      for (std::uint32_t c = 0; c < g.coefficient_count(); ++c)
        for (std::uint32_t i = 0; i < g.count; ++i) halves.push_back(d.coefficients[g.coefficient_index(m, c, i)]);
    w.write(g.bind_blend);
    w.write(g.cluster_count);
    w.write(g.center_offset);
    w.write(g.cluster_band);
  }
  w.write_vector(d.vertex_order);
  w.write_vector(d.centers);
  w.write_vector(halves);
  w.write_vector(d.bind_ao);
  w.write_vector(d.mean_ao);
  return BakeChunk{kPoseAOChunkType, kPoseAOChunkVersion, chunk_label("pose-ao", d.key), w.take()};
}

Result<PoseAOData> read_pose_ao_chunk(const BakeChunk& chunk) {
  const std::string context = "chunk 'PSAO' (" + chunk.label + ")";
  const auto bad = [&](const std::string& what) {
    return make_error(ErrorCode::InvalidInput, context + ": " + what + "; re-bake the pose-AO");
  };
  PENUMBRA_TRY(check_chunk(chunk, kPoseAOChunkType, kPoseAOChunkVersion, context));
  PoseAOData d;
  ByteReader r(chunk.payload, context);
  PENUMBRA_TRY(r.read_string(d.key));
  PENUMBRA_TRY(r.read(d.vertex_count));
  PENUMBRA_TRY(r.read(d.joint_count));
  PENUMBRA_TRY(r.read(d.poses));
  PENUMBRA_TRY(r.read(d.rays_per_vertex));
  PENUMBRA_TRY(r.read(d.requested_locality));
  PENUMBRA_TRY(r.read(d.locality));
  PENUMBRA_TRY(r.read(d.lambda));
  PENUMBRA_TRY(r.read(d.training_rmse));
  std::uint8_t source = 0;
  PENUMBRA_TRY(r.read(source));
  PENUMBRA_TRY(r.read(d.moving_joints));
  PENUMBRA_TRY(r.read(d.widest_range));
  PENUMBRA_TRY(r.read(d.requested_clusters));
  PENUMBRA_TRY(r.read(d.clusters));
  const std::uint32_t V = d.vertex_count, J = d.joint_count;
  if (source > static_cast<std::uint8_t>(PoseSpaceSource::DegenerateClipsRoles))
    return bad("pose space source " + std::to_string(source) + " is unknown");
  d.pose_space = static_cast<PoseSpaceSource>(source);
  if (d.moving_joints > J || !(std::isfinite(d.widest_range) && d.widest_range >= 0.0f))
    return bad(std::to_string(d.moving_joints) + " moving joints of " + std::to_string(J) +
               " or a widest range that is negative or not finite");
  if (V == 0 || V > (1u << 30)) return bad("vertex count " + std::to_string(V) + " is outside 1..2^30");
  if (J == 0 || J > 65535) return bad("joint count " + std::to_string(J) + " is outside 1..65535");
  if (d.locality > d.requested_locality || d.requested_locality > kPoseAOMaxLocality)
    return bad("locality " + std::to_string(d.locality) + " of " + std::to_string(d.requested_locality) + " is out of range");
  if (d.clusters == 0 || d.clusters > kPoseAOMaxClusters || d.requested_clusters == 0)
    return bad(std::to_string(d.clusters) + " clusters of " + std::to_string(d.requested_clusters) +
               " asked for is out of range (1.." + std::to_string(kPoseAOMaxClusters) + ")");
  if (!(std::isfinite(d.lambda) && d.lambda >= 0.0f) || !std::isfinite(d.training_rmse))
    return bad("lambda or training RMSE is not finite");
  PENUMBRA_TRY(r.read_vector(d.joint_parents, J));
  if (d.joint_parents.size() != J) return bad("joint parents do not match " + std::to_string(J) + " joints");
  for (std::size_t j = 0; j < J; ++j)
    if (d.joint_parents[j] < -1 || d.joint_parents[j] >= static_cast<std::int32_t>(J) ||
        d.joint_parents[j] == static_cast<std::int32_t>(j))
      return bad("joint " + std::to_string(j) + " has parent " + std::to_string(d.joint_parents[j]));
  std::uint64_t groups = 0;
  PENUMBRA_TRY(r.read(groups));
  if (groups == 0 || groups > V) return bad(std::to_string(groups) + " joint sets for " + std::to_string(V) + " vertices");
  // Each set's record as written above: check the count against the bytes present before allocating.
  constexpr std::size_t kGroupBytes = sizeof(PoseAOGroup::joints) + sizeof(PoseAOGroup::joint_count) +
                                      sizeof(PoseAOGroup::first) + sizeof(PoseAOGroup::count) +
                                      sizeof(PoseAOGroup::coefficient_offset) + sizeof(PoseAOGroup::bind_blend) +
                                      sizeof(PoseAOGroup::cluster_count) + sizeof(PoseAOGroup::center_offset) +
                                      sizeof(PoseAOGroup::cluster_band);
  if (groups > r.remaining() / kGroupBytes)
    return bad(std::to_string(groups) + " joint sets do not fit in the " + std::to_string(r.remaining()) +
               " bytes left");
  d.groups.resize(static_cast<std::size_t>(groups));
  std::uint64_t vertices = 0, coefficients = 0, centers = 0;
  for (std::size_t i = 0; i < d.groups.size(); ++i) {
    PoseAOGroup& g = d.groups[i];
    PENUMBRA_TRY(r.read(g.joints));
    PENUMBRA_TRY(r.read(g.joint_count));
    PENUMBRA_TRY(r.read(g.first));
    PENUMBRA_TRY(r.read(g.count));
    PENUMBRA_TRY(r.read(g.coefficient_offset));
    PENUMBRA_TRY(r.read(g.bind_blend));
    PENUMBRA_TRY(r.read(g.cluster_count));
    PENUMBRA_TRY(r.read(g.center_offset));
    PENUMBRA_TRY(r.read(g.cluster_band));
    // Several clusters need at least one joint, the metric's scales and a centre each (PoseAOGroup).
    const bool clustered = g.cluster_count > 1;
    bool ok = g.joint_count <= d.locality && g.count >= 1 && g.first == vertices &&
              g.coefficient_offset == coefficients && std::isfinite(g.bind_blend) && g.bind_blend >= 0.0f &&
              g.cluster_count >= 1 && g.cluster_count <= d.clusters && (!clustered || g.joint_count > 0) &&
              g.center_offset == (clustered ? centers : 0) && std::isfinite(g.cluster_band) && g.cluster_band >= 0.0f;
    for (std::uint32_t k = 0; ok && k < g.joint_count; ++k)
      ok = g.joints[k] < J && (k == 0 || g.joints[k] > g.joints[k - 1]);
    if (!ok)
      return bad("joint set " + std::to_string(i) + " is malformed (joints, count, offsets, bind blend or clusters)");
    vertices += g.count;
    coefficients += std::uint64_t{g.cluster_count} * g.coefficient_count() * g.count;
    if (clustered) centers += std::uint64_t{g.cluster_count + 1} * (g.coefficient_count() - 1);
    if (vertices > V) return bad("the joint sets hold more than " + std::to_string(V) + " vertices");
  }
  if (vertices != V) return bad("the joint sets hold " + std::to_string(vertices) + " of " + std::to_string(V) + " vertices");
  PENUMBRA_TRY(r.read_vector(d.vertex_order, V));
  if (d.vertex_order.size() != V) return bad("the vertex order does not hold " + std::to_string(V) + " vertices");
  std::vector<std::uint8_t> seen(V, 0);
  for (std::uint32_t v : d.vertex_order) {
    if (v >= V || seen[v]) return bad("the vertex order is not a permutation (vertex " + std::to_string(v) + ")");
    seen[v] = 1;
  }
  PENUMBRA_TRY(r.read_vector(d.centers, centers));
  if (d.centers.size() != centers) return bad("the cluster centres do not match the joint sets");
  for (std::size_t i = 0; i < d.centers.size(); ++i)
    if (!std::isfinite(d.centers[i])) return bad("cluster centre entry " + std::to_string(i) + " is not finite");
  std::vector<std::uint16_t> halves;
  PENUMBRA_TRY(r.read_vector(halves, coefficients));
  if (halves.size() != coefficients) return bad("the coefficient count does not match the joint sets");
  for (std::size_t i = 0; i < halves.size(); ++i)
    if ((halves[i] & 0x7c00u) == 0x7c00u) return bad("coefficient " + std::to_string(i) + " is not finite");
  // Into blocks of kPoseAOBlock vertices (PoseAOGroup), the padding lanes zero.
  std::uint64_t padded = 0;
  for (PoseAOGroup& g : d.groups) {
    g.coefficient_offset = padded;
    padded += g.coefficient_span();
  }
  d.coefficients.assign(padded, 0);
  std::size_t next = 0;
  for (const PoseAOGroup& g : d.groups)
    for (std::uint32_t m = 0; m < g.cluster_count; ++m)
      for (std::uint32_t c = 0; c < g.coefficient_count(); ++c)
        for (std::uint32_t i = 0; i < g.count; ++i) d.coefficients[g.coefficient_index(m, c, i)] = halves[next++];
  PENUMBRA_TRY(r.read_vector(d.bind_ao, V));
  PENUMBRA_TRY(r.read_vector(d.mean_ao, V));
  PENUMBRA_TRY(r.finish());
  if (d.bind_ao.size() != V || d.mean_ao.size() != V) return bad("the baselines do not hold one AO per vertex");
  for (std::size_t v = 0; v < V; ++v)
    if (!(d.bind_ao[v] >= 0.0f && d.bind_ao[v] <= 1.0f && d.mean_ao[v] >= 0.0f && d.mean_ao[v] <= 1.0f))
      return bad("vertex " + std::to_string(v) + " has a baseline AO outside [0, 1]");
  return d;
}

std::vector<std::string> describe_pose_ao_chunk(const BakeChunk& chunk) {
  auto d = read_pose_ao_chunk(chunk);
  if (!d) return {d.error().message};
  char line[256];
  std::vector<std::string> out;
  std::snprintf(line, sizeof line,
                "%u vertices, %u joints, %zu joint sets, %u poses x %u rays, locality %u, lambda %.3g, %u clusters",
                d->vertex_count, d->joint_count, d->groups.size(), d->poses, d->rays_per_vertex, d->locality,
                static_cast<double>(d->lambda), d->clusters);
  out.emplace_back(line);
  std::snprintf(line, sizeof line, "training RMSE %.4f, %.1f B per vertex (16-bit coefficients), %s", 
                static_cast<double>(d->training_rmse), d->bytes_per_vertex(), format_bytes(d->bytes()).c_str());
  out.emplace_back(line);
  std::snprintf(line, sizeof line, "pose space from %s: %u of %u joints move, the widest %.3g rad",
                to_string(d->pose_space), d->moving_joints, d->joint_count, static_cast<double>(d->widest_range));
  out.emplace_back(line);
  if (degenerate_clips(d->pose_space))
    out.emplace_back(
        "warning: the clips barely move the joints; bake with the character's animations (--poses) or set joint_ranges");
  if (d->locality < d->requested_locality) {
    std::snprintf(line, sizeof line, "warning: locality reduced from %u to %u joints (too few poses); bake more poses",
                  d->requested_locality, d->locality);
    out.emplace_back(line);
  }
  return out;
}

}  // namespace penumbra
