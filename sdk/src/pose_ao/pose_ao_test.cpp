// Pose-AO without ray tracing: the ridge solver against closed forms and on rank-deficient data,
// pose parameters, exact recovery of a linear AO, clamping, the clusters' blend weights and fit,
// the PSAO chunk, the settings' validation and the system.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>

#include <glm/gtc/packing.hpp>
#include <glm/gtc/quaternion.hpp>

#include "penumbra/core/jobs.h"
#include "penumbra/core/random.h"
#include "penumbra/ecs/transform.h"
#include "penumbra/pose_ao/pose_ao_baker.h"
#include "penumbra/pose_ao/pose_ao_system.h"
#include "ridge.h"

namespace penumbra {
namespace {

using pose_ao_detail::RidgeSolver;

TEST(PoseAORidge, MatchesTheClosedFormOfALine) {
  // y = a + b x with ridge on b only: [[n, Sx], [Sx, Sxx + lambda n]] t = [Sy, Sxy].
  const std::vector<double> x = {0.0, 1.0, 2.0, 4.0};
  const std::vector<float> y = {1.0f, 2.5f, 2.0f, 5.0f};
  std::vector<double> theta;
  for (double xi : x) theta.insert(theta.end(), {1.0, xi});
  for (double lambda : {0.0, 0.3}) {
    const RidgeSolver solver(theta, 4, 2, lambda);
    std::vector<double> t(2);
    solver.solve(y.data(), 1, t);
    double sx = 0, sxx = 0, sy = 0, sxy = 0;
    for (std::size_t i = 0; i < 4; ++i) {
      sx += x[i]; sxx += x[i] * x[i]; sy += y[i]; sxy += x[i] * y[i];
    }
    const double a11 = 4, a12 = sx, a22 = sxx + lambda * 4, det = a11 * a22 - a12 * a12;
    EXPECT_NEAR(t[0], (a22 * sy - a12 * sxy) / det, 1e-12) << lambda;
    EXPECT_NEAR(t[1], (a11 * sxy - a12 * sy) / det, 1e-12) << lambda;
    EXPECT_EQ(solver.floored_pivots(), 0u);
    if (lambda == 0.0) {  // least squares: the explained sum of squares is |Theta t|^2
      double fitted = 0.0;
      for (std::size_t i = 0; i < 4; ++i) fitted += (t[0] + t[1] * x[i]) * (t[0] + t[1] * x[i]);
      EXPECT_NEAR(solver.explained(y.data(), 1), fitted, 1e-9);
    }
  }
}

TEST(PoseAORidge, RankDeficientColumnsDoNotBlowUp) {
  // Columns: bias, x, a zero column (a joint that never moves), x again (collinear); lambda = 0.
  std::vector<double> theta;
  std::vector<float> y;
  for (int i = 0; i < 20; ++i) {
    const double x = 0.1 * i - 1.0;
    theta.insert(theta.end(), {1.0, x, 0.0, x});
    y.push_back(static_cast<float>(0.5 + 0.2 * x));
  }
  const RidgeSolver solver(theta, 20, 4, 0.0);
  std::vector<double> t(4);
  solver.solve(y.data(), 1, t);
  EXPECT_GE(solver.floored_pivots(), 1u);
  for (double c : t) EXPECT_TRUE(std::isfinite(c) && std::abs(c) < 10.0) << c;
  EXPECT_NEAR(t[0], 0.5, 1e-6);
  EXPECT_NEAR(t[1] + t[3], 0.2, 1e-6);  // the collinear pair shares the slope
  EXPECT_EQ(t[2], 0.0);                 // nothing along the zero column
}

glm::mat4 rotation(float angle, glm::vec3 axis) { return glm::mat4_cast(glm::angleAxis(angle, glm::normalize(axis))); }
// A random axis (never zero) for the synthetic poses.
glm::vec3 random_axis(Rng& rng) {
  return {rng.next_float() - 0.5f, rng.next_float() - 0.5f, rng.next_float() - 0.5f + 1e-3f};
}

TEST(PoseAOFeatures, LocalRotationRelativeToTheParent) {
  const glm::mat4 r1 = rotation(0.7f, {1, 2, 0}), r2 = rotation(-0.4f, {0, 1, 1});
  glm::mat4 child = r1 * r2;
  child[3] = glm::vec4(3.0f, -1.0f, 2.0f, 1.0f);  // translations do not matter
  const std::vector<std::int32_t> parents = {-1, 0};
  std::vector<float> f;
  pose_features(parents, std::vector<glm::mat4>{r1, child}, f);
  ASSERT_EQ(f.size(), 18u);
  for (int c = 0; c < 3; ++c)
    for (int k = 0; k < 3; ++k) {
      EXPECT_NEAR(f[3 * c + k], r1[c][k] - (c == k), 1e-6f);
      EXPECT_NEAR(f[9 + 3 * c + k], r2[c][k] - (c == k), 1e-6f);
    }
  pose_features(parents, std::vector<glm::mat4>(2, glm::mat4(1.0f)), f);
  for (float v : f) EXPECT_EQ(v, 0.0f);
}

// A two-joint rig (root, child), three vertices skinned to the child and one to the root: the fit
// sees only the child (nothing lies outside the root's subtree, so its rotation cannot matter).
struct TinyCharacter {
  PoseRig rig;
  MeshData mesh;
  TinyCharacter() {
    rig.parents = {-1, 0};
    rig.order = {0, 1};
    rig.offsets.assign(2, glm::mat4(1.0f));
    rig.inverse_bind.assign(2, glm::mat4(1.0f));
    rig.bind.assign(2, Transform{});
    rig.bind_positions = {glm::vec3(0.0f), glm::vec3(0.0f, 1.0f, 0.0f)};
    rig.animated = {true, true};
    rig.clip_ranges.assign(2, JointRange{});
    mesh.positions = {{0, 1, 0}, {1, 1, 0}, {0, 1, 1}, {0, 0, 0}};
    mesh.normals.assign(4, glm::vec3(0, 1, 0));
    mesh.joints = {glm::u16vec4(1, 0, 0, 0), glm::u16vec4(1, 0, 0, 0), glm::u16vec4(1, 0, 0, 0), glm::u16vec4(0)};
    mesh.weights.assign(4, glm::vec4(1, 0, 0, 0));
    mesh.indices = {0, 1, 2, 0, 2, 3};
  }
};

constexpr std::size_t kVertices = 4;

// AO exactly linear in the child's parameters: a_v = 0.5 + sum_e w_ve f_e.
PoseAOTraining linear_training(const TinyCharacter& c, std::size_t poses, std::uint64_t seed, std::vector<float>& weights) {
  PoseAOTraining tr;
  tr.vertex_count = kVertices;
  tr.joint_count = 2;
  tr.bind_ao.assign(kVertices, 0.5f);
  weights.resize(9 * kVertices);
  Rng w = Rng::stream(4242, 999);  // the same model for every seed
  for (float& x : weights) x = 0.04f * (w.next_float() - 0.5f);
  for (std::size_t p = 0; p < poses; ++p) {
    Rng rng = Rng::stream(seed, p);
    const glm::vec3 axis = random_axis(rng);
    const glm::mat4 r = rotation(3.0f * rng.next_float(), axis);
    std::vector<float> f;
    pose_features(c.rig.parents, std::vector<glm::mat4>{glm::mat4(1.0f), r}, f);
    tr.features.insert(tr.features.end(), f.begin(), f.end());
    for (std::size_t v = 0; v < kVertices; ++v) {
      float a = 0.5f;
      for (std::size_t e = 0; e < 9; ++e) a += weights[v * 9 + e] * f[9 + e];
      tr.ao.push_back(a);
    }
  }
  return tr;
}

TEST(PoseAOFit, RecoversAnExactlyLinearAO) {
  TinyCharacter c;
  std::vector<float> w;
  const PoseAOTraining tr = linear_training(c, 200, 7, w);
  SkinnedPoseAO s;
  s.lambda = 0.0f;
  JobContext jobs;
  auto data = fit_pose_ao(tr, c.rig, c.mesh, s, 0, jobs);
  ASSERT_TRUE(data) << data.error().message;
  ASSERT_EQ(data->groups.size(), 1u);
  EXPECT_EQ(data->groups[0].joint_count, 1u);
  EXPECT_EQ(data->groups[0].joints[0], 1u);
  EXPECT_LT(data->training_rmse, 1e-5f);
  const PoseAOGroup& g = data->groups[0];
  for (std::uint32_t i = 0; i < g.count; ++i) {
    const std::uint32_t v = data->vertex_order[g.first + i];
    // The coefficients are halves: 11 significant bits.
    EXPECT_NEAR(data->coefficient(g, 0, 0, i), 0.5f, 1e-4f);
    for (std::uint32_t e = 0; e < 9; ++e)
      EXPECT_NEAR(data->coefficient(g, 0, 1 + e, i), w[v * 9 + e], std::abs(w[v * 9 + e]) * 0x1p-11f + 1e-4f)
          << v << " " << e;
  }
  // Held-out poses: the evaluation reproduces the linear AO.
  std::vector<float> w2;
  const PoseAOTraining test = linear_training(c, 20, 7 + 1000, w2);
  ASSERT_EQ(w, w2);
  std::vector<float> ao(kVertices);
  for (std::size_t p = 0; p < test.poses(); ++p) {
    const std::span<const float> f(test.features.data() + p * 18, 18);
    evaluate_pose_ao(*data, f, ao);
    for (std::uint32_t v = 0; v < kVertices; ++v) {
      EXPECT_NEAR(ao[v], test.ao[p * kVertices + v], 1e-4f);
    }
  }
  // Poses far outside any range (features at their bounds and beyond) stay in [0, 1].
  for (float big : {-2.0f, 2.0f, 50.0f, -50.0f}) {
    std::vector<float> f(18, big);
    evaluate_pose_ao(*data, f, ao);
    for (float a : ao) EXPECT_TRUE(a >= 0.0f && a <= 1.0f) << a;
  }
}

// A root (joint 0) with two limbs, joint 1 along +x and joint 2 along -x.
PoseRig two_limb_rig() {
  PoseRig rig;
  rig.parents = {-1, 0, 0};
  rig.order = {0, 1, 2};
  rig.offsets.assign(3, glm::mat4(1.0f));
  rig.inverse_bind.assign(3, glm::mat4(1.0f));
  rig.bind.assign(3, Transform{});
  rig.bind_positions = {glm::vec3(0.0f), glm::vec3(1.0f, 0.0f, 0.0f), glm::vec3(-1.0f, 0.0f, 0.0f)};
  rig.animated = {true, true, true};
  rig.clip_ranges.assign(3, JointRange{});
  return rig;
}

// Two limbs under a root: 40 vertices on limb 1 and 5 on limb 2, each vertex's AO linear in its
// own limb's parameters. Limb 2's set is too small to run as a group of its own and no large set
// holds joint 2, so its vertices take the set pooled for their dominant joint, which keeps it:
// both limbs' AO is recovered (moved into limb 1's set they would keep only their pose average).
TEST(PoseAOFit, VerticesOfRareJointSetsKeepTheirOwnJoint) {
  const PoseRig rig = two_limb_rig();
  constexpr std::size_t kLimb1 = 40, kLimb2 = 5, V = kLimb1 + kLimb2;
  MeshData mesh;
  for (std::size_t v = 0; v < V; ++v) {
    const bool first = v < kLimb1;
    mesh.positions.push_back(glm::vec3(first ? 1.0f : -1.0f, 0.01f * float(v), 0.0f));
    mesh.joints.push_back(glm::u16vec4(first ? 1 : 2, 0, 0, 0));
  }
  mesh.normals.assign(V, glm::vec3(0, 1, 0));
  mesh.weights.assign(V, glm::vec4(1, 0, 0, 0));
  mesh.indices = {0, 1, 2, 40, 41, 42};
  std::vector<float> w(V * 9);
  Rng wr = Rng::stream(77, 1);
  for (float& x : w) x = 0.04f * (wr.next_float() - 0.5f);
  const auto training = [&](std::size_t poses, std::uint64_t seed) {
    PoseAOTraining tr;
    tr.vertex_count = V;
    tr.joint_count = 3;
    tr.bind_ao.assign(V, 0.5f);
    for (std::size_t p = 0; p < poses; ++p) {
      Rng rng = Rng::stream(seed, p);
      const auto random_turn = [&rng] {
        const float angle = 2.0f * rng.next_float() - 1.0f;
        return rotation(angle, random_axis(rng));
      };
      const glm::mat4 r1 = random_turn(), r2 = random_turn();
      std::vector<float> f;
      pose_features(rig.parents, std::vector<glm::mat4>{glm::mat4(1.0f), r1, r2}, f);
      tr.features.insert(tr.features.end(), f.begin(), f.end());
      for (std::size_t v = 0; v < V; ++v) {
        const float* limb = f.data() + (v < kLimb1 ? 9 : 18);
        float a = 0.5f;
        for (std::size_t e = 0; e < 9; ++e) a += w[v * 9 + e] * limb[e];
        tr.ao.push_back(a);
      }
    }
    return tr;
  };
  SkinnedPoseAO s;
  s.lambda = 0.0f;
  s.locality = 1;
  s.clusters = 1;
  JobContext jobs;
  auto data = fit_pose_ao(training(200, 5), rig, mesh, s, 0, jobs);
  ASSERT_TRUE(data) << data.error().message;
  for (const PoseAOGroup& g : data->groups)
    for (std::uint32_t i = 0; i < g.count; ++i) {
      ASSERT_EQ(g.joint_count, 1u);
      EXPECT_EQ(g.joints[0], data->vertex_order[g.first + i] < kLimb1 ? 1u : 2u);
    }
  const PoseAOTraining test = training(10, 500);
  std::vector<float> ao(V);
  for (std::size_t p = 0; p < test.poses(); ++p) {
    evaluate_pose_ao(*data, std::span(test.features).subspan(p * 27, 27), ao);
    for (std::size_t v = 0; v < V; ++v) EXPECT_NEAR(ao[v], test.ao[p * V + v], 1e-3f) << p << " " << v;
  }
}

TEST(PoseAOFit, FewerPosesThanCoefficientsReducesLocalityWithAWarning) {
  TinyCharacter c;
  std::vector<float> w;
  const PoseAOTraining tr = linear_training(c, 6, 3, w);  // 6 poses < 10 coefficients of one joint
  SkinnedPoseAO s;
  s.locality = 4;
  std::vector<std::string> warnings;
  JobContext jobs;
  auto data = fit_pose_ao(tr, c.rig, c.mesh, s, 0, jobs, &warnings);
  ASSERT_TRUE(data);
  EXPECT_EQ(data->locality, 0u);
  EXPECT_EQ(data->requested_locality, 4u);
  ASSERT_EQ(warnings.size(), 1u);
  EXPECT_NE(warnings[0].find("locality reduced from 4 to 0"), std::string::npos) << warnings[0];
  // Bias only: the pose average.
  for (const PoseAOGroup& g : data->groups)
    for (std::uint32_t i = 0; i < g.count; ++i) {
      const float mean = data->mean_ao[data->vertex_order[g.first + i]];
      EXPECT_NEAR(data->coefficient(g, 0, 0, i), mean, mean * 0x1p-11f + 1e-6f);
    }
  EXPECT_FALSE(fit_pose_ao(PoseAOTraining{}, c.rig, c.mesh, s, 0, jobs));
}

PoseAOData tiny_data() {
  TinyCharacter c;
  std::vector<float> w;
  const PoseAOTraining tr = linear_training(c, 60, 11, w);
  JobContext jobs;
  PoseAOData d = fit_pose_ao(tr, c.rig, c.mesh, SkinnedPoseAO{}, 0, jobs).value();
  d.key = "walker/body";
  return d;
}

TEST(PoseAOChunk, RoundTripKeepsEveryBit) {
  PoseAOData d = tiny_data();
  d.groups.front().bind_blend = 0.125f;
  d.pose_space = PoseSpaceSource::DegenerateClips;
  d.moving_joints = 1;
  d.widest_range = 1.0f;
  const BakeChunk chunk = write_pose_ao_chunk(d);
  EXPECT_EQ(chunk.label, "pose-ao:walker/body");
  auto r = read_pose_ao_chunk(chunk);
  ASSERT_TRUE(r) << r.error().message;
  EXPECT_EQ(r->key, "walker/body");
  EXPECT_EQ(r->vertex_order, d.vertex_order);
  EXPECT_EQ(r->bind_ao, d.bind_ao);
  EXPECT_EQ(r->mean_ao, d.mean_ao);
  EXPECT_EQ(r->joint_parents, d.joint_parents);
  EXPECT_EQ(r->coefficients, d.coefficients);  // halves in blocks, the padding zero both ways
  for (std::size_t k = 0; k < d.groups.size(); ++k)
    EXPECT_EQ(r->groups[k].coefficient_offset, d.groups[k].coefficient_offset);
  EXPECT_EQ(r->pose_space, PoseSpaceSource::DegenerateClips);
  EXPECT_EQ(r->moving_joints, 1u);
  EXPECT_EQ(r->widest_range, 1.0f);
  for (std::size_t g = 0; g < d.groups.size(); ++g) EXPECT_EQ(r->groups[g].bind_blend, d.groups[g].bind_blend);
  const std::vector<std::string> lines = describe_pose_ao_chunk(chunk);
  ASSERT_GE(lines.size(), 4u);
  EXPECT_NE(lines[2].find("pose space from +-default_range (the clips barely move): 1 of"), std::string::npos) << lines[2];
  EXPECT_NE(lines[3].find("warning"), std::string::npos) << lines[3];
}

// One group of bias-only vertices (no joint) whose coefficients are every half from 0 to 1, then
// -1 and 2: each vertex's AO is its half exactly (clamped for the last two), on both paths.
TEST(PoseAOEvaluate, EveryHalfInTheUnitIntervalReadsBackExactlyOnBothPaths) {
  std::vector<std::uint16_t> halves;
  for (std::uint16_t h = 0; h <= 0x3c00; ++h) halves.push_back(h);  // +0, subnormals, normals up to 1
  halves.push_back(0xbc00);  // -1
  halves.push_back(0x4000);  // 2
  const auto V = static_cast<std::uint32_t>(halves.size());
  PoseAOData d;
  d.vertex_count = V;
  PoseAOGroup g;
  g.count = V;
  d.groups = {g};
  d.coefficients.assign(g.coefficient_span(), 0xffff);  // NaN in the padding lanes: never read into the AO
  for (std::uint32_t i = 0; i < V; ++i) d.coefficients[g.coefficient_index(0, 0, i)] = halves[i];
  for (std::uint32_t i = 0; i < V; ++i) d.vertex_order.push_back(V - 1 - i);  // written through the order
  d.bind_ao.assign(V, 0.0f);
  d.mean_ao.assign(V, 0.0f);
  for (const Isa isa : {Isa::Best, Isa::Portable}) {
    std::vector<float> ao(V, -1.0f);
    evaluate_pose_ao(d, {}, ao, isa);
    for (std::uint32_t i = 0; i < V; ++i) {
      const float expected = std::clamp(glm::unpackHalf1x16(halves[i]), 0.0f, 1.0f);
      ASSERT_EQ(ao[V - 1 - i], expected)
          << "half 0x" << std::hex << halves[i] << (isa == Isa::Best ? " best" : " portable");
    }
  }
}

TEST(PoseAOFit, TheBindBlendIsExactAtTheBindPoseAndAbsentFarFromIt) {
  PoseAOData d = tiny_data();
  const std::size_t F = d.feature_count();
  std::vector<float> linear(d.vertex_count), blended(d.vertex_count);
  for (float& b : d.bind_ao) b = 0.3f;
  for (PoseAOGroup& g : d.groups) g.bind_blend = 0.0f;
  const auto at = [&](float scale, std::vector<float>& out) {
    // Features of one moving joint at `scale`: every entry of joint 1 the same value.
    std::vector<float> f(F, 0.0f);
    for (std::size_t e = 0; e < kPoseFeaturesPerJoint; ++e) f[kPoseFeaturesPerJoint + e] = scale;
    evaluate_pose_ao(d, f, out);
  };
  const auto with_blend = [&](float blend, float scale, std::vector<float>& out) {
    for (PoseAOGroup& g : d.groups) g.bind_blend = blend;
    at(scale, out);
    for (PoseAOGroup& g : d.groups) g.bind_blend = 0.0f;
  };
  // d^2 = 9 scale^2 against bind_blend 0.9: the bind pose, a quarter of the way, and beyond.
  at(0.0f, linear);
  with_blend(0.9f, 0.0f, blended);
  for (std::size_t v = 0; v < linear.size(); ++v) EXPECT_EQ(blended[v], 0.3f) << v;
  const float quarter = std::sqrt(0.9f * 0.25f / 9.0f);
  at(quarter, linear);
  with_blend(0.9f, quarter, blended);
  for (std::size_t v = 0; v < linear.size(); ++v) EXPECT_NEAR(blended[v], 0.3f + 0.25f * (linear[v] - 0.3f), 1e-5f) << v;
  at(0.4f, linear);
  with_blend(0.9f, 0.4f, blended);
  EXPECT_EQ(blended, linear);
}

TEST(PoseAOClusters, WeightsSumToOneAndAreContinuousAcrossTheBoundary) {
  // Two centres on the x axis and a third far off; the pose walks along y = 0.3 through the
  // boundary x = 0 between the first two.
  const float centers[] = {-1.0f, 0.0f, 1.0f, 0.0f, 0.0f, 10.0f};
  const float band = 0.5f;  // in squared distance: blended where |x| < band / 4
  float w[3], previous[3] = {1.0f, 0.0f, 0.0f};
  for (int step = 0; step <= 4000; ++step) {
    const float theta[] = {-2.0f + 0.001f * static_cast<float>(step), 0.3f};
    const std::uint32_t active = pose_ao_cluster_weights(centers, 3, 2, theta, band, w);
    EXPECT_NEAR(w[0] + w[1] + w[2], 1.0f, 1e-6f);
    EXPECT_EQ(w[2], 0.0f);
    EXPECT_EQ(active, (w[0] > 0.0f ? 1u : 0u) + (w[1] > 0.0f ? 1u : 0u));
    for (int m = 0; m < 3; ++m) EXPECT_LT(std::abs(w[m] - previous[m]), 0.01f) << step;  // no jump
    std::copy(w, w + 3, previous);
  }
  const float far_left[] = {-1.5f, 0.3f}, boundary[] = {0.0f, 0.3f}, inside[] = {0.1f, 0.3f}, outside[] = {0.2f, 0.3f};
  EXPECT_EQ(pose_ao_cluster_weights(centers, 3, 2, far_left, band, w), 1u);
  EXPECT_EQ(w[0], 1.0f);
  EXPECT_EQ(pose_ao_cluster_weights(centers, 3, 2, boundary, band, w), 2u);
  EXPECT_FLOAT_EQ(w[0], 0.5f);
  EXPECT_FLOAT_EQ(w[1], 0.5f);
  EXPECT_EQ(pose_ao_cluster_weights(centers, 3, 2, inside, band, w), 2u);  // gap 0.4 < 0.5
  EXPECT_GT(w[1], w[0]);
  EXPECT_EQ(pose_ao_cluster_weights(centers, 3, 2, outside, band, w), 1u);  // gap 0.8 > 0.5
  EXPECT_EQ(w[1], 1.0f);
  // Band 0: the nearest alone, the lower index on a tie.
  EXPECT_EQ(pose_ao_cluster_weights(centers, 3, 2, boundary, 0.0f, w), 1u);
  EXPECT_EQ(w[0], 1.0f);
}

TEST(PoseAOClusters, WideWeightsAgreeWithThePortableOnes) {
  // Sixteen centres in the dimensions of four to one joints (the wide loop's tails 4 to 1), poses
  // near and between them so that many blend.
  Rng rng = Rng::stream(7, 0);
  for (const std::uint32_t dims : {36u, 27u, 18u, 9u}) {
    std::vector<float> centers(16 * dims);
    for (float& c : centers) c = rng.next_float() - 0.5f;
    for (int pose = 0; pose < 200; ++pose) {
      const std::uint32_t a = rng.next_u32() % 16, b = rng.next_u32() % 16;
      const float t = rng.next_float();
      std::vector<float> theta(dims);
      for (std::uint32_t i = 0; i < dims; ++i)
        theta[i] = (1.0f - t) * centers[a * dims + i] + t * centers[b * dims + i] + 0.05f * (rng.next_float() - 0.5f);
      float portable[16], wide[16];
      pose_ao_cluster_weights(centers.data(), 16, dims, theta.data(), 0.3f, portable, Isa::Portable);
      pose_ao_cluster_weights(centers.data(), 16, dims, theta.data(), 0.3f, wide, Isa::Best);
      float sum = 0.0f;
      for (int m = 0; m < 16; ++m) {
        EXPECT_NEAR(wide[m], portable[m], 1e-5f) << dims << " " << pose << " " << m;
        sum += wide[m];
      }
      EXPECT_NEAR(sum, 1.0f, 1e-6f);
    }
  }
}

// AO with a hinge in the child's rotation: open (0.9) while the entry of its local rotation
// R[1][0] (minus the sine of a turn about z) is negative, darkening linearly beyond, as a limb
// swinging into a vertex's hemisphere does. One linear map cannot follow the kink.
PoseAOTraining hinge_training(const TinyCharacter& c, std::size_t poses, std::uint64_t seed) {
  PoseAOTraining tr;
  tr.vertex_count = kVertices;
  tr.joint_count = 2;
  tr.bind_ao.assign(kVertices, 0.9f);
  for (std::size_t p = 0; p < poses; ++p) {
    Rng rng = Rng::stream(seed, p);
    const glm::vec3 axis = random_axis(rng);
    std::vector<float> f;
    pose_features(c.rig.parents, std::vector<glm::mat4>{glm::mat4(1.0f), rotation(3.0f * rng.next_float(), axis)}, f);
    tr.features.insert(tr.features.end(), f.begin(), f.end());
    for (std::size_t v = 0; v < kVertices; ++v)
      tr.ao.push_back(std::clamp(0.9f - (0.6f + 0.1f * static_cast<float>(v)) * std::max(0.0f, f[9 + 3]), 0.0f, 1.0f));
  }
  return tr;
}

double held_out_rmse(const PoseAOData& d, const PoseAOTraining& test) {
  std::vector<float> ao(kVertices);
  double sum = 0.0;
  for (std::size_t p = 0; p < test.poses(); ++p) {
    evaluate_pose_ao(d, std::span<const float>(test.features.data() + p * 18, 18), ao);
    for (std::size_t v = 0; v < kVertices; ++v) sum += std::pow(double(ao[v]) - test.ao[p * kVertices + v], 2.0);
  }
  return std::sqrt(sum / double(test.poses() * kVertices));
}

TEST(PoseAOFit, ClustersFollowAHingeThatOneLinearMapCannot) {
  TinyCharacter c;
  const PoseAOTraining tr = hinge_training(c, 600, 5), test = hinge_training(c, 200, 5000);
  SkinnedPoseAO s;
  s.lambda = 1e-4f;
  JobContext jobs;
  s.clusters = 1;
  const PoseAOData linear = fit_pose_ao(tr, c.rig, c.mesh, s, 0, jobs).value();
  s.clusters = 8;  // 600 poses afford 8 clusters of 10 coefficients (3 poses per coefficient)
  const PoseAOData clustered = fit_pose_ao(tr, c.rig, c.mesh, s, 0, jobs).value();
  EXPECT_EQ(linear.clusters, 1u);
  EXPECT_GT(clustered.clusters, 1u);
  EXPECT_EQ(clustered.requested_clusters, 8u);
  const double e_linear = held_out_rmse(linear, test), e_clustered = held_out_rmse(clustered, test);
  EXPECT_LT(e_clustered, 0.65 * e_linear) << e_clustered << " vs " << e_linear;
  EXPECT_LT(clustered.training_rmse, linear.training_rmse);
  // Bit-identical at one and two threads, and through the chunk.
  ThreadPool pool(2);
  JobContext two(&pool);
  const PoseAOData again = fit_pose_ao(tr, c.rig, c.mesh, s, 0, two).value();
  EXPECT_EQ(write_pose_ao_chunk(again).payload, write_pose_ao_chunk(clustered).payload);
  auto stored = read_pose_ao_chunk(write_pose_ao_chunk(clustered));
  ASSERT_TRUE(stored) << stored.error().message;
  EXPECT_EQ(stored->centers, clustered.centers);
  EXPECT_EQ(stored->clusters, clustered.clusters);
  for (std::size_t g = 0; g < clustered.groups.size(); ++g) {
    EXPECT_EQ(stored->groups[g].cluster_count, clustered.groups[g].cluster_count);
    EXPECT_EQ(stored->groups[g].cluster_band, clustered.groups[g].cluster_band);
  }
  EXPECT_NEAR(held_out_rmse(*stored, test), e_clustered, 1e-3);
  // Too few poses for more than one cluster: the thesis' model, and a note that says why.
  std::vector<std::string> notes;
  const PoseAOData few = fit_pose_ao(hinge_training(c, 40, 5), c.rig, c.mesh, s, 0, jobs, &notes).value();
  EXPECT_EQ(few.clusters, 1u);
  ASSERT_EQ(notes.size(), 1u);
  EXPECT_NE(notes[0].find("allow 1 of the 8 clusters"), std::string::npos) << notes[0];
}

// The hinge of the test above on limb 1, while limb 2 turns three times as far and shades
// nothing: a vertex's set holds both limbs. Clusters in the plain parameters would split the
// poses by limb 2, whose parameters spread most; in the metric of the set's linear model
// (PoseAOGroup) limb 2 weighs nothing and the clusters follow the hinge.
TEST(PoseAOFit, ClustersSplitThePosesWhereTheAOChangesNotWhereThePosesSpread) {
  const PoseRig rig = two_limb_rig();
  MeshData mesh;
  mesh.positions = {{1, 0, 0}, {1, 1, 0}, {1, 0, 1}, {-1, 0, 0}};
  mesh.normals.assign(4, glm::vec3(0, 1, 0));
  mesh.joints = {glm::u16vec4(1, 0, 0, 0), glm::u16vec4(1, 0, 0, 0), glm::u16vec4(1, 0, 0, 0), glm::u16vec4(2, 0, 0, 0)};
  mesh.weights.assign(4, glm::vec4(1, 0, 0, 0));
  mesh.indices = {0, 1, 2, 0, 2, 3};
  const auto training = [&](std::size_t poses, std::uint64_t seed) {
    PoseAOTraining tr;
    tr.vertex_count = 4;
    tr.joint_count = 3;
    tr.bind_ao.assign(4, 0.9f);
    for (std::size_t p = 0; p < poses; ++p) {
      Rng rng = Rng::stream(seed, p);
      const glm::vec3 axis1 = random_axis(rng);
      const float angle1 = rng.next_float();
      const glm::vec3 axis2 = random_axis(rng);
      const glm::mat4 r1 = rotation(angle1, axis1), r2 = rotation(3.0f * rng.next_float(), axis2);
      std::vector<float> f;
      pose_features(rig.parents, std::vector<glm::mat4>{glm::mat4(1.0f), r1, r2}, f);
      tr.features.insert(tr.features.end(), f.begin(), f.end());
      for (std::size_t v = 0; v < 3; ++v)
        tr.ao.push_back(std::clamp(0.9f - (1.5f + 0.2f * static_cast<float>(v)) * std::max(0.0f, f[9 + 3]), 0.0f, 1.0f));
      tr.ao.push_back(0.5f);
    }
    return tr;
  };
  const PoseAOTraining tr = training(600, 8), test = training(200, 8000);
  SkinnedPoseAO s;
  s.lambda = 1e-4f;
  s.locality = 2;
  JobContext jobs;
  s.clusters = 1;
  const PoseAOData linear = fit_pose_ao(tr, rig, mesh, s, 0, jobs).value();
  s.clusters = 8;
  const PoseAOData clustered = fit_pose_ao(tr, rig, mesh, s, 0, jobs).value();
  for (const PoseAOGroup& g : clustered.groups)
    if (clustered.vertex_order[g.first] < 3) {
      EXPECT_EQ(g.joint_count, 2u);
    }
  const auto rmse = [&](const PoseAOData& d) {
    std::vector<float> ao(4);
    double sum = 0.0;
    for (std::size_t p = 0; p < test.poses(); ++p) {
      evaluate_pose_ao(d, std::span(test.features).subspan(p * 27, 27), ao);
      for (std::size_t v = 0; v < 3; ++v) sum += std::pow(double(ao[v]) - test.ao[p * 4 + v], 2.0);
    }
    return std::sqrt(sum / double(test.poses() * 3));
  };
  EXPECT_LT(rmse(clustered), 0.65 * rmse(linear)) << rmse(clustered) << " vs " << rmse(linear);
}

// On a clustered model (the hinge below), poses near and between cluster centres.
TEST(PoseAOEvaluate, TheWideAndThePortablePathsAgree) {
  TinyCharacter c;
  const PoseAOTraining tr = hinge_training(c, 600, 5), poses = hinge_training(c, 40, 77);
  SkinnedPoseAO s;
  s.lambda = 1e-4f;
  s.clusters = 8;
  JobContext jobs;
  const PoseAOData d = fit_pose_ao(tr, c.rig, c.mesh, s, 0, jobs).value();
  ASSERT_GT(d.clusters, 1u);
  const std::size_t F = d.feature_count();
  std::vector<float> best(d.vertex_count), portable(d.vertex_count);
  for (std::size_t p = 0; p < poses.poses(); ++p) {
    const std::span<const float> f(poses.features.data() + p * F, F);
    evaluate_pose_ao(d, f, best, Isa::Best);
    evaluate_pose_ao(d, f, portable, Isa::Portable);
    for (std::uint32_t v = 0; v < d.vertex_count; ++v) ASSERT_NEAR(best[v], portable[v], 2e-6f) << p << " " << v;
  }
}

TEST(PoseAOFit, AnExactlyLinearAOKeepsOneCluster) {
  // More clusters must cut the validation error; on a linear AO they cannot.
  TinyCharacter c;
  std::vector<float> w;
  SkinnedPoseAO s;
  s.lambda = 0.0f;
  JobContext jobs;
  const PoseAOData d = fit_pose_ao(linear_training(c, 600, 9, w), c.rig, c.mesh, s, 0, jobs).value();
  EXPECT_EQ(d.clusters, 1u);
}

TEST(PoseAOChunk, CorruptionIsReportedNeverMisread) {
  const BakeChunk good = write_pose_ao_chunk(tiny_data());
  const auto expect_bad = [](const BakeChunk& c, const char* why) {
    auto r = read_pose_ao_chunk(c);
    ASSERT_FALSE(r) << why;
    EXPECT_NE(r.error().message.find("PSAO"), std::string::npos) << r.error().message;
  };
  BakeChunk c = good;
  c.payload.resize(c.payload.size() - 3);
  expect_bad(c, "truncated");
  c = good;
  c.payload.push_back(std::byte{0});
  expect_bad(c, "trailing byte");
  c = good;
  c.version = 99;
  expect_bad(c, "version");
  c = good;
  const std::uint32_t zero = 0;
  std::memcpy(c.payload.data() + 4 + tiny_data().key.size(), &zero, 4);  // vertex count 0 (after the key)
  expect_bad(c, "vertex count");
  // A set count the bytes left cannot hold is refused before anything is allocated (a 157 KiB file
  // once asked for 32 GiB here).
  {
    const PoseAOData t = tiny_data();
    c = good;
    const std::size_t at = 4 + t.key.size();  // the vertex count, after the key
    const std::uint32_t many_vertices = 1u << 30;
    std::memcpy(c.payload.data() + at, &many_vertices, 4);
    const std::uint64_t many_sets = std::uint64_t{1} << 29;
    // After 8 four-byte values, the pose space (a byte, then two four-byte values), the cluster
    // counts (two four-byte values) and the joint parents (a u64 count, then one i32 per joint).
    std::memcpy(c.payload.data() + at + 32 + 9 + 8 + 8 + 4 * std::size_t{t.joint_count}, &many_sets, 8);
    auto r = read_pose_ao_chunk(c);
    ASSERT_FALSE(r);
    EXPECT_NE(r.error().message.find("joint sets do not fit"), std::string::npos) << r.error().message;
  }
  // A negative bind blend (the first set's, after its record) is refused.
  {
    const PoseAOData t = tiny_data();
    PoseAOData negative = t;
    negative.groups.front().bind_blend = -1.0f;
    auto r = read_pose_ao_chunk(write_pose_ao_chunk(negative));
    ASSERT_FALSE(r);
    EXPECT_NE(r.error().message.find("bind blend"), std::string::npos) << r.error().message;
  }
  // Clusters out of range, or a centre that is not finite, are refused.
  {
    TinyCharacter tc;
    SkinnedPoseAO s;
    JobContext jobs;
    const PoseAOData clustered = fit_pose_ao(hinge_training(tc, 600, 5), tc.rig, tc.mesh, s, 0, jobs).value();
    ASSERT_GT(clustered.clusters, 1u);
    PoseAOData bad = clustered;
    bad.clusters = kPoseAOMaxClusters + 1;
    auto r = read_pose_ao_chunk(write_pose_ao_chunk(bad));
    ASSERT_FALSE(r);
    EXPECT_NE(r.error().message.find("clusters"), std::string::npos) << r.error().message;
    bad = clustered;
    bad.centers.back() = std::nanf("");
    r = read_pose_ao_chunk(write_pose_ao_chunk(bad));
    ASSERT_FALSE(r);
    EXPECT_NE(r.error().message.find("not finite"), std::string::npos) << r.error().message;
    bad = clustered;
    bad.groups.front().cluster_band = -1.0f;
    EXPECT_FALSE(read_pose_ao_chunk(write_pose_ao_chunk(bad)));
  }
  // Every single-byte change either fails or reads back finite data of the same shape.
  for (std::size_t i = 0; i < good.payload.size(); ++i) {
    c = good;
    c.payload[i] ^= std::byte{0xFF};
    auto r = read_pose_ao_chunk(c);
    if (!r) continue;
    EXPECT_EQ(r->vertex_order.size(), r->vertex_count);
    for (std::uint16_t x : r->coefficients) EXPECT_NE(x & 0x7c00u, 0x7c00u);  // no infinite or NaN half
    for (const PoseAOGroup& g : r->groups) EXPECT_TRUE(std::isfinite(g.bind_blend) && g.bind_blend >= 0.0f);
  }
}

TEST(PoseAOSettings, ValidationNamesTheFieldAndTheFix) {
  EXPECT_TRUE(validate_pose_ao(SkinnedPoseAO::preset(Preset::Draft), 8, "c"));
  SkinnedPoseAO s;
  s.locality = 5;
  EXPECT_NE(validate_pose_ao(s, 8, "pose-AO 'x'").error().message.find("locality"), std::string::npos);
  s = {};
  s.lambda = -1.0f;
  EXPECT_NE(validate_pose_ao(s, 8, "c").error().message.find("lambda"), std::string::npos);
  s = {};
  s.rays_per_vertex = 0;
  EXPECT_FALSE(validate_pose_ao(s, 8, "c"));
  s = {};
  s.clusters = 0;
  EXPECT_NE(validate_pose_ao(s, 8, "c").error().message.find("clusters"), std::string::npos);
  s.clusters = kPoseAOMaxClusters + 1;
  EXPECT_FALSE(validate_pose_ao(s, 8, "c"));
  s = {};
  s.reference_poses = 0;
  s.clip_poses = 0;
  EXPECT_FALSE(validate_pose_ao(s, 8, "c"));
  s = {};
  s.joint_ranges.resize(3);
  EXPECT_NE(validate_pose_ao(s, 8, "c").error().message.find("joint_ranges"), std::string::npos);
  s.joint_ranges.resize(8);
  s.joint_ranges[2].min.x = 1.0f;
  EXPECT_FALSE(validate_pose_ao(s, 8, "c"));
  s.joint_ranges[2] = JointRange{};
  s.joint_ranges[5].axes = glm::quat(2.0f, 0.0f, 0.0f, 0.0f);
  EXPECT_NE(validate_pose_ao(s, 8, "c").error().message.find("joint_ranges[5].axes"), std::string::npos);
  s.joint_ranges[5].axes = glm::angleAxis(0.7f, glm::vec3(0.0f, 0.6f, 0.8f));
  EXPECT_TRUE(validate_pose_ao(s, 8, "c"));
}

TEST(PoseAOSystem, NothingWithoutTheComponentAndOnlyOnChange) {
  World world;
  const Entity plain = world.create();
  world.add<SkinPose>(plain, SkinPose{std::vector<glm::mat4>(2, glm::mat4(1.0f))});
  EXPECT_EQ(update_pose_ao(world, 0), 0u);
  EXPECT_FALSE(world.has<VertexAO>(plain));

  const Entity e = world.create();
  world.add<SkinPose>(e, SkinPose{std::vector<glm::mat4>(2, glm::mat4(1.0f))});
  SkinnedPoseAO s;
  s.data = std::make_shared<const PoseAOData>(tiny_data());
  world.add<SkinnedPoseAO>(e, s);
  EXPECT_EQ(update_pose_ao(world, 0), 1u);
  ASSERT_TRUE(world.has<VertexAO>(e));
  const std::vector<float> bind = world.get<VertexAO>(e).ao;
  ASSERT_EQ(bind.size(), kVertices);
  EXPECT_FALSE(world.has<VertexAO>(plain));
  // Unchanged pose: no work. A new pose: new values.
  const std::uint64_t since = world.tick();
  update_world_transforms(world);  // advances the tick
  EXPECT_EQ(update_pose_ao(world, since), 0u);
  world.patch<SkinPose>(e).joint_matrices[1] = rotation(1.0f, {1, 0, 0});
  EXPECT_EQ(update_pose_ao(world, since), 1u);
  EXPECT_NE(world.get<VertexAO>(e).ao, bind);
}

}  // namespace
}  // namespace penumbra
