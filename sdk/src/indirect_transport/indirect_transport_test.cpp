// Indirect transport: the Haar bases, the standard decomposition of a link, closed forms (two
// facing squares, a closed box), the Neumann series at albedo 0.99, the extremes of the runtime's
// direct light, determinism, the chunk and the update system.
#include "penumbra/indirect_transport/indirect_transport_baker.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <numbers>

#include <glm/geometric.hpp>

#include "penumbra/bake/baker.h"
#include "penumbra/bakers.h"
#include "penumbra/bake/ray_scene.h"
#include "penumbra/core/jobs.h"
#include "penumbra/core/random.h"
#include "penumbra/ecs/transform.h"
#include "penumbra/indirect_transport/indirect_transport.h"
#include "penumbra/indirect_transport/indirect_transport_system.h"
#include "penumbra/runtime.h"
#include "penumbra/scene/animation.h"
#include "penumbra/scene/builtin.h"
#include "penumbra/scene/components.h"
#include "penumbra/scene/mesh.h"

namespace penumbra {
namespace {

constexpr float kPi = std::numbers::pi_v<float>;

// A static quad p0 p1 p2 p3 (counter-clockwise seen from the side it faces) as a receiver.
Entity quad(World& world, const std::string& name, glm::vec3 p0, glm::vec3 p1, glm::vec3 p2, glm::vec3 p3,
            glm::vec3 albedo) {
  MeshData mesh;
  mesh.name = name;
  mesh.positions = {p0, p1, p2, p3};
  const glm::vec3 n = glm::normalize(glm::cross(p1 - p0, p2 - p0));
  mesh.normals = {n, n, n, n};
  mesh.indices = {0, 1, 2, 0, 2, 3};
  compute_bounds(mesh);
  const Entity e = world.create();
  world.add<Name>(e, Name{name});
  world.add<Transform>(e);
  world.add<Mesh>(e, Mesh{std::make_shared<const MeshData>(std::move(mesh))});
  Material m;
  m.base_color = glm::vec4(albedo, 1.0f);
  world.add<Material>(e, m);
  world.add<Static>(e);
  world.add<IndirectReceiver>(e);
  return e;
}

Entity transport(World& world, std::uint32_t level, float threshold) {
  const Entity e = world.create();
  world.add<Name>(e, Name{"transport"});
  world.add<Transform>(e);
  IndirectTransport t = IndirectTransport::preset(Preset::Draft);
  t.finest_level = level;
  t.refinement_threshold = threshold;
  world.add<IndirectTransport>(e, t);
  return e;
}

Result<BakeResult> bake(World& world, unsigned threads) {
  register_bakers(world);
  update_world_transforms(world);
  ThreadPool pool(threads);
  JobContext jobs(&pool);
  BakeSettings settings;
  settings.preset = Preset::Draft;
  return bake_world(world, {"indirect-transport"}, settings, jobs);
}

std::shared_ptr<const TransportData> baked(World& world, unsigned threads = 2) {
  auto result = bake(world, threads);
  EXPECT_TRUE(result.ok()) << (result.ok() ? "" : result.error().message);
  if (!result.ok()) return nullptr;
  for (Entity e : world.view<IndirectTransport>().sorted_entities()) return world.get<IndirectTransport>(e).data;
  return nullptr;
}

// The six inward faces of the unit cube.
void closed_box(World& world, glm::vec3 a) {
  quad(world, "floor", {0, 0, 0}, {0, 0, 1}, {1, 0, 1}, {1, 0, 0}, a);
  quad(world, "ceiling", {0, 1, 0}, {1, 1, 0}, {1, 1, 1}, {0, 1, 1}, a);
  quad(world, "back", {0, 0, 1}, {0, 1, 1}, {1, 1, 1}, {1, 0, 1}, a);
  quad(world, "front", {0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}, a);
  quad(world, "left", {0, 0, 0}, {0, 1, 0}, {0, 1, 1}, {0, 0, 1}, a);
  quad(world, "right", {1, 0, 0}, {1, 0, 1}, {1, 1, 1}, {1, 1, 0}, a);
}

// The coverage-weighted mean indirect irradiance (green) when every covered leaf has E = 1.
double covered_mean_of_uniform(const TransportData& data) {
  std::vector<glm::vec3> direct(data.leaf_count(), glm::vec3(0.0f)), indirect(data.leaf_count());
  for (const TransportPatch& p : data.patches)
    for (std::uint32_t k = 0; k < p.leaves(); ++k)
      if (p.coverage[k] > 0.0f) direct[p.first + k] = glm::vec3(1.0f);
  apply_transport(data, direct, indirect, 0.0f);
  double sum = 0.0, weight = 0.0;
  for (const TransportPatch& p : data.patches)
    for (std::uint32_t k = 0; k < p.leaves(); ++k) {
      sum += double(p.coverage[k]) * p.leaf_area() * indirect[p.first + k].y;
      weight += double(p.coverage[k]) * p.leaf_area();
    }
  return sum / weight;
}

TEST(IndirectTransportHaar, RoundTripsAndPreservesTheIntegralOfTheSquare) {
  Rng rng = Rng::stream(3, 0);
  for (std::uint32_t level = 0; level <= 4; ++level) {
    const std::size_t n = std::size_t{1} << (2 * level);
    std::vector<glm::vec3> f(n), c(n);
    double square = 0.0;
    for (std::size_t k = 0; k < n; ++k) {
      f[k] = glm::vec3(rng.next_float(), rng.next_float() - 0.5f, 2.0f * rng.next_float());
      square += glm::dot(f[k], f[k]) * 0.25;
    }
    c = f;
    haar_analyse(c, level, 0.25f);
    double coeff_square = 0.0;
    for (const glm::vec3& v : c) coeff_square += glm::dot(v, v);
    EXPECT_NEAR(coeff_square, square, 1e-4 * square) << "level " << level;
    // The scaling coefficient is the integral over the patch / sqrt(area).
    double sum = 0.0;
    for (const glm::vec3& v : f) sum += v.x;
    EXPECT_NEAR(c[0].x, sum * 0.25 / std::sqrt(0.25 * double(n)), 1e-4 * (1.0 + std::abs(sum)));
    haar_synthesise(c, level, 0.25f);
    for (std::size_t k = 0; k < n; ++k) EXPECT_NEAR(glm::length(c[k] - f[k]), 0.0f, 1e-5f);
  }
}

// Two patches side by side; one link between a level-1 node of the receiver and a level-2 node of
// the sender must transfer exactly F rho x (the sender node's mean) onto every receiver leaf below
// its node, and nothing elsewhere.
TEST(IndirectTransportOperator, OneLinkInTheHaarBasesIsTheBoxToBoxTransfer) {
  std::vector<TransportPatch> patches(2);
  for (int k = 0; k < 2; ++k) {
    TransportPatch& p = patches[static_cast<std::size_t>(k)];
    p.level = 2;
    p.origin = glm::vec3(0.0f, 0.0f, float(k));
    p.edge_u = glm::vec3(k == 0 ? 2.0f : 1.0f, 0.0f, 0.0f);  // different leaf areas
    p.edge_v = glm::vec3(0.0f, 1.0f, 0.0f);
    p.albedo = glm::vec3(0.5f, 0.25f, 1.0f);
    p.coverage.assign(16, 1.0f);
    p.first = 16u * static_cast<std::uint32_t>(k);
  }
  // Receiver node (level 1, i 1, j 0) = leaves i in {2, 3}, j in {0, 1}; sender node (2, 3, 2) =
  // one leaf; and a second link from the sender's root.
  const std::uint32_t r_node = 1 + 1, s_leaf = 5 + 3 + 2 * 4, s_root = 0;
  std::vector<std::vector<TransportLink>> links(2);
  links[0] = {{r_node, 1, s_leaf, 0.3f}, {0, 1, s_root, 0.1f}};
  TransportData data;
  data.patches = patches;
  JobContext jobs;
  data.global = direct_operator(patches, links, jobs);
  std::vector<glm::vec3> direct(32, glm::vec3(0.0f)), indirect(32);
  Rng rng = Rng::stream(9, 1);
  double sender_sum = 0.0;
  for (std::uint32_t k = 16; k < 32; ++k) {
    direct[k] = glm::vec3(rng.next_float() + 0.1f);
    sender_sum += direct[k].x;
  }
  apply_transport(data, direct, indirect, 0.0f);
  const float mean = float(sender_sum / 16.0);
  const glm::vec3 leaf = direct[16 + 3 + 2 * 4];
  for (std::uint32_t j = 0; j < 4; ++j)
    for (std::uint32_t i = 0; i < 4; ++i) {
      glm::vec3 expect = 0.1f * mean * patches[1].albedo;
      if (i >= 2 && j < 2) expect += 0.3f * leaf * patches[1].albedo;
      EXPECT_NEAR(glm::length(indirect[i + 4 * j] - expect), 0.0f, 1e-5f) << i << "," << j;
    }
  for (std::uint32_t k = 16; k < 32; ++k) EXPECT_NEAR(glm::length(indirect[k]), 0.0f, 1e-6f);
}

// Two coaxial unit squares one metre apart: the form factor between them is 0.19982 (Hottel's
// closed form for parallel equal squares). A black receiver facing a sender lit by E = 1 with
// albedo 0.5 receives 0.5 x 0.19982 on average, and reflects nothing back.
TEST(IndirectTransportBake, ParallelSquaresMatchTheClosedFormFormFactor) {
  World world;
  register_lighting(world);
  const Entity re = quad(world, "receiver", {0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}, glm::vec3(0.0f));  // faces +z
  const Entity se = quad(world, "sender", {0, 0, 1}, {0, 1, 1}, {1, 1, 1}, {1, 0, 1}, glm::vec3(0.5f));   // faces -z
  world.patch<IndirectReceiver>(re).patch_size = 1.0f;
  world.patch<IndirectReceiver>(se).patch_size = 1.0f;
  transport(world, 3, 0.002f);
  auto data = baked(world);
  ASSERT_TRUE(data);
  ASSERT_EQ(data->patches.size(), 2u);
  const TransportPatch& r = data->patches[0].key == "receiver" ? data->patches[0] : data->patches[1];
  const TransportPatch& s = data->patches[0].key == "receiver" ? data->patches[1] : data->patches[0];
  std::vector<glm::vec3> direct(data->leaf_count(), glm::vec3(0.0f)), indirect(data->leaf_count());
  for (std::uint32_t k = 0; k < s.leaves(); ++k) direct[s.first + k] = glm::vec3(1.0f);
  apply_transport(*data, direct, indirect, 0.0f);
  double mean = 0.0;
  for (std::uint32_t k = 0; k < r.leaves(); ++k) mean += indirect[r.first + k].x / double(r.leaves());
  EXPECT_NEAR(mean, 0.5 * 0.19982, 0.03 * 0.5 * 0.19982);
  for (std::uint32_t k = 0; k < s.leaves(); ++k) EXPECT_EQ(indirect[s.first + k], glm::vec3(0.0f));
  // Symmetry: the centre of the receiver gets more than its corners.
  EXPECT_GT(indirect[r.first + 3 + 3 * 8].x, indirect[r.first].x);
}

// A closed cube seen from inside, every wall albedo rho and lit by E = 1: the form factors from
// any point sum to 1, so every bounce brings rho^k and E_ind = rho / (1 - rho).
TEST(IndirectTransportBake, ClosedBoxConvergesToTheGeometricSeries) {
  World world;
  register_lighting(world);
  const float rho = 0.5f;
  closed_box(world, glm::vec3(rho));
  transport(world, 2, 0.01f);
  auto data = baked(world);
  ASSERT_TRUE(data);
  EXPECT_TRUE(data->converged);
  EXPECT_GT(data->terms, 5u);
  const double mean = covered_mean_of_uniform(*data);
  EXPECT_NEAR(mean, rho / (1.0f - rho), 0.05 * rho / (1.0f - rho));
}

TEST(IndirectTransportBake, AlbedoNearOneStopsWithAReport) {
  World world;
  register_lighting(world);
  closed_box(world, glm::vec3(0.99f));
  const Entity t = transport(world, 1, 0.05f);
  world.patch<IndirectTransport>(t).max_bounces = 8;
  auto data = baked(world);
  ASSERT_TRUE(data);
  EXPECT_EQ(data->terms, 8u);
  EXPECT_FALSE(data->converged);
  EXPECT_GT(data->last_term_ratio, 1e-3f);
}

TEST(IndirectTransportBake, IsBitIdenticalAtAnyThreadCountAndScaleFree) {
  const auto bytes = [](float scale, unsigned threads) {
    World world;
    register_lighting(world);
    EXPECT_TRUE(load_builtin(world, "maze").ok());
    world.view<Transform>().each([&](Entity e, Transform& tr) {
      if (!world.has<Parent>(e)) tr.scale = glm::vec3(scale);
    });
    world.update(0.0);
    world.update(0.0);
  const Status defaults = add_default_lighting(world, Preset::Draft, false);
    EXPECT_TRUE(defaults.ok()) << defaults.error().message;
    auto result = bake(world, threads);
    EXPECT_TRUE(result.ok()) << (result.ok() ? "" : result.error().message);
    return result.ok() && !result->file.chunks.empty() ? result->file.chunks[0].payload : std::vector<std::byte>{};
  };
  const std::vector<std::byte> one = bytes(1.0f, 1), two = bytes(1.0f, 2);
  ASSERT_FALSE(one.empty());
  EXPECT_EQ(one, two);
  // Thresholds are form factors: a maze scaled by 1e-3 or 1e4 refines into the same links.
  for (float scale : {1e-3f, 1e4f}) {
    const std::vector<std::byte> scaled = bytes(scale, 2);
    ASSERT_FALSE(scaled.empty());
    auto a = read_transport_chunk(BakeChunk{kTransportChunkType, kTransportChunkVersion, "", one});
    auto b = read_transport_chunk(BakeChunk{kTransportChunkType, kTransportChunkVersion, "", scaled});
    ASSERT_TRUE(a.ok() && b.ok());
    EXPECT_EQ(b->data.leaf_count(), a->data.leaf_count()) << scale;
    // Decisions at the threshold flip with rounding (a few percent of the links); the light they
    // carry does not change.
    EXPECT_NEAR(double(b->data.links), double(a->data.links), 0.06 * double(a->data.links)) << scale;
    EXPECT_NEAR(covered_mean_of_uniform(b->data), covered_mean_of_uniform(a->data),
                0.01 * covered_mean_of_uniform(a->data))
        << scale;
  }
}

// Slivers, coplanar overlaps (a T-junction's pieces) and patches that see each other's backs: a
// warning names the sliver, the rest bakes to finite light with no transfer between coplanar or
// back-to-back surfaces.
TEST(IndirectTransportBake, DegenerateAndBackFacingGeometry) {
  World world;
  register_lighting(world);
  quad(world, "sliver", {0, 0, 2}, {2, 0, 2}, {2, 1e-5f, 2}, {0, 1e-5f, 2}, glm::vec3(0.5f));
  quad(world, "floor_a", {0, 0, 0}, {0, 0, 1}, {1, 0, 1}, {1, 0, 0}, glm::vec3(0.5f));
  quad(world, "floor_b", {0.5f, 0, 0}, {0.5f, 0, 1}, {1.5f, 0, 1}, {1.5f, 0, 0}, glm::vec3(0.5f));  // overlaps a
  quad(world, "back", {0, 1, 0}, {0, 1, 1}, {1, 1, 1}, {1, 1, 0}, glm::vec3(0.5f));  // faces up, away from the floor
  const Entity t = transport(world, 2, 0.02f);
  update_world_transforms(world);
  std::vector<std::string> warnings;
  auto patches = build_transport_patches(world, world.get<IndirectTransport>(t), warnings);
  ASSERT_TRUE(patches.ok()) << patches.error().message;
  ASSERT_FALSE(warnings.empty());
  EXPECT_NE(warnings[0].find("'sliver'"), std::string::npos) << warnings[0];
  auto data = baked(world);
  ASSERT_TRUE(data);
  EXPECT_EQ(data->links, 0u);  // coplanar floors and a back-to-back ceiling exchange nothing
  std::vector<glm::vec3> direct(data->leaf_count(), glm::vec3(1.0f)), indirect(data->leaf_count());
  apply_transport(*data, direct, indirect, 0.0f);
  for (const glm::vec3& e : indirect) EXPECT_EQ(e, glm::vec3(0.0f));
}

TEST(IndirectTransportRuntime, UpdateIsBitIdenticalAtAnyThreadCount) {
  World world;
  register_lighting(world);
  closed_box(world, glm::vec3(0.6f));
  transport(world, 3, 0.01f);
  auto data = baked(world);
  ASSERT_TRUE(data);
  std::vector<glm::vec3> direct(data->leaf_count());
  Rng rng = Rng::stream(5, 5);
  for (glm::vec3& d : direct) d = glm::vec3(rng.next_float(), rng.next_float(), rng.next_float());
  std::vector<glm::vec3> serial(data->leaf_count()), one(data->leaf_count()), two(data->leaf_count());
  apply_transport(*data, direct, serial);
  ThreadPool p1(1), p2(2);
  apply_transport(*data, direct, one, 1e-4f, &p1);
  apply_transport(*data, direct, two, 1e-4f, &p2);
  EXPECT_EQ(serial, one);
  EXPECT_EQ(serial, two);
}

TEST(IndirectTransportChunk, RoundTripsAndRejectsDamage) {
  World world;
  register_lighting(world);
  quad(world, "a", {0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}, glm::vec3(0.5f));
  quad(world, "b", {0, 0, 1}, {0, 1, 1}, {1, 1, 1}, {1, 0, 1}, glm::vec3(0.5f));
  transport(world, 2, 0.05f);
  auto result = bake(world, 2);
  ASSERT_TRUE(result.ok()) << result.error().message;
  ASSERT_EQ(result->file.chunks.size(), 1u);
  const BakeChunk& chunk = result->file.chunks[0];
  auto read = read_transport_chunk(chunk);
  ASSERT_TRUE(read.ok()) << read.error().message;
  EXPECT_EQ(write_transport_chunk(read->key, read->data).payload, chunk.payload);
  // Every truncation fails cleanly, naming the chunk.
  for (std::size_t cut = 0; cut < chunk.payload.size(); cut += 7) {
    BakeChunk damaged = chunk;
    damaged.payload.resize(cut);
    auto bad = read_transport_chunk(damaged);
    ASSERT_FALSE(bad.ok()) << cut;
    EXPECT_NE(bad.error().message.find("WRTO"), std::string::npos);
  }
  // An operator row out of range.
  TransportData d = read->data;
  ASSERT_GT(d.global.row.size(), 0u);
  d.global.row[0] = d.global.size;
  auto bad = read_transport_chunk(write_transport_chunk("x", d));
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(bad.error().message.find("re-bake"), std::string::npos);
}

TEST(IndirectTransportRuntime, LightTouchingAPatchCornerGivesTheSolidAngleLimit) {
  // A point light of intensity I at height h -> 0 over the shared corner of four leaves sees each
  // leaf fill a quarter of its half space, Omega -> pi / 2: each leaf's mean irradiance is
  // I (pi / 2) / A, finite although the inverse-square kernel diverges there.
  TransportData data;
  TransportPatch p;
  p.level = 1;
  p.edge_u = glm::vec3(1, 0, 0);
  p.edge_v = glm::vec3(0, 1, 0);
  p.normal = glm::vec3(0, 0, 1);
  p.coverage.assign(4, 1.0f);
  data.patches.push_back(p);
  RuntimeLight light;
  light.light.type = Light::Type::Point;
  light.light.intensity = 1.0f;
  light.position = glm::vec3(0.5f, 0.5f, 1e-6f);  // the centre of the patch: the shared corner of its 4 leaves
  std::vector<glm::vec3> out(4);
  direct_irradiance(data, std::span<const RuntimeLight>(&light, 1), nullptr, out);
  for (const glm::vec3& e : out) {
    EXPECT_TRUE(std::isfinite(e.x));
    EXPECT_NEAR(e.x, (kPi / 2.0f) / 0.25f, 0.01f * (kPi / 2.0f) / 0.25f);
  }
  // Behind the patch and grazing (in its plane): nothing.
  light.position = glm::vec3(0.5f, 0.5f, -0.3f);
  direct_irradiance(data, std::span<const RuntimeLight>(&light, 1), nullptr, out);
  for (const glm::vec3& e : out) EXPECT_EQ(e.x, 0.0f);
  light.position = glm::vec3(3.0f, 0.5f, 0.0f);
  direct_irradiance(data, std::span<const RuntimeLight>(&light, 1), nullptr, out);
  for (const glm::vec3& e : out) EXPECT_EQ(e.x, 0.0f);
  // Far away it is the inverse-square law at the leaf centre.
  light.position = glm::vec3(0.25f, 0.25f, 100.0f);
  direct_irradiance(data, std::span<const RuntimeLight>(&light, 1), nullptr, out);
  EXPECT_NEAR(out[0].x, 1e-4f, 1e-8f);
}

TEST(IndirectTransportRuntime, RejectsANonFiniteLightByName) {
  World world;
  register_lighting(world);
  const Entity e = world.create();
  world.add<Name>(e, Name{"lantern"});
  Transform t;
  t.translation = glm::vec3(std::numeric_limits<float>::quiet_NaN(), 1.0f, 0.0f);
  world.add<Transform>(e, t);
  world.add<Light>(e);
  world.add<DynamicLight>(e);
  update_world_transforms(world);
  auto lights = dynamic_lights(world);
  ASSERT_FALSE(lights.ok());
  EXPECT_NE(lights.error().message.find("lantern"), std::string::npos);
}

TEST(IndirectTransportRuntime, UpdatesOnlyWhenALightMovesWithoutDriftOrGrowth) {
  World world;
  register_lighting(world);
  ASSERT_TRUE(load_builtin(world, "maze").ok());
  world.update(0.0);
  const Status defaults = add_default_lighting(world, Preset::Draft, false);
  ASSERT_TRUE(defaults.ok()) << defaults.error().message;
  ASSERT_TRUE(bake(world, 2).ok());
  Entity owner, lantern;
  for (Entity e : world.view<IndirectTransport>().sorted_entities()) owner = e;
  for (Entity e : world.view<DynamicLight>().sorted_entities()) lantern = e;
  ASSERT_TRUE(owner && lantern);
  world.remove<Animator>(lantern);  // the test moves it
  auto first = update_indirect_transport(world);
  ASSERT_TRUE(first.ok() && *first);
  const std::vector<glm::vec3> start = world.get<IndirectLightmap>(owner).irradiance;
  auto again = update_indirect_transport(world);
  ASSERT_TRUE(again.ok());
  EXPECT_FALSE(*again);  // nothing moved: nothing done
  double total = 0.0;
  for (const glm::vec3& v : start) total += v.x + v.y + v.z;
  EXPECT_GT(total, 0.0);
  const glm::vec3 home = world.get<Transform>(lantern).translation;
  for (int frame = 0; frame < 1000; ++frame) {
    world.patch<Transform>(lantern).translation = home + glm::vec3(0.002f * float(frame % 50), 0.0f, 0.0f);
    update_world_transforms(world);
    auto moved = update_indirect_transport(world);
    ASSERT_TRUE(moved.ok());
    if (frame % 50 != 0) {
      EXPECT_TRUE(*moved) << frame;
    }
  }
  world.patch<Transform>(lantern).translation = home;
  update_world_transforms(world);
  ASSERT_TRUE(update_indirect_transport(world).ok());
  const IndirectLightmap& map = world.get<IndirectLightmap>(owner);
  EXPECT_EQ(map.irradiance.size(), start.size());
  EXPECT_EQ(map.irradiance.capacity(), start.size());
  EXPECT_EQ(map.irradiance, start);  // no drift: the same light gives the same light
}

}  // namespace
}  // namespace penumbra
