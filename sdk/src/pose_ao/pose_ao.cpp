// Skinned pose-AO (Kontkanen & Aila 2006): settings, pose parameters and the per-frame evaluation
// (see pose_ao.h).
#include "penumbra/pose_ao/pose_ao.h"

#include "penumbra/core/memory.h"
#include "penumbra/pose_ao/joint_roles.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>

#include <glm/gtc/packing.hpp>
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
      const float norm = glm::length(glm::vec4(r.axes.x, r.axes.y, r.axes.z, r.axes.w));
      if (!(std::abs(norm - 1.0f) < 1e-3f))
        return bad("joint_ranges[" + std::to_string(j) + "].axes is not a unit quaternion (length " +
                   std::to_string(norm) + "); leave it at identity for the joint's own axes");
    }
  }
  return {};
}

std::uint64_t PoseAOData::bytes() const {
  return bytes_of(joint_parents) + bytes_of(groups) + bytes_of(vertex_order) + bytes_of(coefficients) +
         bytes_of(centers) + bytes_of(bind_ao) + bytes_of(mean_ao);
}

float PoseAOData::coefficient(const PoseAOGroup& g, std::uint32_t m, std::uint32_t c, std::uint32_t i) const {
  return glm::unpackHalf1x16(coefficients[g.coefficient_index(m, c, i)]);
}

double PoseAOData::bytes_per_vertex() const {
  if (vertex_count == 0) return 0.0;
  // What the chunk stores: the coefficients without the blocks' padding.
  std::uint64_t halves = 0;
  for (const PoseAOGroup& g : groups) halves += std::uint64_t{g.cluster_count} * g.coefficient_count() * g.count;
  const double stored = 2.0 * static_cast<double>(halves) + 4.0 * static_cast<double>(vertex_order.size()) +
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

// |a - b|^2 over n entries, in order.
float squared_distance(const float* a, const float* b, std::uint32_t n) {
  float d = 0.0f;
  for (std::uint32_t i = 0; i < n; ++i) d += (a[i] - b[i]) * (a[i] - b[i]);
  return d;
}

#if defined(__x86_64__)
// The same eight lanes wide with FMA, the lanes summed at the end, the last n mod 8 entries after.
__attribute__((target("avx2,fma"))) float squared_distance_avx2(const float* a, const float* b, std::uint32_t n) {
  __m256 sum = _mm256_setzero_ps();
  std::uint32_t i = 0;
  for (; i + 8 <= n; i += 8) {
    const __m256 d = _mm256_sub_ps(_mm256_loadu_ps(a + i), _mm256_loadu_ps(b + i));
    sum = _mm256_fmadd_ps(d, d, sum);
  }
  __m128 s = _mm_add_ps(_mm256_castps256_ps128(sum), _mm256_extractf128_ps(sum, 1));
  s = _mm_add_ps(s, _mm_movehl_ps(s, s));
  s = _mm_add_ss(s, _mm_movehdup_ps(s));
  return _mm_cvtss_f32(s) + squared_distance(a + i, b + i, n - i);
}
#endif

// The widest of the two this CPU runs, or the portable one.
float squared_distance_on(Isa isa, const float* a, const float* b, std::uint32_t n) {
#if defined(__x86_64__)
  if (isa == Isa::Best && cpu_has_avx2_fma_f16c()) return squared_distance_avx2(a, b, n);
#endif
  return squared_distance(a, b, n);
}

}  // namespace

