// Skinned pose-AO (Kontkanen & Aila 2006): settings, pose parameters, the per-frame evaluation and
// the GPU layout (see pose_ao.h).
#include "penumbra/pose_ao/pose_ao.h"

#include "penumbra/core/memory.h"
#include "penumbra/pose_ao/joint_roles.h"

#include <algorithm>
#include <cmath>
#include <cstring>

#include <glm/mat3x3.hpp>

namespace penumbra {

SkinnedPoseAO SkinnedPoseAO::preset(Preset preset) {
  SkinnedPoseAO s;
  switch (preset) {
    case Preset::Draft: s.reference_poses = 100; s.rays_per_vertex = 32; s.locality = 3; break;
    case Preset::Medium: s.reference_poses = 250; s.rays_per_vertex = 64; s.locality = 4; break;
    case Preset::High: s.reference_poses = 1000; s.rays_per_vertex = 128; s.locality = 4; break;
  }
  s.clip_poses = 16;
  return s;
}

Status validate_pose_ao(const SkinnedPoseAO& s, std::size_t joint_count, std::string_view context) {
  const auto bad = [&](const std::string& what) {
    return make_error(ErrorCode::InvalidArgument, std::string(context) + ": " + what);
  };
  if (std::uint64_t{s.reference_poses} + s.clip_poses == 0)
    return bad("reference_poses and clip_poses are both 0; use at least 50 reference poses (the presets use 100-1000)");
  // Each setting's range: the field list (pose_ao_fields.cpp).
  PENUMBRA_TRY(check_fields(skinned_pose_ao_info(), &s, context));
  if (auto limits = parse_joint_limits(s.joint_limits); !limits) return bad(limits.error().message);
  if (!s.joint_ranges.empty()) {
    if (s.joint_ranges.size() != joint_count)
      return bad("joint_ranges has " + std::to_string(s.joint_ranges.size()) + " entries but the skin has " +
                 std::to_string(joint_count) + " joints; give one per joint or none");
    for (std::size_t j = 0; j < joint_count; ++j) {
      const JointRange& r = s.joint_ranges[j];
      for (int a = 0; a < 3; ++a)
        if (!(std::isfinite(r.min[a]) && std::isfinite(r.max[a]) && r.min[a] <= r.max[a]))
          return bad("joint_ranges[" + std::to_string(j) + "] axis " + std::to_string(a) +
                     " is not a finite interval with min <= max");
    }
  }
  return {};
}

std::uint64_t PoseAOData::bytes() const {
  return bytes_of(joint_parents) + bytes_of(groups) + bytes_of(vertex_order) + bytes_of(coefficients) +
         bytes_of(bind_ao) + bytes_of(mean_ao);
}

double PoseAOData::bytes_per_vertex() const {
  if (vertex_count == 0) return 0.0;
  const double stored = 2.0 * static_cast<double>(coefficients.size()) + 4.0 * static_cast<double>(vertex_order.size()) +
                        static_cast<double>(groups.size() * (kPoseAOMaxLocality * 2 + 4 * 3 + 8));
  return stored / vertex_count;
}

namespace {

// The rotation of a skinning matrix: its upper 3x3 with unit columns (drops a joint's scale).
glm::mat3 rotation_of(const glm::mat4& m) {
  glm::mat3 r(m);
  for (int c = 0; c < 3; ++c) {
    const float len = glm::length(r[c]);
    r[c] = len > 0.0f ? r[c] / len : glm::vec3(0.0f);
  }
  return r;
}

}  // namespace

void pose_features(std::span<const std::int32_t> parents, std::span<const glm::mat4> joint_matrices,
                   std::vector<float>& out) {
  const std::size_t joints = joint_matrices.size();
  out.resize(joints * kPoseFeaturesPerJoint);
  for (std::size_t j = 0; j < joints; ++j) {
    const glm::mat3 r = rotation_of(joint_matrices[j]);
    const std::int32_t p = parents[j];
    const glm::mat3 local = p >= 0 && static_cast<std::size_t>(p) < joints
                                ? glm::transpose(rotation_of(joint_matrices[static_cast<std::size_t>(p)])) * r
                                : r;
    float* f = out.data() + j * kPoseFeaturesPerJoint;
    for (int c = 0; c < 3; ++c)
      for (int k = 0; k < 3; ++k) f[3 * c + k] = local[c][k] - (c == k ? 1.0f : 0.0f);
  }
}

namespace {

// Four float lanes (the GCC/Clang vector extension: one SSE register on x86-64, NEON on ARM).
typedef float Lanes __attribute__((vector_size(16)));
constexpr std::size_t kLanes = 4;
inline Lanes load(const float* p) {
  Lanes v;
  std::memcpy(&v, p, sizeof v);
  return v;
}
inline Lanes clamp01(Lanes x) {
  const Lanes zero{}, one = zero + 1.0f;
  x = x < zero ? zero : x;
  return x > one ? one : x;
}

// One group: ao[order[i]] = clamp(t_i . theta, 0, 1). Coefficient c of the group's vertices is
// contiguous, so a block of 16 vertices keeps its sums in four registers while the coefficients
// stream past (four 4-lane multiply-adds per coefficient); then blocks of 4, then at most 3 scalar.
void evaluate_group(const float* t, std::size_t n, std::uint32_t count, const float* theta,
                    const std::uint32_t* order, float* ao) {
  constexpr std::size_t kBlock = 4 * kLanes;
  std::size_t i = 0;
  for (; i + kBlock <= n; i += kBlock) {
    Lanes a0 = load(t + i), a1 = load(t + i + kLanes), a2 = load(t + i + 2 * kLanes), a3 = load(t + i + 3 * kLanes);
    for (std::uint32_t c = 1; c < count; ++c) {
      const Lanes w = Lanes{} + theta[c];
      const float* tc = t + std::size_t{c} * n + i;
      a0 += w * load(tc);
      a1 += w * load(tc + kLanes);
      a2 += w * load(tc + 2 * kLanes);
      a3 += w * load(tc + 3 * kLanes);
    }
    // Clamp in the lanes, then scatter to mesh vertex order.
    float out[kBlock];
    const Lanes sums[4] = {clamp01(a0), clamp01(a1), clamp01(a2), clamp01(a3)};
    std::memcpy(out, sums, sizeof out);
    for (std::size_t b = 0; b < kBlock; ++b) ao[order[i + b]] = out[b];
  }
  for (; i + kLanes <= n; i += kLanes) {  // the rest of the group, 4 at a time
    Lanes a = load(t + i);
    for (std::uint32_t c = 1; c < count; ++c) a += (Lanes{} + theta[c]) * load(t + std::size_t{c} * n + i);
    float out[kLanes];
    a = clamp01(a);
    std::memcpy(out, &a, sizeof out);
    for (std::size_t b = 0; b < kLanes; ++b) ao[order[i + b]] = out[b];
  }
  for (; i < n; ++i) {
    float acc = t[i];
    for (std::uint32_t c = 1; c < count; ++c) acc += theta[c] * t[std::size_t{c} * n + i];
    ao[order[i]] = std::clamp(acc, 0.0f, 1.0f);
  }
}

}  // namespace

void evaluate_pose_ao(const PoseAOData& data, std::span<const float> features, std::span<float> ao) {
  constexpr std::uint32_t kMaxCoefficients = pose_ao_coefficients(kPoseAOMaxLocality);
  for (const PoseAOGroup& g : data.groups) {
    // Gather theta_local once per group: [1, f_j1 .. f_jk].
    float theta[kMaxCoefficients];
    theta[0] = 1.0f;
    for (std::uint32_t k = 0; k < g.joint_count; ++k)
      for (std::uint32_t e = 0; e < kPoseFeaturesPerJoint; ++e)
        theta[1 + kPoseFeaturesPerJoint * k + e] = features[std::size_t{g.joints[k]} * kPoseFeaturesPerJoint + e];
    const std::uint32_t* order = data.vertex_order.data() + g.first;
    evaluate_group(data.coefficients.data() + g.coefficient_offset, g.count, g.coefficient_count(), theta, order,
                   ao.data());
    // Within bind_blend of the bind pose: towards the bind-pose AO (PoseAOGroup).
    if (g.bind_blend > 0.0f) {
      float d2 = 0.0f;
      for (std::uint32_t c = 1; c < g.coefficient_count(); ++c) d2 += theta[c] * theta[c];
      const float w = d2 / g.bind_blend;
      if (w < 1.0f)
        for (std::uint32_t i = 0; i < g.count; ++i) {
          const float bind = data.bind_ao[order[i]];
          ao[order[i]] = bind + w * (ao[order[i]] - bind);
        }
    }
  }
}

}  // namespace penumbra
