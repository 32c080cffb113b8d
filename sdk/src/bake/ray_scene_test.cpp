#include "penumbra/bake/ray_scene.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <memory>
#include <vector>

#include <glm/gtc/matrix_transform.hpp>

#include "penumbra/core/random.h"
#include "penumbra/ecs/transform.h"
#include "penumbra/scene/components.h"
#include "penumbra/scene/mesh.h"

namespace penumbra {
namespace {

constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();
constexpr float kInf = std::numeric_limits<float>::infinity();

Entity add_mesh(World& world, MeshData mesh, const glm::mat4& m, bool is_static, Material material = {}) {
  Entity e = world.create();
  world.add<Mesh>(e, Mesh{std::make_shared<const MeshData>(std::move(mesh))});
  world.add<WorldTransform>(e, WorldTransform{m});
  world.add<Material>(e, std::move(material));
  if (is_static) world.add<Static>(e);
  return e;
}

// Hit point reconstructed from the hit's triangle and barycentrics, in world space.
glm::vec3 hit_point(const MeshData& mesh, const glm::mat4& m, const Hit& h) {
  const glm::vec3 p0 = mesh.positions[mesh.indices[3 * h.primitive]];
  const glm::vec3 p1 = mesh.positions[mesh.indices[3 * h.primitive + 1]];
  const glm::vec3 p2 = mesh.positions[mesh.indices[3 * h.primitive + 2]];
  const glm::vec3 local = (1.0f - h.barycentrics.x - h.barycentrics.y) * p0 + h.barycentrics.x * p1 +
                          h.barycentrics.y * p2;
  return glm::vec3(m * glm::vec4(local, 1.0f));
}

TEST(RayScene, StaticQuadHitRecord) {
  World world;
  Material red;
  red.base_color = {0.8f, 0.2f, 0.1f, 1.0f};
  red.emissive = {0.0f, 1.0f, 2.0f};
  const glm::mat4 m = glm::translate(glm::mat4(1.0f), glm::vec3(0.0f, 0.0f, -1.0f));
  Entity quad = add_mesh(world, make_quad(2.0f, 2.0f), m, true, red);
  auto scene = RayScene::build(world);
  ASSERT_TRUE(scene.ok()) << scene.error().message;
  EXPECT_EQ(scene->triangle_count(), 2u);
  EXPECT_GT(scene->bvh_bytes(), 0u);

  // From the front (+Z): t = 5, normal +Z, front face, the entity's material.
  const Ray down{{0.2f, 0.3f, 4.0f}, 0.0f, {0.0f, 0.0f, -1.0f}, kInf};
  Hit h;
  ASSERT_TRUE(scene->intersect(down, h));
  EXPECT_NEAR(h.t, 5.0f, 1e-5f);
  EXPECT_EQ(h.entity, quad);
  EXPECT_NEAR(h.normal.z, 1.0f, 1e-6f);
  EXPECT_FALSE(h.back_face);
  EXPECT_EQ(h.material.albedo, glm::vec3(0.8f, 0.2f, 0.1f));
  EXPECT_EQ(h.material.emissive, red.emissive);
  const glm::vec3 p = hit_point(*world.get<Mesh>(quad).data, m, h);
  EXPECT_NEAR(glm::length(p - (down.origin + h.t * down.direction)), 0.0f, 1e-5f);
  EXPECT_TRUE(scene->occluded(down));

  // From behind: back face; a segment ending before the quad: no hit.
  const Ray up{{0.2f, 0.3f, -3.0f}, 0.0f, {0.0f, 0.0f, 1.0f}, kInf};
  ASSERT_TRUE(scene->intersect(up, h));
  EXPECT_TRUE(h.back_face);
  EXPECT_NEAR(h.t, 2.0f, 1e-5f);
  EXPECT_FALSE(scene->occluded(Ray{up.origin, 0.0f, up.direction, 1.9f}));
  EXPECT_FALSE(scene->intersect(Ray{{5.0f, 0.0f, 4.0f}, 0.0f, {0.0f, 0.0f, -1.0f}, kInf}, h));
  EXPECT_EQ(scene->invalid_ray_count(), 0u);
}

TEST(RayScene, InvalidRaysAreRejectedAndCounted) {
  World world;
  add_mesh(world, make_quad(2.0f, 2.0f), glm::mat4(1.0f), true);
  auto scene = RayScene::build(world);
  ASSERT_TRUE(scene.ok()) << scene.error().message;
  const std::vector<Ray> bad = {
      Ray{{kNaN, 0.0f, 1.0f}, 0.0f, {0.0f, 0.0f, -1.0f}, kInf},  // NaN origin
      Ray{{0.0f, kInf, 1.0f}, 0.0f, {0.0f, 0.0f, -1.0f}, kInf},  // infinite origin
      Ray{{0.0f, 0.0f, 1.0f}, 0.0f, {0.0f, 0.0f, 0.0f}, kInf},   // zero direction
      Ray{{0.0f, 0.0f, 1.0f}, 0.0f, {kNaN, 0.0f, -1.0f}, kInf},  // NaN direction
      Ray{{0.0f, 0.0f, 1.0f}, 2.0f, {0.0f, 0.0f, -1.0f}, 1.0f},  // tnear > tfar
      Ray{{0.0f, 0.0f, 1.0f}, -1.0f, {0.0f, 0.0f, -1.0f}, kInf}, // negative tnear
      Ray{{0.0f, 0.0f, 1.0f}, 0.0f, {0.0f, 0.0f, -1.0f}, kNaN},  // NaN tfar
  };
  Hit h;
  for (const Ray& r : bad) {
    EXPECT_FALSE(ray_is_valid(r));
    EXPECT_FALSE(scene->intersect(r, h));
    EXPECT_FALSE(scene->occluded(r));
  }
  EXPECT_EQ(scene->invalid_ray_count(), 2 * bad.size());

  // Packets mixing valid and invalid rays: valid lanes are answered, invalid ones are misses.
  std::vector<Ray> mixed;
  for (int i = 0; i < 40; ++i) {
    mixed.push_back(i % 3 == 0 ? bad[static_cast<std::size_t>(i) % bad.size()]
                               : Ray{{0.01f * float(i) - 0.2f, 0.1f, 1.0f}, 0.0f, {0.0f, 0.0f, -1.0f}, kInf});
  }
  std::vector<std::uint8_t> occ(mixed.size()), mask(mixed.size());
  std::vector<Hit> hits(mixed.size());
  scene->occluded(mixed, occ);
  scene->intersect(mixed, hits, mask);
  std::uint64_t invalid = 0;
  for (std::size_t i = 0; i < mixed.size(); ++i) {
    const bool ok = i % 3 != 0;
    invalid += ok ? 0 : 1;
    EXPECT_EQ(occ[i], ok ? 1 : 0) << i;
    EXPECT_EQ(mask[i], ok ? 1 : 0) << i;
    if (ok) {
      EXPECT_NEAR(hits[i].t, 1.0f, 1e-5f);
    }
  }
  EXPECT_EQ(scene->invalid_ray_count(), 2 * bad.size() + 2 * invalid);
}

TEST(RayScene, DropsDegenerateTrianglesAndRejectsBadIndices) {
  MeshData mesh;
  mesh.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {2, 0, 0}, {kNaN, 0, 0}};
  mesh.indices = {0, 1, 2,   // good
                  0, 1, 3,   // collinear: zero area
                  0, 4, 2};  // NaN vertex
  World world;
  add_mesh(world, mesh, glm::mat4(1.0f), true);
  auto scene = RayScene::build(world);
  ASSERT_TRUE(scene.ok()) << scene.error().message;
  EXPECT_EQ(scene->triangle_count(), 1u);
  EXPECT_EQ(scene->dropped_triangle_count(), 2u);
  Hit h;
  ASSERT_TRUE(scene->intersect(Ray{{0.2f, 0.2f, 1.0f}, 0.0f, {0.0f, 0.0f, -1.0f}, kInf}, h));
  EXPECT_EQ(h.primitive, 0u);

