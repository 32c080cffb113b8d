// Skinned pose-AO (Kontkanen & Aila 2006): settings, pose parameters, the per-frame evaluation and
// the GPU layout (see pose_ao.h).
#include "penumbra/pose_ao/pose_ao.h"

#include "penumbra/core/memory.h"
#include "penumbra/pose_ao/joint_roles.h"

#include <algorithm>
#include <cmath>
#include <cstring>

#include <glm/mat3x3.hpp>

#if defined(__x86_64__)
#include <immintrin.h>
#endif

namespace penumbra {

SkinnedPoseAO SkinnedPoseAO::preset(Preset preset) {
  SkinnedPoseAO s;
  switch (preset) {
    case Preset::Draft: s.reference_poses = 100; s.rays_per_vertex = 32; s.locality = 3; s.clusters = 1; break;
    case Preset::Medium: s.reference_poses = 250; s.rays_per_vertex = 64; s.locality = 4; s.clusters = 2; break;
    case Preset::High: s.reference_poses = 1000; s.rays_per_vertex = 128; s.locality = 4; s.clusters = 8; break;
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
         bytes_of(centers) + bytes_of(bind_ao) + bytes_of(mean_ao);
}

double PoseAOData::bytes_per_vertex() const {
  if (vertex_count == 0) return 0.0;
  const double stored = 2.0 * static_cast<double>(coefficients.size()) + 4.0 * static_cast<double>(vertex_order.size()) +
                        4.0 * static_cast<double>(centers.size()) +
                        static_cast<double>(groups.size() * (kPoseAOMaxLocality * 2 + 4 * 5 + 8 * 2));
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

std::uint32_t pose_ao_cluster_weights(const float* centers, std::uint32_t clusters, std::uint32_t dims,
                                      const float* theta, float band, float* weights) {
  std::uint32_t nearest = 0;
  float least = 0.0f;
  for (std::uint32_t m = 0; m < clusters; ++m) {
    float d = 0.0f;
    const float* c = centers + std::size_t{m} * dims;
    for (std::uint32_t i = 0; i < dims; ++i) d += (theta[i] - c[i]) * (theta[i] - c[i]);
    weights[m] = d;
    if (m == 0 || d < least) {
      least = d;
      nearest = m;
    }
  }
  float sum = 0.0f;
  std::uint32_t active = 0;
  for (std::uint32_t m = 0; m < clusters; ++m) {
    float w = 0.0f;
    if (m == nearest) {
      w = 1.0f;
    } else if (band > 0.0f) {
      const float x = (weights[m] - least) / band;
      w = x < 1.0f ? 1.0f - x * x * (3.0f - 2.0f * x) : 0.0f;
    }
    weights[m] = w;
    sum += w;
    active += w > 0.0f ? 1u : 0u;
  }
  for (std::uint32_t m = 0; m < clusters; ++m) weights[m] /= sum;
  return active;
}

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

// One group: ao[order[i]] = clamp(sum_t weight[t] row[t][i], 0, 1) over `terms` coefficient rows
// (the active clusters' coefficients, each weighted by its cluster weight times its theta entry).
// A block of 16 vertices keeps its sums in four registers while the rows stream past (four 4-lane
// multiply-adds per row); then blocks of 4, then at most 3 scalar.
void evaluate_group(const float* const* row, const float* weight, std::uint32_t terms, std::size_t n,
                    const std::uint32_t* order, float* ao) {
  constexpr std::size_t kBlock = 4 * kLanes;
  std::size_t i = 0;
  for (; i + kBlock <= n; i += kBlock) {
    Lanes a0{}, a1{}, a2{}, a3{};
    for (std::uint32_t t = 0; t < terms; ++t) {
      const Lanes w = Lanes{} + weight[t];
      const float* r = row[t] + i;
      a0 += w * load(r);
      a1 += w * load(r + kLanes);
      a2 += w * load(r + 2 * kLanes);
      a3 += w * load(r + 3 * kLanes);
    }
    // Clamp in the lanes, then scatter to mesh vertex order.
    float out[kBlock];
    const Lanes sums[4] = {clamp01(a0), clamp01(a1), clamp01(a2), clamp01(a3)};
    std::memcpy(out, sums, sizeof out);
    for (std::size_t b = 0; b < kBlock; ++b) ao[order[i + b]] = out[b];
  }
  for (; i + kLanes <= n; i += kLanes) {  // the rest of the group, 4 at a time
    Lanes a{};
    for (std::uint32_t t = 0; t < terms; ++t) a += (Lanes{} + weight[t]) * load(row[t] + i);
    float out[kLanes];
    a = clamp01(a);
    std::memcpy(out, &a, sizeof out);
    for (std::size_t b = 0; b < kLanes; ++b) ao[order[i + b]] = out[b];
  }
  for (; i < n; ++i) {
    float acc = 0.0f;
    for (std::uint32_t t = 0; t < terms; ++t) acc += weight[t] * row[t][i];
    ao[order[i]] = std::clamp(acc, 0.0f, 1.0f);
  }
}

#if defined(__x86_64__)
// The same loop eight lanes wide with fused multiply-adds, for CPUs with AVX2 and FMA (chosen once
// at runtime): blocks of 32 vertices in four registers, then 8, then the 4-lane and scalar tails.
// Rounds once per multiply-add instead of twice, so it may differ from the loop above in the last
// bit.
__attribute__((target("avx2,fma"))) void evaluate_group_avx2(const float* const* row, const float* weight,
                                                             std::uint32_t terms, std::size_t n,
                                                             const std::uint32_t* order, float* ao) {
  constexpr std::size_t kWide = 8, kBlock = 4 * kWide;
  const __m256 zero = _mm256_setzero_ps(), one = _mm256_set1_ps(1.0f);
#define PENUMBRA_CLAMP01(x) _mm256_min_ps(_mm256_max_ps((x), zero), one)
  std::size_t i = 0;
  for (; i + kBlock <= n; i += kBlock) {
    __m256 a0 = zero, a1 = zero, a2 = zero, a3 = zero;
    for (std::uint32_t t = 0; t < terms; ++t) {
      const __m256 w = _mm256_set1_ps(weight[t]);
      const float* r = row[t] + i;
      a0 = _mm256_fmadd_ps(w, _mm256_loadu_ps(r), a0);
      a1 = _mm256_fmadd_ps(w, _mm256_loadu_ps(r + kWide), a1);
      a2 = _mm256_fmadd_ps(w, _mm256_loadu_ps(r + 2 * kWide), a2);
      a3 = _mm256_fmadd_ps(w, _mm256_loadu_ps(r + 3 * kWide), a3);
    }
    alignas(32) float out[kBlock];
    _mm256_store_ps(out, PENUMBRA_CLAMP01(a0));
    _mm256_store_ps(out + kWide, PENUMBRA_CLAMP01(a1));
    _mm256_store_ps(out + 2 * kWide, PENUMBRA_CLAMP01(a2));
    _mm256_store_ps(out + 3 * kWide, PENUMBRA_CLAMP01(a3));
    for (std::size_t b = 0; b < kBlock; ++b) ao[order[i + b]] = out[b];
  }
  for (; i + kWide <= n; i += kWide) {
    __m256 a = zero;
    for (std::uint32_t t = 0; t < terms; ++t) a = _mm256_fmadd_ps(_mm256_set1_ps(weight[t]), _mm256_loadu_ps(row[t] + i), a);
    alignas(32) float out[kWide];
    _mm256_store_ps(out, PENUMBRA_CLAMP01(a));
    for (std::size_t b = 0; b < kWide; ++b) ao[order[i + b]] = out[b];
  }
#undef PENUMBRA_CLAMP01
  if (i < n) {
    const float* rest[kPoseAOMaxClusters * pose_ao_coefficients(kPoseAOMaxLocality)];
    for (std::uint32_t t = 0; t < terms; ++t) rest[t] = row[t] + i;
    evaluate_group(rest, weight, terms, n - i, order + i, ao);
  }
}
#endif

// The widest loop this CPU runs.
void evaluate_group_fastest(const float* const* row, const float* weight, std::uint32_t terms, std::size_t n,
                            const std::uint32_t* order, float* ao) {
#if defined(__x86_64__)
  static const bool avx2 = __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma");
  if (avx2) return evaluate_group_avx2(row, weight, terms, n, order, ao);
#endif
  evaluate_group(row, weight, terms, n, order, ao);
}

}  // namespace

void evaluate_pose_ao(const PoseAOData& data, std::span<const float> features, std::span<float> ao) {
  constexpr std::uint32_t kMaxCoefficients = pose_ao_coefficients(kPoseAOMaxLocality);
  for (const PoseAOGroup& g : data.groups) {
    // Gather theta_local once per group: [1, f_j1 .. f_jk].
    const std::uint32_t C = g.coefficient_count();
    float theta[kMaxCoefficients];
    theta[0] = 1.0f;
    for (std::uint32_t k = 0; k < g.joint_count; ++k)
      for (std::uint32_t e = 0; e < kPoseFeaturesPerJoint; ++e)
        theta[1 + kPoseFeaturesPerJoint * k + e] = features[std::size_t{g.joints[k]} * kPoseFeaturesPerJoint + e];
    // The clusters' weights, then one term per coefficient of each blended cluster.
    float cluster_weight[kPoseAOMaxClusters] = {1.0f};
    if (g.cluster_count > 1)
      pose_ao_cluster_weights(data.centers.data() + g.center_offset, g.cluster_count, C - 1, theta + 1, g.cluster_band,
                              cluster_weight);
    const float* row[kPoseAOMaxClusters * kMaxCoefficients];
    float weight[kPoseAOMaxClusters * kMaxCoefficients];
    std::uint32_t terms = 0;
    for (std::uint32_t m = 0; m < g.cluster_count; ++m) {
      if (cluster_weight[m] == 0.0f) continue;
      const float* block = data.coefficients.data() + g.coefficient_offset + std::size_t{m} * C * g.count;
      for (std::uint32_t c = 0; c < C; ++c) {
        row[terms] = block + std::size_t{c} * g.count;
        weight[terms++] = cluster_weight[m] * theta[c];
      }
    }
    const std::uint32_t* order = data.vertex_order.data() + g.first;
    evaluate_group_fastest(row, weight, terms, g.count, order, ao.data());
    // Within bind_blend of the bind pose: towards the bind-pose AO (PoseAOGroup).
    if (g.bind_blend > 0.0f) {
      float d2 = 0.0f;
      for (std::uint32_t c = 1; c < C; ++c) d2 += theta[c] * theta[c];
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
