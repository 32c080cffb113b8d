// Probe grid without ray tracing: validation, interpolation, evaluation, GPU packing, the chunk,
// the runtime system and the default grid.
#include "penumbra/probe_grid/probe_grid.h"
#include "penumbra/probe_grid/probe_grid_gpu.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <limits>
#include <memory>

#include <glm/geometric.hpp>
#include <glm/gtc/matrix_transform.hpp>
#include <glm/gtc/quaternion.hpp>

#include "penumbra/core/random.h"
#include "penumbra/core/sampling.h"
#include "penumbra/ecs/transform.h"
#include "penumbra/probe_grid/probe_grid_baker.h"
#include "penumbra/probe_grid/probe_grid_system.h"
#include "penumbra/scene/animation.h"
#include "penumbra/scene/builtin.h"
#include "penumbra/scene/mesh.h"

namespace penumbra {
namespace {

constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();

IrradianceProbeGrid box_grid(glm::vec3 lo, glm::vec3 hi, glm::uvec3 res) {
  IrradianceProbeGrid g;
  g.box.min = lo;
  g.box.max = hi;
  g.resolution = res;
  return g;
}

// Data whose node expansions are f(node position) (RGB, every coefficient) for a given f.
template <class F>
ProbeGridData synthetic(const IrradianceProbeGrid& grid, ProbeShOrder order, F f) {
  auto layout = probe_grid_layout(grid, glm::mat4(1.0f), "test grid");
  EXPECT_TRUE(layout.ok());
  ProbeGridData d;
  d.layout = *layout;
  d.sh_order = order;
  const int count = sh_coefficients(order);
  const glm::uvec3 r = d.layout.resolution;
  for (std::uint32_t z = 0; z < r.z; ++z)
    for (std::uint32_t y = 0; y < r.y; ++y)
      for (std::uint32_t x = 0; x < r.x; ++x)
        for (int c = 0; c < count; ++c) d.coefficients.push_back(f(d.layout.node_position({x, y, z}), c));
  d.validity.assign(d.node_count(), 1.0f);
  d.filled.assign(d.node_count(), 0);
  return d;
}

// --- Validation ----------------------------------------------------------------------------------

TEST(ProbeGridLayout, RejectsGridsWithFewerThanTwoNodesPerAxis) {
  auto one = probe_grid_layout(box_grid({0, 0, 0}, {1, 1, 1}, {1, 1, 1}), glm::mat4(1.0f), "grid 'hall'");
  ASSERT_FALSE(one.ok());
  EXPECT_EQ(one.error().code, ErrorCode::InvalidArgument);
  EXPECT_NE(one.error().message.find("grid 'hall'"), std::string::npos) << one.error().message;
  EXPECT_NE(one.error().message.find("1x1x1"), std::string::npos) << one.error().message;
  EXPECT_FALSE(probe_grid_layout(box_grid({0, 0, 0}, {1, 1, 1}, {4, 1, 4}), glm::mat4(1.0f), "g").ok());
  EXPECT_TRUE(probe_grid_layout(box_grid({0, 0, 0}, {1, 1, 1}, {2, 2, 2}), glm::mat4(1.0f), "g").ok());
}

TEST(ProbeGridLayout, RejectsDegenerateAndNonFiniteBoxes) {
  for (const auto& [lo, hi] : {std::pair{glm::vec3(0, 0, 0), glm::vec3(1, 0, 1)},     // flat
                               std::pair{glm::vec3(0, 0, 0), glm::vec3(0, 0, 0)},     // a point
                               std::pair{glm::vec3(1, 1, 1), glm::vec3(0, 2, 2)},     // inverted
                               std::pair{glm::vec3(0, kNaN, 0), glm::vec3(1, 1, 1)},  // NaN
                               std::pair{glm::vec3(0, 0, 0), glm::vec3(std::numeric_limits<float>::infinity())}}) {
    auto r = probe_grid_layout(box_grid(lo, hi, {0, 0, 0}), glm::mat4(1.0f), "g");
    ASSERT_FALSE(r.ok());
    EXPECT_EQ(r.error().code, ErrorCode::InvalidArgument);
    EXPECT_NE(r.error().message.find("box"), std::string::npos) << r.error().message;
  }
}

TEST(ProbeGridLayout, RejectsNaNAndCollapsedTransforms) {
  IrradianceProbeGrid g;  // box from the transform
  glm::mat4 m(1.0f);
  m[3][1] = kNaN;
  auto nan = probe_grid_layout(g, m, "g");
  ASSERT_FALSE(nan.ok());
  EXPECT_NE(nan.error().message.find("NaN"), std::string::npos) << nan.error().message;
  auto flat = probe_grid_layout(g, glm::scale(glm::mat4(1.0f), {2.0f, 0.0f, 2.0f}), "g");
  ASSERT_FALSE(flat.ok());
  EXPECT_NE(flat.error().message.find("degenerate"), std::string::npos) << flat.error().message;
}

TEST(ProbeGridLayout, RejectsBadSettings) {
  const auto check = [](IrradianceProbeGrid g, const char* word) {
    g.box.min = glm::vec3(0.0f);
    g.box.max = glm::vec3(4.0f);
    auto r = probe_grid_layout(g, glm::mat4(1.0f), "g");
    ASSERT_FALSE(r.ok()) << word;
    EXPECT_NE(r.error().message.find(word), std::string::npos) << r.error().message;
  };
  IrradianceProbeGrid g;
  g.spacing = kNaN;
  check(g, "spacing");
  g = {};
  g.spacing = 1e-9f;
  check(g, "spacing");
  g = {};
  g.back_face_threshold = 1.5f;
  check(g, "back_face_threshold");
  g = {};
  g.rays_per_sample = 0;
  check(g, "rays_per_sample");
  g = {};
  g.hit_samples = 1;
  check(g, "hit_samples");
  g = {};
  g.resolution = {1024, 1024, 1024};
  check(g, "exceeds the limit");
}

TEST(ProbeGridLayout, NodesSpanTheBoxAndTheTransformedUnitCube) {
  IrradianceProbeGrid metre = box_grid({-1, 0, 2}, {3, 2, 4}, {0, 0, 0});
  metre.spacing = 1.0f;
  auto a = probe_grid_layout(metre, glm::mat4(1.0f), "g");
  ASSERT_TRUE(a.ok());
  EXPECT_EQ(a->resolution, glm::uvec3(5, 3, 3));  // ceil(size / 1 m) + 1
  EXPECT_EQ(a->node_position({0, 0, 0}), glm::vec3(-1, 0, 2));
  EXPECT_EQ(a->node_position({4, 2, 2}), glm::vec3(3, 2, 4));
  EXPECT_EQ(a->spacing, glm::vec3(1.0f));
  // Unit cube through a rotated, scaled transform: the corners follow the matrix.
  IrradianceProbeGrid g;
  g.resolution = {3, 3, 3};
  const glm::mat4 m = glm::scale(glm::rotate(glm::translate(glm::mat4(1.0f), {5, 1, 0}), 0.7f, {0, 1, 0}), {4, 2, 6});
  auto b = probe_grid_layout(g, m, "g");
  ASSERT_TRUE(b.ok());
  const glm::vec3 corner = glm::vec3(m * glm::vec4(0.5f, 0.5f, 0.5f, 1.0f));
  EXPECT_LT(glm::length(b->node_position({2, 2, 2}) - corner), 1e-5f);
  EXPECT_LT(glm::length(b->spacing - glm::vec3(2, 1, 3)), 1e-5f);
}

// Spacing 0 follows the box: `cells` across its smallest side, whatever its scale, and at most
// kMaxDerivedCells along its longest.
TEST(ProbeGridLayout, DerivedSpacingFollowsTheBoxScale) {
  for (float scale : {1e-3f, 1.0f, 1e3f}) {
    IrradianceProbeGrid g = box_grid(glm::vec3(0.0f), scale * glm::vec3(4, 1, 2), {0, 0, 0});
    g.cells = 6;
    auto l = probe_grid_layout(g, glm::mat4(1.0f), "g");
    ASSERT_TRUE(l.ok()) << l.error().message;
    EXPECT_EQ(l->resolution, glm::uvec3(25, 7, 13)) << scale;
    EXPECT_NEAR(l->spacing.y, scale / 6.0f, 1e-5f * scale) << scale;
  }
  IrradianceProbeGrid flat = box_grid(glm::vec3(0.0f), glm::vec3(1000, 1, 1000), {0, 0, 0});
  auto l = probe_grid_layout(flat, glm::mat4(1.0f), "g");
  ASSERT_TRUE(l.ok()) << l.error().message;
  EXPECT_EQ(l->resolution.x, kMaxDerivedCells + 1);
  flat.cells = 0;
  auto bad = probe_grid_layout(flat, glm::mat4(1.0f), "grid 'hall'");
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(bad.error().message.find("field 'cells' = 0"), std::string::npos) << bad.error().message;
}

// Bounces from a truncation: the fewest k with rho^k <= t, so the light left out is at most t.
TEST(ProbeGridPreset, BouncesBoundTheTruncation) {
  IrradianceProbeGrid g;
  g.bounces = 2;
  EXPECT_EQ(probe_bounces(g, 0.73f), 2u);  // truncation 0: as given
  g.truncation = 0.05f;
  for (float rho : {0.1f, 0.5f, 0.73f, 0.9f}) {
    const std::uint32_t k = probe_bounces(g, rho);
    EXPECT_LE(std::pow(rho, float(k)), 0.05f + 1e-6f) << rho;
    EXPECT_GT(std::pow(rho, float(k - 1)), 0.05f) << rho;
  }
  EXPECT_EQ(probe_bounces(g, 0.73f), 10u);  // the Cornell box's white
  EXPECT_EQ(probe_bounces(g, 0.0f), 1u);
  EXPECT_EQ(probe_bounces(g, 1.0f), kMaxDerivedBounces);
  EXPECT_EQ(probe_bounces(g, std::nanf("")), 1u);
  EXPECT_EQ(probe_bounces(g, 0.9999f), kMaxDerivedBounces);
}

TEST(ProbeGridPreset, QualityGrowsWithThePreset) {
  const auto d = IrradianceProbeGrid::preset(Preset::Draft), m = IrradianceProbeGrid::preset(Preset::Medium),
             h = IrradianceProbeGrid::preset(Preset::High);
  EXPECT_LT(d.samples_per_node * d.rays_per_sample, m.samples_per_node * m.rays_per_sample);
  EXPECT_LT(m.samples_per_node * m.rays_per_sample, h.samples_per_node * h.rays_per_sample);
  EXPECT_LT(d.cells, m.cells);
  EXPECT_LT(m.cells, h.cells);
  EXPECT_GT(d.truncation, m.truncation);
  EXPECT_GT(m.truncation, h.truncation);
  EXPECT_EQ(d.sampling, ProbeSampling::Supersampled);
  EXPECT_EQ(m.sampling, ProbeSampling::Fitted);
  EXPECT_EQ(h.sampling, ProbeSampling::Fitted);
}

// --- Evaluation ----------------------------------------------------------------------------------

// Trilinear interpolation reproduces functions that are linear in each coordinate exactly.
TEST(ProbeGridEvaluate, InterpolationIsExactForTrilinearFields) {
  const auto f = [](glm::vec3 p, int c) {
    return glm::vec3(1.0f + 0.5f * p.x - 0.25f * p.y + 0.1f * p.z + 0.05f * p.x * p.y * p.z, float(c), -p.z);
  };
  const ProbeGridData d = synthetic(box_grid({-2, 0, -1}, {2, 3, 1}, {5, 4, 3}), ProbeShOrder::L2, f);
  Rng rng = Rng::stream(3, 0);
  for (int i = 0; i < 200; ++i) {
    const glm::vec3 x(-2.0f + 4.0f * rng.next_float(), 3.0f * rng.next_float(), -1.0f + 2.0f * rng.next_float());
    const SH9rgb sh = interpolate(d, x);
    for (int c = 0; c < 9; ++c) EXPECT_LT(glm::length(sh[c] - f(x, c)), 2e-5f) << "c " << c;
  }
  // Outside the box: the value at the nearest point of the box.
  EXPECT_LT(glm::length(interpolate(d, {10.0f, 1.0f, 0.0f})[0] - f({2.0f, 1.0f, 0.0f}, 0)), 2e-5f);
}

// A bright directional light rings below zero in L2 (and L1) opposite the light; evaluate never
// returns negative irradiance, and matches the expansion where it is positive.
TEST(ProbeGridEvaluate, NeverNegative) {
  const glm::vec3 l = glm::normalize(glm::vec3(0.3f, 1.0f, -0.2f));
  SH9rgb radiance;
  sh_add_sample(radiance, l, glm::vec3(1e4f, 5e3f, 1.0f));
  const SH9rgb e = sh_convolve_cosine(radiance);
  for (ProbeShOrder order : {ProbeShOrder::L1, ProbeShOrder::L2}) {
    const ProbeGridData d = synthetic(box_grid({0, 0, 0}, {1, 1, 1}, {2, 2, 2}), order,
                                      [&](glm::vec3, int c) { return e[c]; });
    bool rang = false;
    for (std::uint32_t i = 0; i < 1024; ++i) {
      const glm::vec3 n = uniform_sphere(sobol_2d(i, 7));
      const glm::vec3 raw = sh_evaluate(d.node(0), n, order == ProbeShOrder::L1 ? 2 : 3);
      const glm::vec3 v = evaluate(d, {0.5f, 0.5f, 0.5f}, n);
      for (int c = 0; c < 3; ++c) {
        rang = rang || raw[c] < 0.0f;
        EXPECT_GE(v[c], 0.0f);
        if (raw[c] > 0.0f) {
          EXPECT_NEAR(v[c], raw[c], 1e-3f * std::abs(raw[c]) + 1e-3f);
        }
      }
    }
    EXPECT_TRUE(rang) << "the test needs an expansion that rings negative";
  }
}

// --- Leak guard ----------------------------------------------------------------------------------

// A 2x2x2 grid over the unit cube whose z = 0 layer holds 1 and z = 1 layer 10 (DC only), with a
// wall at z = 0.4: the bottom nodes reach 0.4 up, the top nodes 0.6 down, everything else open.
ProbeGridData walled_cell() {
  const auto layers = [](glm::vec3 p, int c) {
    return c == 0 ? glm::vec3(p.z > 0.5f ? 10.0f : 1.0f) : glm::vec3(0.0f);
  };
  ProbeGridData d = synthetic(box_grid({0, 0, 0}, {1, 1, 1}, {2, 2, 2}), ProbeShOrder::L1, layers);
  d.reach.assign(8 * 6, 255);
  for (std::uint32_t n = 0; n < 8; ++n) {
    const bool top = n >= 4;
    d.reach[6 * n + (top ? 5 : 4)] = static_cast<std::uint8_t>(std::floor((top ? 0.6f : 0.4f) * 255.0f));
  }
  return d;
}

TEST(ProbeGridLeakGuard, CornersBehindAWallAreSkipped) {
  ProbeGridData d = walled_cell();
  for (float x : {0.1f, 0.5f, 0.9f})
    for (float y : {0.2f, 0.7f}) {
      // Each side of the wall sees only its own layer, exactly, wherever it is in the cell.
      for (float z : {0.05f, 0.2f, 0.38f}) EXPECT_FLOAT_EQ(interpolate(d, {x, y, z})[0].x, 1.0f) << z;
      for (float z : {0.42f, 0.7f, 0.95f}) EXPECT_FLOAT_EQ(interpolate(d, {x, y, z})[0].x, 10.0f) << z;
      // On the wall's faces the normal says which side the receiver is on.
      EXPECT_FLOAT_EQ(interpolate(d, {x, y, 0.4f}, {0, 0, -1})[0].x, 1.0f);
      EXPECT_FLOAT_EQ(interpolate(d, {x, y, 0.4f}, {0, 0, 1})[0].x, 10.0f);
    }
  // Without reach data, the plain trilinear blend across the wall (the leak).
  const float z = 0.3f;
  d.reach.clear();
  EXPECT_NEAR(interpolate(d, {0.5f, 0.5f, z})[0].x, 1.0f + 9.0f * z, 1e-5f);
}

// A thick solid fills the cell below z = 0.3: its nodes (z = 0) are open on every side, as a node
// inside a block is, but have samples out of the domain, and hold light extrapolated from elsewhere
// (1 against the 10 in front of the face). A receiver on the solid's face, static geometry, takes
// only the nodes in front of it, also when the face is turned from the grid's axes; a moving
// receiver there, a free-space point, or a node layer without out-of-domain samples keeps the plain
// trilinear blend.
TEST(ProbeGridLeakGuard, NodesInsideTheSolidUnderAStaticReceiverAreSkipped) {
  ProbeGridData d = walled_cell();
  d.reach.assign(8 * 6, 255);
  for (std::uint32_t n = 0; n < 4; ++n) d.validity[n] = 0.7f;  // the z = 0 layer: against a solid, mostly out
  const glm::vec3 up(0, 0, 1);
  const float blend = 1.0f + 9.0f * 0.3f;
  for (float x : {0.1f, 0.5f, 0.9f})
    for (float y : {0.2f, 0.7f}) {
      EXPECT_FLOAT_EQ(interpolate(d, {x, y, 0.3f}, up, ProbeReceiver::Static)[0].x, 10.0f) << x << " " << y;
      EXPECT_NEAR(interpolate(d, {x, y, 0.3f}, up, ProbeReceiver::Moving)[0].x, blend, 1e-5f) << "a moving receiver";
      EXPECT_NEAR(interpolate(d, {x, y, 0.3f}, glm::vec3(0.0f), ProbeReceiver::Static)[0].x, blend, 1e-5f)
          << "a point in free space";
    }
  // A face turned 10 degrees about y: both solid corners of the receiver's row lie more than
  // kProbePlaneSlack behind its plane (0.3 cos 10 -/+ 0.5 sin 10 = 0.21, 0.38 cells).
  const float tilt = glm::radians(10.0f);
  EXPECT_FLOAT_EQ(
      interpolate(d, {0.5f, 0.5f, 0.3f}, {std::sin(tilt), 0, std::cos(tilt)}, ProbeReceiver::Static)[0].x, 10.0f);
  // The rule never leaves a receiver without corners: with the wall at z = 0.4 back, the reach
  // leaves only the solid's nodes, all behind the plane, and those decide. (A static receiver's
  // test point sits kProbeStaticNormalBias above it, so this one stands 0.2 below the wall.)
  ProbeGridData walled = walled_cell();
  walled.validity = d.validity;
  EXPECT_FLOAT_EQ(interpolate(walled, {0.5f, 0.5f, 0.2f}, up, ProbeReceiver::Static)[0].x, 1.0f);
  for (std::uint32_t n = 0; n < 4; ++n) d.validity[n] = 1.0f;
  EXPECT_NEAR(interpolate(d, {0.5f, 0.5f, 0.3f}, up, ProbeReceiver::Static)[0].x, blend, 1e-5f)
      << "nodes in free space behind a receiver still count";
}

TEST(ProbeGridLeakGuard, NodesInsideASolidAreSkippedForEveryReceiver) {
  ProbeGridData d = walled_cell();
  d.reach.assign(8 * 6, 255);
  // The z = 0 layer's tents lie mostly in a solid (validity under kProbeSolidValidity): their
  // values are extrapolations, and no receiver reads them while a node outside remains.
  for (std::uint32_t n = 0; n < 4; ++n) d.validity[n] = 0.3f;
  const glm::vec3 up(0, 0, 1);
  for (float x : {0.1f, 0.5f, 0.9f})
    for (float z : {0.1f, 0.3f, 0.8f}) {
      EXPECT_FLOAT_EQ(interpolate(d, {x, 0.6f, z}, up, ProbeReceiver::Static)[0].x, 10.0f) << x << " " << z;
      EXPECT_FLOAT_EQ(interpolate(d, {x, 0.6f, z}, up, ProbeReceiver::Moving)[0].x, 10.0f) << "a moving receiver";
      EXPECT_FLOAT_EQ(interpolate(d, {x, 0.6f, z})[0].x, 10.0f) << "a point in free space";
    }
  // A node just at the threshold counts; a cell with every node inside interpolates them all.
  for (std::uint32_t n = 0; n < 4; ++n) d.validity[n] = kProbeSolidValidity;
  EXPECT_NEAR(interpolate(d, {0.5f, 0.5f, 0.3f})[0].x, 1.0f + 9.0f * 0.3f, 1e-5f);
  d.validity.assign(8, 0.2f);
  EXPECT_NEAR(interpolate(d, {0.5f, 0.5f, 0.3f})[0].x, 1.0f + 9.0f * 0.3f, 1e-5f);
}

TEST(ProbeGridLeakGuard, OpenCellsAndFullyHiddenCellsInterpolateAsPlainTrilinear) {
  ProbeGridData d = walled_cell();
  ProbeGridData plain = d;
  plain.reach.clear();
  Rng rng = Rng::stream(11, 0);
  for (std::uint8_t r : {std::uint8_t{255}, std::uint8_t{0}}) {  // nothing hidden; every corner hidden
    d.reach.assign(8 * 6, r);
    for (int i = 0; i < 100; ++i) {
      const glm::vec3 x(rng.next_float(), rng.next_float(), 0.05f + 0.9f * rng.next_float());
      const glm::vec3 n = uniform_sphere({rng.next_float(), rng.next_float()});
      EXPECT_NEAR(interpolate(d, x, n)[0].x, interpolate(plain, x)[0].x, 1e-5f) << int(r);
    }
  }
  // A NaN normal tests from the point itself; a NaN point gives zero, as without the guard.
  d = walled_cell();
  EXPECT_FLOAT_EQ(interpolate(d, {0.5f, 0.5f, 0.2f}, {kNaN, 0, 0})[0].x, 1.0f);
  EXPECT_EQ(interpolate(d, {kNaN, 0.5f, 0.5f})[0], glm::vec3(0.0f));
}

TEST(ProbeGridLeakGuard, NodeTexelsCarryValidityAndReachExactly) {
  ProbeGridData d = walled_cell();
  d.validity = {0.0f, 0.125f, 0.25f, 0.5f, 0.75f, 1.0f, 1.0f, 1.0f};
  for (std::size_t i = 0; i < d.reach.size(); ++i) d.reach[i] = static_cast<std::uint8_t>(41 * i + 3);
  const std::vector<glm::vec4> t = pack_probe_node_texels(d);
  ASSERT_EQ(t.size(), 8u);
  for (std::size_t n = 0; n < 8; ++n) {
    EXPECT_EQ(t[n].r, d.validity[n]);
    // The shader's unpacking (forward.frag): g = +x, -x, +y; b = -y, +z, -z.
    const auto g = static_cast<std::uint32_t>(t[n].g), b = static_cast<std::uint32_t>(t[n].b);
    const std::uint8_t* r = &d.reach[6 * n];
    EXPECT_EQ(g & 255u, r[0]);
    EXPECT_EQ((g >> 8) & 255u, r[1]);
    EXPECT_EQ(g >> 16, r[2]);
    EXPECT_EQ(b & 255u, r[3]);
    EXPECT_EQ((b >> 8) & 255u, r[4]);
    EXPECT_EQ(b >> 16, r[5]);
    EXPECT_EQ(t[n].a, 0.0f);
  }
  d.reach.clear();
  for (const glm::vec4& texel : pack_probe_node_texels(d)) EXPECT_EQ(texel.g + texel.b, 0.0f);
  EXPECT_EQ(d.bytes_per_node(), 4u * 12u);
}

// --- GPU layout ----------------------------------------------------------------------------------

TEST(ProbeGridTextures, SlotsHoldCoefficientChannelsAndFilterLikeTheCpu) {
  const auto f = [](glm::vec3 p, int c) { return glm::vec3(p.x + float(c), p.y * float(c), 0.25f * p.z - 1.0f); };
  for (ProbeShOrder order : {ProbeShOrder::L1, ProbeShOrder::L2}) {
    const ProbeGridData d = synthetic(box_grid({0, 0, 0}, {3, 2, 1}, {4, 3, 2}), order, f);
    const ProbeGridTextures t = pack_probe_grid_textures(d);
    const std::size_t count = static_cast<std::size_t>(sh_coefficients(order));
    EXPECT_EQ(t.textures, order == ProbeShOrder::L1 ? 3u : 7u);
    ASSERT_EQ(t.data.size(), t.textures * d.node_count() * 16);
    const auto slot = [&](std::size_t node, std::size_t s) {
      float v;
      std::memcpy(&v, t.data.data() + ((s / 4) * d.node_count() + node) * 16 + (s % 4) * 4, sizeof v);
      return v;
    };
    for (std::size_t n = 0; n < d.node_count(); ++n)
      for (std::size_t s = 0; s < 4 * t.textures; ++s)
        EXPECT_EQ(slot(n, s), s < 3 * count ? d.coefficients[n * count + s / 3][static_cast<int>(s % 3)] : 0.0f);
    // A software trilinear fetch at the shader's uvw gives interpolate()'s coefficients.
    const glm::vec3 x(1.3f, 0.7f, 0.4f);
    const glm::vec3 u = glm::vec3(t.world_to_grid * glm::vec4(x, 1.0f)) * glm::vec3(t.extent - 1u);
    const glm::uvec3 b(u);
    const glm::vec3 fr = u - glm::vec3(b);
    const SH9rgb ref = interpolate(d, x);
    for (std::size_t s = 0; s < 3 * count; ++s) {
      float v = 0.0f;
      for (std::uint32_t k = 0; k < 8; ++k) {
        const glm::uvec3 o(k & 1u, (k >> 1) & 1u, (k >> 2) & 1u);
        const float w = (o.x ? fr.x : 1 - fr.x) * (o.y ? fr.y : 1 - fr.y) * (o.z ? fr.z : 1 - fr.z);
        v += w * slot(d.layout.node_index(b + o), s);
      }
      EXPECT_NEAR(v, ref[static_cast<int>(s / 3)][static_cast<int>(s % 3)], 1e-5f);
    }
  }
}

// --- Chunk ---------------------------------------------------------------------------------------

TEST(ProbeGridChunk, RoundTripsAndRejectsDamage) {
  ProbeGridData d = synthetic(box_grid({0, 0, 0}, {2, 1, 1}, {3, 2, 2}), ProbeShOrder::L1,
                              [](glm::vec3 p, int c) { return p * float(c + 1); });
  d.key = "level/probe grid";
  d.validity[3] = 0.0f;
  d.filled[3] = 1;
  const BakeChunk chunk = write_probe_grid_chunk(d);
  EXPECT_EQ(chunk.label, "probe-grid:level/probe grid");
  auto back = read_probe_grid_chunk(chunk);
  ASSERT_TRUE(back.ok()) << back.error().message;
  EXPECT_EQ(back->coefficients, d.coefficients);
  EXPECT_EQ(back->validity, d.validity);
  EXPECT_EQ(back->filled, d.filled);
  EXPECT_EQ(back->layout.resolution, d.layout.resolution);
  EXPECT_EQ(back->key, "level/probe grid");
  EXPECT_EQ(back->sh_order, ProbeShOrder::L1);
  const auto lines = describe_probe_grid_chunk(chunk);
  ASSERT_EQ(lines.size(), 2u);
  EXPECT_NE(lines[0].find("3x2x2"), std::string::npos) << lines[0];
  EXPECT_NE(lines[1].find("valid 91.7%"), std::string::npos) << lines[1];

  BakeChunk truncated = chunk;
  truncated.payload.resize(truncated.payload.size() - 5);
  EXPECT_FALSE(read_probe_grid_chunk(truncated).ok());
  BakeChunk versioned = chunk;
  versioned.version = 99;
  auto v = read_probe_grid_chunk(versioned);
  ASSERT_FALSE(v.ok());
  EXPECT_EQ(v.error().code, ErrorCode::Unsupported);
  ProbeGridData nan = d;
  nan.coefficients[4].y = kNaN;
  auto n = read_probe_grid_chunk(write_probe_grid_chunk(nan));
  ASSERT_FALSE(n.ok());
  EXPECT_NE(n.error().message.find("node 1"), std::string::npos) << n.error().message;
  ProbeGridData one = d;
  one.layout.resolution = {1, 1, 1};
  EXPECT_FALSE(read_probe_grid_chunk(write_probe_grid_chunk(one)).ok());

  // Every sampling mode round-trips and is named by describe; an unknown one is rejected.
  for (ProbeSampling mode : {ProbeSampling::Point, ProbeSampling::Supersampled, ProbeSampling::Fitted}) {
    ProbeGridData m = d;
    m.sampling = mode;
    const BakeChunk c = write_probe_grid_chunk(m);
    auto r = read_probe_grid_chunk(c);
    ASSERT_TRUE(r.ok()) << r.error().message;
    EXPECT_EQ(r->sampling, mode);
    EXPECT_NE(describe_probe_grid_chunk(c)[0].find(to_string(mode)), std::string::npos) << to_string(mode);
  }
  ProbeGridData unknown = d;
  unknown.sampling = static_cast<ProbeSampling>(3);
  auto u = read_probe_grid_chunk(write_probe_grid_chunk(unknown));
  ASSERT_FALSE(u.ok());
  EXPECT_NE(u.error().message.find("sampling mode 3"), std::string::npos) << u.error().message;
}

// --- System --------------------------------------------------------------------------------------

// Grids with constant expansions (irradiance `value` for every normal: only coefficient 0).
Entity add_constant_grid(World& w, glm::vec3 lo, glm::vec3 hi, glm::vec3 value, int priority) {
  IrradianceProbeGrid g = box_grid(lo, hi, {3, 3, 3});
  g.priority = priority;
  g.data = std::make_shared<const ProbeGridData>(synthetic(g, ProbeShOrder::L1, [&](glm::vec3, int c) {
    return c == 0 ? value / 0.28209479f : glm::vec3(0.0f);
  }));
  const Entity e = w.create();
  w.add<IrradianceProbeGrid>(e, g);
  w.add<Transform>(e);
  return e;
}

Entity add_receiver(World& w, glm::vec3 at) {
  const Entity e = w.create();
  w.add<Transform>(e, Transform{at});
  w.add<ProbeLit>(e);
  return e;
}

TEST(ProbeGridSystem, BlendsByPriorityAndBorderDistanceAndUpdatesOnlyWhatChanged) {
  World w;
  register_transform_systems(w);
  register_probe_grid_system(w);
  const Entity low = add_constant_grid(w, {-10, -10, -10}, {10, 10, 10}, glm::vec3(1.0f), 0);
  add_constant_grid(w, {0, 0, 0}, {4, 4, 4}, glm::vec3(5.0f), 1);  // spacing 2 m: blends over 2 m
  const Entity deep = add_receiver(w, {2, 2, 2});      // 2 m inside the high grid: all high
  const Entity outside = add_receiver(w, {-5, 0, 0});  // only the low grid
  const Entity edge = add_receiver(w, {2, 2, 0.5f});   // 0.5 m inside: a quarter high
  const Entity nowhere = add_receiver(w, {50, 0, 0});
  w.update(0.016);
  const glm::vec3 up(0, 1, 0);
  EXPECT_NEAR(probe_lit_irradiance(w.get<ProbeLit>(deep), up).x, 5.0f, 1e-4f);
  EXPECT_NEAR(probe_lit_irradiance(w.get<ProbeLit>(outside), up).x, 1.0f, 1e-4f);
  EXPECT_NEAR(probe_lit_irradiance(w.get<ProbeLit>(edge), up).x, 0.25f * 5.0f + 0.75f * 1.0f, 1e-4f);
  EXPECT_FALSE(w.get<ProbeLit>(nowhere).covered);
  EXPECT_TRUE(w.get<ProbeLit>(deep).covered);
  EXPECT_EQ(probe_lit_irradiance(w.get<ProbeLit>(nowhere), up), glm::vec3(0.0f));

  // Nothing moved: nothing is updated.
  const std::uint64_t first = w.get<ProbeLit>(deep).updated_tick;
  EXPECT_GT(first, 0u);
  w.update(0.016);
  EXPECT_EQ(w.get<ProbeLit>(deep).updated_tick, first);
  EXPECT_EQ(w.get<ProbeLit>(outside).updated_tick, first);
  // One receiver moves: only it is updated, to its new value.
  w.patch<Transform>(outside).translation = {1, 1, 1};
  w.update(0.016);
  EXPECT_GT(w.get<ProbeLit>(outside).updated_tick, first);
  EXPECT_EQ(w.get<ProbeLit>(deep).updated_tick, first);
  EXPECT_NEAR(probe_lit_irradiance(w.get<ProbeLit>(outside), up).x, 5.0f * 0.5f + 1.0f * 0.5f, 1e-4f);
  // A grid changes: everyone is updated.
  w.patch<IrradianceProbeGrid>(low).priority = 2;
  w.update(0.016);
  EXPECT_GT(w.get<ProbeLit>(deep).updated_tick, first);
  // low now comes first: 8 m from its border over a 10 m blend, then the rest from the other.
  EXPECT_NEAR(probe_lit_irradiance(w.get<ProbeLit>(deep), up).x, 0.8f * 1.0f + 0.2f * 5.0f, 1e-4f);
  // A grid is removed: everyone is updated again.
  const std::uint64_t before = w.get<ProbeLit>(deep).updated_tick;
  w.destroy(low);
  w.update(0.016);
  EXPECT_GT(w.get<ProbeLit>(deep).updated_tick, before);
  EXPECT_NEAR(probe_lit_irradiance(w.get<ProbeLit>(deep), up).x, 5.0f, 1e-4f);
  EXPECT_TRUE(w.get<ProbeLit>(outside).covered);
}

// A character's origin is at its feet: with a mesh the receiver takes its lighting at the centre of
// the mesh's bounds instead (through its transform, rotation included); without one, at its origin.
// The grid holds E = 3 + y (linear: trilinear interpolation is exact), so the value names the point.
TEST(ProbeGridSystem, ReceiversWithAMeshTakeTheirLightingAtTheBoundsCentre) {
  World w;
  register_transform_systems(w);
  register_probe_grid_system(w);
  IrradianceProbeGrid g = box_grid({-4, -4, -4}, {4, 4, 4}, {3, 3, 3});
  g.data = std::make_shared<const ProbeGridData>(synthetic(g, ProbeShOrder::L1, [](glm::vec3 p, int c) {
    return c == 0 ? glm::vec3(3.0f + p.y) / 0.28209479f : glm::vec3(0.0f);
  }));
  const Entity grid = w.create();
  w.add<IrradianceProbeGrid>(grid, g);
  w.add<Transform>(grid);
  // A 1.8 m tall body standing on its origin: bounds y in [0, 1.8], centre 0.9 m up.
  MeshData body = make_box({0.3f, 0.9f, 0.3f});
  for (glm::vec3& v : body.positions) v.y += 0.9f;
  compute_bounds(body);
  const Entity character = add_receiver(w, {1, -2, 0});
  w.add<Mesh>(character, Mesh{std::make_shared<const MeshData>(body)});
  const Entity bare = add_receiver(w, {1, -2, 0});
  w.update(0.016);
  const glm::vec3 up(0, 1, 0);
  EXPECT_NEAR(probe_lit_irradiance(w.get<ProbeLit>(character), up).x, 3.0f - 2.0f + 0.9f, 1e-4f);
  EXPECT_NEAR(glm::distance(w.get<ProbeLit>(character).position, glm::vec3(1.0f, -1.1f, 0.0f)), 0.0f, 1e-5f);
  EXPECT_NEAR(probe_lit_irradiance(w.get<ProbeLit>(bare), up).x, 3.0f - 2.0f, 1e-4f);
  EXPECT_EQ(w.get<ProbeLit>(bare).position, glm::vec3(1.0f, -2.0f, 0.0f));
  // Lying on its side (90 degrees about z): the centre is 0.9 m along -x, at the origin's height.
  w.patch<Transform>(character).rotation = glm::angleAxis(1.5707964f, glm::vec3(0, 0, 1));
  w.update(0.016);
  EXPECT_NEAR(probe_lit_irradiance(w.get<ProbeLit>(character), up).x, 3.0f - 2.0f, 1e-4f);
  EXPECT_NEAR(w.get<ProbeLit>(character).position.x, 1.0f - 0.9f, 1e-5f);
  // A new mesh (same transform) updates the receiver.
  const std::uint64_t before = w.get<ProbeLit>(character).updated_tick;
  w.update(0.016);
  EXPECT_EQ(w.get<ProbeLit>(character).updated_tick, before);
  w.patch<Transform>(character).rotation = glm::quat(1, 0, 0, 0);
  w.update(0.016);
  MeshData tall = body;
  for (glm::vec3& v : tall.positions) v.y *= 2.0f;
  compute_bounds(tall);
  w.patch<Mesh>(character).data = std::make_shared<const MeshData>(tall);
  w.update(0.016);
  EXPECT_NEAR(probe_lit_irradiance(w.get<ProbeLit>(character), up).x, 3.0f - 2.0f + 1.8f, 1e-4f);
}

TEST(ProbeGridDefault, CoversTheStaticGeometryInsetAndIsAddedOnce) {
  World w;
  EXPECT_FALSE(add_default_probe_grid(w, Preset::Draft).ok());
  const Entity box = w.create();
  w.add<Mesh>(box, Mesh{std::make_shared<const MeshData>(make_box({5.0f, 1.0f, 2.0f}))});
  w.add<Static>(box);
  w.add<Transform>(box, Transform{{1.0f, 1.0f, 0.0f}});
  update_world_transforms(w);
  auto e = add_default_probe_grid(w, Preset::Draft);
  ASSERT_TRUE(e.ok()) << e.error().message;
  const IrradianceProbeGrid& g = w.get<IrradianceProbeGrid>(*e);
  EXPECT_GT(g.box.min.x, -4.0f);
  EXPECT_LT(g.box.min.x, -3.7f);
  EXPECT_LT(g.box.max.y, 2.0f);
  EXPECT_GT(g.box.max.y, 1.9f);
  EXPECT_EQ(g.spacing, IrradianceProbeGrid::preset(Preset::Draft).spacing);
  EXPECT_TRUE(probe_grid_layout(g, glm::mat4(1.0f), "g").ok());
  auto again = add_default_probe_grid(w, Preset::High);
  ASSERT_TRUE(again.ok());
  EXPECT_EQ(*again, *e);
}

}  // namespace
}  // namespace penumbra