std::uint32_t pose_ao_cluster_weights(const float* centers, std::uint32_t clusters, std::uint32_t dims,
                                      const float* theta, float band, float* weights, Isa isa) {
  std::uint32_t nearest = 0;
  float least = 0.0f;
  for (std::uint32_t m = 0; m < clusters; ++m) {
    const float d = squared_distance_on(isa, theta, centers + std::size_t{m} * dims, dims);
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

// One blended cluster of a group: its run of coefficients (PoseAOGroup) and the weight of each
// coefficient row, the cluster's weight times theta_local's entry.
struct Term {
  const std::uint16_t* cluster;
  float weight[pose_ao_coefficients(kPoseAOMaxLocality)];  // the first coefficient_count() set
};

// An IEEE half as a float, exactly, for finite halves (the bake and the chunk reader hold no
// others): the half's sign, exponent and mantissa moved into a float's places make a float 2^-112
// times the half's value (a subnormal half becomes a subnormal float), and the multiply by 2^112
// is exact. Under a denormals-are-zero mode a subnormal half (below 6.1e-5) reads as 0.
inline float half_to_float(std::uint16_t h) {
  const std::uint32_t bits = (std::uint32_t{h & 0x8000u} << 16) | (std::uint32_t{h & 0x7fffu} << 13);
  return std::bit_cast<float>(bits) * 0x1p112f;
}

// One group: ao[order[i]] = clamp(sum over the terms and c of weight[c] coefficient(m, c, i), 0,
// 1), a block of kPoseAOBlock vertices at a time (its sums in 32 floats while each term's rows
// stream past), then written to mesh vertex order.
void evaluate_group(const Term* terms, std::uint32_t term_count, std::uint32_t C, std::uint32_t count,
                    const std::uint32_t* order, float* ao) {
  const std::uint32_t blocks = (count + kPoseAOBlock - 1) / kPoseAOBlock;
  const std::size_t block_halves = std::size_t{C} * kPoseAOBlock;
  for (std::uint32_t b = 0; b < blocks; ++b) {
    float sum[kPoseAOBlock] = {};
    for (std::uint32_t t = 0; t < term_count; ++t) {
      const std::uint16_t* row = terms[t].cluster + b * block_halves;
      for (std::uint32_t c = 0; c < C; ++c, row += kPoseAOBlock) {
        const float w = terms[t].weight[c];
        for (std::uint32_t l = 0; l < kPoseAOBlock; ++l) sum[l] += w * half_to_float(row[l]);
      }
    }
    const std::uint32_t first = b * kPoseAOBlock, n = std::min(kPoseAOBlock, count - first);
    for (std::uint32_t l = 0; l < n; ++l) ao[order[first + l]] = std::clamp(sum[l], 0.0f, 1.0f);
  }
}

#if defined(__x86_64__)
// Eight halves at p as floats.
__attribute__((target("avx2,fma,f16c"), always_inline)) inline __m256 load_halves(const std::uint16_t* p) {
  return _mm256_cvtph_ps(_mm_loadu_si128(reinterpret_cast<const __m128i*>(p)));
}

// The same loop eight lanes wide, for CPUs with AVX2, FMA and F16C (chosen once at runtime): a
// block's sums in four registers, each row's 32 halves converted by F16C. Rounds once per
// multiply-add instead of twice, so it may differ from the loop above in the last bit.
__attribute__((target("avx2,fma,f16c"))) void evaluate_group_avx2(const Term* terms, std::uint32_t term_count,
                                                                  std::uint32_t C, std::uint32_t count,
                                                                  const std::uint32_t* order, float* ao) {
  const std::uint32_t blocks = (count + kPoseAOBlock - 1) / kPoseAOBlock;
  const std::size_t block_halves = std::size_t{C} * kPoseAOBlock;
  const __m256 zero = _mm256_setzero_ps(), one = _mm256_set1_ps(1.0f);
  for (std::uint32_t b = 0; b < blocks; ++b) {
    __m256 a0 = zero, a1 = zero, a2 = zero, a3 = zero;
    for (std::uint32_t t = 0; t < term_count; ++t) {
      const std::uint16_t* row = terms[t].cluster + b * block_halves;
      for (std::uint32_t c = 0; c < C; ++c, row += kPoseAOBlock) {
        const __m256 w = _mm256_set1_ps(terms[t].weight[c]);
        a0 = _mm256_fmadd_ps(w, load_halves(row), a0);
        a1 = _mm256_fmadd_ps(w, load_halves(row + 8), a1);
        a2 = _mm256_fmadd_ps(w, load_halves(row + 16), a2);
        a3 = _mm256_fmadd_ps(w, load_halves(row + 24), a3);
      }
    }
    alignas(32) float out[kPoseAOBlock];
    _mm256_store_ps(out, _mm256_min_ps(_mm256_max_ps(a0, zero), one));
    _mm256_store_ps(out + 8, _mm256_min_ps(_mm256_max_ps(a1, zero), one));
    _mm256_store_ps(out + 16, _mm256_min_ps(_mm256_max_ps(a2, zero), one));
    _mm256_store_ps(out + 24, _mm256_min_ps(_mm256_max_ps(a3, zero), one));
    const std::uint32_t first = b * kPoseAOBlock, n = std::min(kPoseAOBlock, count - first);
    for (std::uint32_t l = 0; l < n; ++l) ao[order[first + l]] = out[l];
  }
}
#endif

// The widest loop this CPU runs, or the portable one.
void evaluate_group_on(Isa isa, const Term* terms, std::uint32_t term_count, std::uint32_t C, std::uint32_t count,
                       const std::uint32_t* order, float* ao) {
#if defined(__x86_64__)
  if (isa == Isa::Best && cpu_has_avx2_fma_f16c()) return evaluate_group_avx2(terms, term_count, C, count, order, ao);
#endif
  evaluate_group(terms, term_count, C, count, order, ao);
}

}  // namespace

void evaluate_pose_ao(const PoseAOData& data, std::span<const float> features, std::span<float> ao, Isa isa) {
  constexpr std::uint32_t kMaxCoefficients = pose_ao_coefficients(kPoseAOMaxLocality);
  for (const PoseAOGroup& g : data.groups) {
    // Gather theta_local once per group: [1, f_j1 .. f_jk].
    const std::uint32_t C = g.coefficient_count();
    float theta[kMaxCoefficients];
    theta[0] = 1.0f;
    for (std::uint32_t k = 0; k < g.joint_count; ++k)
      for (std::uint32_t e = 0; e < kPoseFeaturesPerJoint; ++e)
        theta[1 + kPoseFeaturesPerJoint * k + e] = features[std::size_t{g.joints[k]} * kPoseFeaturesPerJoint + e];
    // The clusters' weights, then one term per blended cluster.
    float cluster_weight[kPoseAOMaxClusters] = {1.0f};
    if (g.cluster_count > 1) {
      // theta_local in the clusters' metric: the scales precede the centres.
      const float* scales = data.centers.data() + g.center_offset;
      float scaled[kMaxCoefficients - 1];
      for (std::uint32_t c = 0; c + 1 < C; ++c) scaled[c] = theta[1 + c] * scales[c];
      pose_ao_cluster_weights(scales + (C - 1), g.cluster_count, C - 1, scaled, g.cluster_band, cluster_weight, isa);
    }
    Term terms[kPoseAOMaxClusters];
    std::uint32_t term_count = 0;
    for (std::uint32_t m = 0; m < g.cluster_count; ++m) {
      if (cluster_weight[m] == 0.0f) continue;
      Term& t = terms[term_count++];
      t.cluster = data.coefficients.data() + g.coefficient_index(m, 0, 0);
      for (std::uint32_t c = 0; c < C; ++c) t.weight[c] = cluster_weight[m] * theta[c];
    }
    const std::uint32_t* order = data.vertex_order.data() + g.first;
    evaluate_group_on(isa, terms, term_count, C, g.count, order, ao.data());
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