  mesh.indices = {0, 1, 7};
  World bad_world;
  Entity e = add_mesh(bad_world, mesh, glm::mat4(1.0f), true);
  bad_world.add<Name>(e, Name{"broken"});
  auto bad = RayScene::build(bad_world);
  ASSERT_FALSE(bad.ok());
  EXPECT_EQ(bad.error().code, ErrorCode::InvalidInput);
  EXPECT_NE(bad.error().message.find("broken"), std::string::npos) << bad.error().message;
}

TEST(RayScene, MovableInstancesFollowUpdate) {
  World world;
  // One static floor and two movable quads sharing one mesh (one sub-scene).
  add_mesh(world, make_quad(10.0f, 10.0f), glm::translate(glm::mat4(1.0f), {0.0f, 0.0f, -5.0f}), true);
  auto shared = std::make_shared<const MeshData>(make_quad(1.0f, 1.0f));
  Entity a = world.create(), b = world.create();
  world.add<Mesh>(a, Mesh{shared});
  world.add<Mesh>(b, Mesh{shared});
  world.add<WorldTransform>(a, WorldTransform{glm::translate(glm::mat4(1.0f), {0.0f, 0.0f, 1.0f})});
  // b: flipped to face -Z, at x = 3.
  world.add<WorldTransform>(b, WorldTransform{glm::rotate(glm::translate(glm::mat4(1.0f), {3.0f, 0.0f, 2.0f}),
                                                          glm::radians(180.0f), {1.0f, 0.0f, 0.0f})});
  auto scene = RayScene::build(world);
  ASSERT_TRUE(scene.ok()) << scene.error().message;
  EXPECT_EQ(scene->triangle_count(), 6u);

  Hit h;
  const Ray at_a{{0.1f, 0.1f, 4.0f}, 0.0f, {0.0f, 0.0f, -1.0f}, kInf};
  ASSERT_TRUE(scene->intersect(at_a, h));
  EXPECT_EQ(h.entity, a);
  EXPECT_NEAR(h.t, 3.0f, 1e-5f);
  EXPECT_NEAR(h.normal.z, 1.0f, 1e-5f);
  const Ray at_b{{3.1f, 0.1f, 4.0f}, 0.0f, {0.0f, 0.0f, -1.0f}, kInf};
  ASSERT_TRUE(scene->intersect(at_b, h));
  EXPECT_EQ(h.entity, b);
  EXPECT_NEAR(h.t, 2.0f, 1e-5f);
  EXPECT_NEAR(h.normal.z, -1.0f, 1e-5f);  // instance normal transformed to world space
  EXPECT_TRUE(h.back_face);

  // Move a down by 2 and destroy b: the floor shows through where b was.
  world.get<WorldTransform>(a).matrix = glm::translate(glm::mat4(1.0f), {0.0f, 0.0f, -1.0f});
  world.destroy(b);
  ASSERT_TRUE(scene->update(world).ok());
  ASSERT_TRUE(scene->intersect(at_a, h));
  EXPECT_EQ(h.entity, a);
  EXPECT_NEAR(h.t, 5.0f, 1e-5f);
  ASSERT_TRUE(scene->intersect(at_b, h));
  EXPECT_NEAR(h.t, 9.0f, 1e-5f);
  EXPECT_NE(h.entity, a);

  // Static-only scenes ignore movable meshes.
  auto statics = RayScene::build(world, RaySceneOptions{.include_dynamic = false});
  ASSERT_TRUE(statics.ok());
  EXPECT_EQ(statics->triangle_count(), 2u);
}

TEST(RayScene, SkinnedMeshIsRefittedFromThePose) {
  World world;
  MeshData mesh = make_quad(2.0f, 2.0f);
  // Left half bound to joint 0, right half to joint 1.
  for (const glm::vec3& p : mesh.positions) {
    mesh.joints.push_back(glm::u16vec4(p.x < 0.0f ? 0 : 1, 0, 0, 0));
    mesh.weights.push_back({1.0f, 0.0f, 0.0f, 0.0f});
  }
  Entity skinned = world.create();
  world.add<Mesh>(skinned, Mesh{std::make_shared<const MeshData>(mesh)});
  world.add<WorldTransform>(skinned, WorldTransform{glm::mat4(1.0f)});
  world.add<Skin>(skinned, Skin{{world.create(), world.create()}, {glm::mat4(1.0f), glm::mat4(1.0f)}});
  world.add<SkinPose>(skinned, SkinPose{{glm::mat4(1.0f), glm::mat4(1.0f)}});
  auto scene = RayScene::build(world);
  ASSERT_TRUE(scene.ok()) << scene.error().message;

  Hit h;
  const Ray centre{{0.0f, 0.5f, 4.0f}, 0.0f, {0.0f, 0.0f, -1.0f}, kInf};
  ASSERT_TRUE(scene->intersect(centre, h));
  EXPECT_EQ(h.entity, skinned);
  EXPECT_NEAR(h.t, 4.0f, 1e-5f);

  // Lift every joint by 1 (the whole quad moves), then only the right joint: the quad tilts.
  const glm::mat4 up = glm::translate(glm::mat4(1.0f), {0.0f, 0.0f, 1.0f});
  world.get<SkinPose>(skinned).joint_matrices = {up, up};
  ASSERT_TRUE(scene->update(world).ok());
  ASSERT_TRUE(scene->intersect(centre, h));
  EXPECT_NEAR(h.t, 3.0f, 1e-5f);
  world.get<SkinPose>(skinned).joint_matrices = {glm::mat4(1.0f), glm::translate(glm::mat4(1.0f), {0.0f, 0.0f, 2.0f})};
  ASSERT_TRUE(scene->update(world).ok());
  ASSERT_TRUE(scene->intersect(Ray{{0.5f, 0.0f, 4.0f}, 0.0f, {0.0f, 0.0f, -1.0f}, kInf}, h));
  EXPECT_NEAR(h.t, 2.5f, 1e-4f);  // z = 1.5 at x = 0.5 on the plane from (-1, z=0) to (1, z=2)

  // A pose that produces NaN is refused with an error, not sent to Embree.
  world.get<SkinPose>(skinned).joint_matrices[0][0][0] = kNaN;
  EXPECT_FALSE(scene->update(world).ok());
  // So is a pose with fewer matrices than the mesh's joints.
  world.get<SkinPose>(skinned).joint_matrices = {glm::mat4(1.0f)};
  const Status short_pose = scene->update(world);
  ASSERT_FALSE(short_pose.ok());
  EXPECT_NE(short_pose.error().message.find("joint 1"), std::string::npos) << short_pose.error().message;
}

TEST(RayScene, PacketQueriesMatchSingleRays) {
  World world;
  add_mesh(world, make_icosphere(1.0f, 4), glm::mat4(1.0f), true);
  auto scene = RayScene::build(world);
  ASSERT_TRUE(scene.ok()) << scene.error().message;
  Rng rng = Rng::stream(7, 0);
  std::vector<Ray> rays;
  for (int i = 0; i < 1000; ++i) {
    const glm::vec3 o(4.0f * rng.next_float() - 2.0f, 4.0f * rng.next_float() - 2.0f, 3.0f);
    const glm::vec3 target(rng.next_float() - 0.5f, rng.next_float() - 0.5f, 0.0f);
    rays.push_back(Ray{o, 0.0f, target - o, kInf});
  }
  std::vector<std::uint8_t> occ(rays.size()), mask(rays.size());
  std::vector<Hit> hits(rays.size());
  scene->occluded(rays, occ);
  scene->intersect(rays, hits, mask);
  int hit_count = 0;
  for (std::size_t i = 0; i < rays.size(); ++i) {
    Hit h;
    const bool single = scene->intersect(rays[i], h);
    EXPECT_EQ(single, scene->occluded(rays[i]));
    EXPECT_EQ(single, occ[i] != 0);
    ASSERT_EQ(single, mask[i] != 0);
    if (!single) continue;
    ++hit_count;
    EXPECT_EQ(h.primitive, hits[i].primitive);
    EXPECT_NEAR(h.t, hits[i].t, 1e-5f * h.t);
    // The sphere is hit from outside: front faces, at radius ~1.
    EXPECT_FALSE(h.back_face);
    EXPECT_NEAR(glm::length(rays[i].origin + h.t * rays[i].direction), 1.0f, 3e-3f);
  }
  EXPECT_GT(hit_count, 500);
}

}  // namespace
}  // namespace penumbra