namespace penumbra {
namespace {

// A grid a user adds (ComponentInfo::fit) covers what it was added to: a character's posed
// vertices with room around them, or, on an entity without meshes, the level as the default grid does.
TEST(FitProbeGrid, CoversTheSelectionOrTheLevel) {
  World w;
  register_scene_systems(w);
  ASSERT_TRUE(load_builtin(w, "courtyard").ok());
  Transform at;
  at.translation = glm::vec3(-4.0f, 0.0f, 3.0f);
  const Entity walker = add_builtin_character(w, Entity::null(), at, "walker");
  w.update(0.0);
  w.add<IrradianceProbeGrid>(walker);
  irradiance_probe_grid_info().fit(w, walker);
  const Aabb posed = posed_bounds(w, walker);
  const Aabb box = w.get<IrradianceProbeGrid>(walker).box;
  ASSERT_FALSE(posed.empty());
  EXPECT_NEAR(posed.extent().y, 1.83f, 0.1f);  // the walker's height, not the courtyard's
  for (int a = 0; a < 3; ++a) {
    EXPECT_NEAR(box.min[a], posed.min[a] - std::max(0.1f * posed.extent()[a], 0.05f), 1e-4f);
    EXPECT_NEAR(box.max[a], posed.max[a] + std::max(0.1f * posed.extent()[a], 0.05f), 1e-4f);
  }
  const Entity empty = w.create();
  w.add<IrradianceProbeGrid>(empty);
  irradiance_probe_grid_info().fit(w, empty);
  const Aabb fitted = w.get<IrradianceProbeGrid>(empty).box;
  EXPECT_GT(fitted.extent().x, 19.0f);  // the 20 m courtyard, inset by 2%
  EXPECT_LT(fitted.extent().x, 20.0f);
}

}  // namespace
}  // namespace penumbra
