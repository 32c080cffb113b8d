// The ao-field bake against ray-traced AO of the caster alone (sphere, box), the extremes
// (centre, hull, beyond the falloff, scale 1e-3 and 1e4, a flat caster, a needle, many casters),
// determinism across thread counts, the chunk round trip and the baker through bake_world.
#include "penumbra/ao_field/ao_field_baker.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <functional>
#include <memory>
#include <numbers>
#include <vector>

#include <glm/geometric.hpp>
#include <glm/gtc/matrix_transform.hpp>

#include "penumbra/ao_field/ao_field_system.h"
#include "penumbra/bake/baker.h"
#include "penumbra/bake/integrators.h"
#include "penumbra/bake/ray_scene.h"
#include "penumbra/core/random.h"
#include "penumbra/core/sampling.h"
#include "penumbra/ecs/transform.h"
#include "penumbra/runtime.h"
#include "penumbra/scene/mesh.h"

namespace penumbra {
namespace {

AOFieldCaster settings(std::uint32_t res, std::uint32_t radii, std::uint32_t rays) {
  AOFieldCaster c;
  c.resolution = res;
  c.radial_samples = radii;
  c.rays_per_sample = rays;
  return c;
}

AOFieldData bake(const AOFieldCaster& c, const MeshData& mesh, unsigned threads = 2, std::uint64_t seed = 7) {
  ThreadPool pool(threads);
  JobContext jobs(&pool);
  MemoryBudget budget;
  auto data = bake_ao_field(c, mesh, seed, jobs, budget, "ao field 'test'");
  EXPECT_TRUE(data.ok()) << (data.ok() ? "" : data.error().message);
  return data.ok() ? std::move(*data) : AOFieldData{};
}

// A RayScene of the mesh alone at the identity transform: the reference's world.
RayScene scene_of(const MeshData& mesh, World& w) {
  const Entity e = w.create();
  w.add<Mesh>(e, Mesh{std::make_shared<const MeshData>(mesh)});
  w.add<WorldTransform>(e);
  w.add<Static>(e);
  auto s = RayScene::build(w);
  EXPECT_TRUE(s.ok());
  return std::move(*s);
}

struct ErrorStats {
  double mae = 0.0, max = 0.0;
  int count = 0;
};

// Receivers at random directions and distances outside the hull (r from the hull distance
// `hull(dir)`, known in closed form for the test shapes, to 3 x the bounding radius), normals random over the hemisphere that faces the caster's centre; error of the field
// against the ray-traced occlusion (1 - ambient_occlusion) with 1024 rays.
ErrorStats error_outside_hull(const AOFieldData& field, const MeshData& mesh, int receivers,
                              const std::function<float(glm::vec3)>& hull) {
  World w;
  const RayScene scene = scene_of(mesh, w);
  ErrorStats st;
  for (int i = 0; i < receivers; ++i) {
    Rng rng = Rng::stream(99, static_cast<std::uint64_t>(i));
    const glm::vec3 dir = uniform_sphere({rng.next_float(), rng.next_float()});
    const float r0 = hull(dir);
    const float r = r0 + (3.0f * field.bounding_radius - r0) * rng.next_float();
    const glm::vec3 x = field.centre + r * dir;
    glm::vec3 n = to_world(-dir, cosine_hemisphere({rng.next_float(), rng.next_float()}));
    n = glm::normalize(n);
    const float a = evaluate_local(field, x, n);
    const AoEstimate ref = ambient_occlusion(scene, x, n, std::numeric_limits<float>::infinity(), 1024, rng);
    const double err = std::abs(double(a) - (1.0 - double(ref.value)));
    st.mae += err;
    st.max = std::max(st.max, err);
    ++st.count;
  }
  st.mae /= st.count;
  return st;
}

TEST(AOFieldBake, SphereMatchesRayTracedAO) {
  const MeshData sphere = make_icosphere(1.0f, 3);
  const AOFieldData field = bake(settings(16, 24, 256), sphere);
  ASSERT_EQ(field.texels.size(), 6u * 16u * 16u);
  // The hull of a sphere is itself: r0 close to the radius everywhere.
  for (const AOFieldTexel& t : field.texels) EXPECT_NEAR(t.r0, 1.0f, 0.02f);
  const ErrorStats st = error_outside_hull(field, sphere, 300, [](glm::vec3) { return 1.0f; });
  RecordProperty("mae", std::to_string(st.mae));
  RecordProperty("max_err", std::to_string(st.max));
  EXPECT_LE(st.mae, 0.03) << "max " << st.max;
}

TEST(AOFieldBake, BoxMatchesRayTracedAO) {
  const MeshData box = make_box(glm::vec3(0.5f, 0.3f, 0.4f));
  const AOFieldData field = bake(settings(16, 24, 256), box);
  // The hull of a box is the box: along +X r0 is the half extent.
  const AOFieldTexel& centre_px = field.texels[(0 * 16 + 8) * 16 + 8];
  EXPECT_NEAR(centre_px.r0, 0.5f / glm::length(cube_direction(0, 1.0f / 16.0f, 1.0f / 16.0f).x), 0.01f);
  const glm::vec3 half(0.5f, 0.3f, 0.4f);
  const ErrorStats st = error_outside_hull(field, box, 300, [&](glm::vec3 d) {
    const glm::vec3 t = half / glm::max(glm::abs(d), glm::vec3(1e-6f));
    return std::min({t.x, t.y, t.z});
  });
  RecordProperty("mae", std::to_string(st.mae));
  RecordProperty("max_err", std::to_string(st.max));
  EXPECT_LE(st.mae, 0.03) << "max " << st.max;
}

TEST(AOFieldBake, ExtremesCentreHullAndFalloff) {
  const MeshData sphere = make_icosphere(1.0f, 2);
  const AOFieldData field = bake(settings(8, 12, 128), sphere);
  const glm::vec3 up(0, 1, 0);
  // At the centre: the inside constant.
  EXPECT_FLOAT_EQ(evaluate_local(field, field.centre, up), field.inside_occlusion);
  // On the hull: continuous across it (the blend reaches the hull value at r0).
  for (int k = 0; k < 6; ++k) {
    const glm::vec3 d = cube_direction(static_cast<std::uint32_t>(k), 0.13f, -0.27f);
    const float r0 = 1.0f;  // the sphere's hull; the field's r0 is within 2% of it
    const float in = evaluate_local(field, field.centre + 0.999f * r0 * d, -d);
    const float out = evaluate_local(field, field.centre + 1.02f * r0 * d, -d);
    EXPECT_GE(in, 0.0f);
    EXPECT_LE(in, 1.0f);
    EXPECT_NEAR(in, out, 0.1f);
    // Facing the caster from its surface: close to fully occluded; facing away: nothing.
    EXPECT_GT(out, 0.8f);
    EXPECT_LT(evaluate_local(field, field.centre + 1.02f * r0 * d, d), 0.05f);
  }
  // Beyond the falloff: exactly zero, and it fades monotonically towards it.
  EXPECT_EQ(evaluate_local(field, field.centre + glm::vec3(field.r_far * 1.0001f, 0, 0), glm::vec3(-1, 0, 0)), 0.0f);
  EXPECT_EQ(evaluate_local(field, field.centre + glm::vec3(0, 0, 1e30f), glm::vec3(0, 0, -1)), 0.0f);
  float prev = 1.0f;
  for (int i = 0; i <= 40; ++i) {
    const float r = 1.05f + (field.r_far - 1.05f) * static_cast<float>(i) / 40.0f;
    const float a = evaluate_local(field, field.centre + glm::vec3(0, r, 0), glm::vec3(0, -1, 0));
    EXPECT_LE(a, prev + 1e-3f) << r;
    prev = a;
  }
  // Many casters on one receiver: stays in [0, 1].
  std::vector<float> each;
  for (int i = 0; i < 5000; ++i)
    each.push_back(evaluate_local(field, field.centre + glm::vec3(0, 1.1f + 0.001f * float(i), 0), glm::vec3(0, -1, 0)));
  const float all = combine_occlusion(each);
  EXPECT_GE(all, 0.0f);
  EXPECT_LE(all, 1.0f);
}

TEST(AOFieldBake, FollowsRotationTranslationAndUniformScale) {
  const MeshData box = make_box(glm::vec3(0.5f, 0.2f, 0.3f));
  const AOFieldData field = bake(settings(8, 12, 128), box);
  for (float scale : {1e-3f, 1.0f, 1e4f}) {
    const glm::mat4 m = glm::scale(
        glm::rotate(glm::translate(glm::mat4(1.0f), glm::vec3(5, -3, 2) * scale), 0.8f, glm::vec3(1, 2, -1)),
        glm::vec3(scale));
    Rng rng = Rng::stream(3, 0);
    for (int i = 0; i < 50; ++i) {
      const glm::vec3 xl = field.centre + (0.6f + 2.0f * rng.next_float()) * uniform_sphere({rng.next_float(), rng.next_float()});
      const glm::vec3 nl = uniform_sphere({rng.next_float(), rng.next_float()});
      const glm::vec3 xw = glm::vec3(m * glm::vec4(xl, 1.0f));
      const glm::vec3 nw = glm::normalize(glm::mat3(m) * nl);
      EXPECT_NEAR(evaluate(field, m, xw, nw), evaluate_local(field, xl, nl), 2e-3f) << scale;
    }
  }
}

TEST(AOFieldBake, ScaledMeshGivesTheSameRelativeField) {
  // A mesh 1e-3 and 1e4 times the size bakes the same field up to the scale (the fit runs in units
  // of the bounding radius; ray offsets scale with it).
  const AOFieldData unit = bake(settings(4, 8, 64), make_box(glm::vec3(0.5f, 0.2f, 0.3f)));
  for (float s : {1e-3f, 1e4f}) {
    const AOFieldData scaled = bake(settings(4, 8, 64), make_box(glm::vec3(0.5f, 0.2f, 0.3f) * s));
    for (int i = 0; i < 20; ++i) {
      const glm::vec3 d = cube_direction(static_cast<std::uint32_t>(i % 6), 0.3f, -0.1f * float(i % 4));
      const glm::vec3 n = glm::normalize(-d + glm::vec3(0.2f, 0.1f, 0.0f));
      const float r = 0.7f + 0.1f * float(i);
      EXPECT_NEAR(evaluate_local(scaled, scaled.centre + r * s * d, n), evaluate_local(unit, unit.centre + r * d, n),
                  0.02f)
          << s;
    }
  }
}

TEST(AOFieldBake, FlatCasterAndNeedle) {
  // A plane: the hull is flat, so every point off it is outside; just above its middle, facing
  // it, the plane covers nearly the whole hemisphere.
  const MeshData quad = make_quad(2.0f, 2.0f);
  const AOFieldData plane = bake(settings(8, 16, 128), quad);
  const float near = evaluate_local(plane, plane.centre + glm::vec3(0, 0, 0.05f), glm::vec3(0, 0, -1));
  EXPECT_GT(near, 0.85f);
  EXPECT_LE(near, 1.0f);
  // A needle: thin, tiny solid angle from the side.
  const MeshData needle = make_cylinder(0.005f, 2.0f, 8);
  const AOFieldData thin = bake(settings(8, 16, 128), needle);
  Rng rng = Rng::stream(5, 1);
  for (int i = 0; i < 200; ++i) {
    const glm::vec3 x = thin.centre + (0.05f + 3.0f * rng.next_float()) * uniform_sphere({rng.next_float(), rng.next_float()});
    const float a = evaluate_local(thin, x, uniform_sphere({rng.next_float(), rng.next_float()}));
    EXPECT_TRUE(a >= 0.0f && a <= 1.0f);
  }
  const float side = evaluate_local(thin, thin.centre + glm::vec3(1.0f, 0, 0), glm::vec3(-1, 0, 0));
  EXPECT_LT(side, 0.05f);
  for (const AOFieldTexel& t : thin.texels) {
    EXPECT_GE(t.r0, 0.0f);
    const float d0 = (t.a * t.r0 + t.b) * t.r0 + t.c;
    const float d1 = (t.a * thin.r_far + t.b) * thin.r_far + t.c;
    EXPECT_GT(d0, 0.0f);  // the denominator stays positive on [r0, r_far]
    EXPECT_GT(d1, 0.0f);
  }
}

TEST(AOFieldBake, BitIdenticalAtOneAndTwoThreads) {
  const MeshData box = make_box(glm::vec3(0.5f, 0.2f, 0.3f));
  const AOFieldData a = bake(settings(4, 8, 64), box, 1);
  const AOFieldData b = bake(settings(4, 8, 64), box, 2);
  ASSERT_EQ(a.texels.size(), b.texels.size());
  EXPECT_EQ(std::memcmp(a.texels.data(), b.texels.data(), a.texels.size() * sizeof(AOFieldTexel)), 0);
  const AOFieldData c = bake(settings(4, 8, 64), box, 2, 8);
  EXPECT_NE(std::memcmp(a.texels.data(), c.texels.data(), a.texels.size() * sizeof(AOFieldTexel)), 0);
}

TEST(AOFieldBake, RejectsEmptyMeshAndShortFalloff) {
  JobContext jobs;
  MemoryBudget budget;
  MeshData empty;
  auto e = bake_ao_field(AOFieldCaster{}, empty, 1, jobs, budget, "ao field 'empty'");
  ASSERT_FALSE(e.ok());
  EXPECT_NE(e.error().message.find("ao field 'empty'"), std::string::npos);
  AOFieldCaster c = settings(4, 8, 64);
  c.falloff_distance = 0.1f;
  auto f = bake_ao_field(c, make_box(glm::vec3(1.0f)), 1, jobs, budget, "ao field 'short'");
  ASSERT_FALSE(f.ok());
  EXPECT_NE(f.error().message.find("falloff_distance"), std::string::npos);
  MemoryBudget tiny(64);
  auto g = bake_ao_field(settings(4, 8, 64), make_box(glm::vec3(1.0f)), 1, jobs, tiny, "ao field 'big'");
  ASSERT_FALSE(g.ok());
  EXPECT_EQ(g.error().code, ErrorCode::OutOfBudget);
}

TEST(AOFieldBake, ChunkRoundTripAndCorruption) {
  AOFieldData field = bake(settings(4, 8, 64), make_box(glm::vec3(0.5f)));
  field.key = "crates/crate a";
  const BakeChunk chunk = write_ao_field_chunk(field);
  EXPECT_EQ(chunk.label, "ao-field:crates/crate a");
  auto back = read_ao_field_chunk(chunk);
  ASSERT_TRUE(back.ok()) << back.error().message;
  EXPECT_EQ(back->key, "crates/crate a");
  EXPECT_EQ(back->resolution, field.resolution);
  EXPECT_EQ(std::memcmp(back->texels.data(), field.texels.data(), field.texels.size() * sizeof(AOFieldTexel)), 0);
  EXPECT_FALSE(describe_ao_field_chunk(chunk).empty());
  // A NaN in a texel, a truncated payload and a wrong version are reported, naming the chunk.
  AOFieldData broken = field;
  broken.texels[3].c = std::nanf("");
  auto nan = read_ao_field_chunk(write_ao_field_chunk(broken));
  ASSERT_FALSE(nan.ok());
  EXPECT_NE(nan.error().message.find("texel 3"), std::string::npos);
  // A falloff distance of 1e38 (finite, but the field would darken the whole world) is refused.
  AOFieldData far = field;
  far.r_far = 1e38f;
  auto huge = read_ao_field_chunk(write_ao_field_chunk(far));
  ASSERT_FALSE(huge.ok());
  EXPECT_NE(huge.error().message.find("above 1e6"), std::string::npos) << huge.error().message;
  BakeChunk cut = chunk;
  cut.payload.resize(cut.payload.size() - 5);
  EXPECT_FALSE(read_ao_field_chunk(cut).ok());
  BakeChunk future = chunk;
  future.version = 99;
  auto v = read_ao_field_chunk(future);
  ASSERT_FALSE(v.ok());
  EXPECT_EQ(v.error().code, ErrorCode::Unsupported);
}

TEST(AOFieldBake, BakerThroughBakeWorldAndAttach) {
  World w;
  register_ao_field_system(w);
  register_ao_field_baker(w);
  const Entity crate = w.create();
  w.add<Name>(crate, Name{"crate"});
  w.add<Mesh>(crate, Mesh{std::make_shared<const MeshData>(make_box(glm::vec3(0.5f)))});
  w.add<WorldTransform>(crate, WorldTransform{glm::translate(glm::mat4(1.0f), glm::vec3(0, 0.5f, 0))});
  w.add<AOFieldCaster>(crate, settings(4, 8, 64));
  JobContext jobs;
  auto result = bake_world(w, {"ao-field"}, BakeSettings{}, jobs);
  ASSERT_TRUE(result.ok()) << result.error().message;
  const BakeChunk* chunk = result->file.find(fourcc("AOFC"));
  ASSERT_NE(chunk, nullptr);
  ASSERT_NE(w.get<AOFieldCaster>(crate).data, nullptr);
  // A receiver on the floor just beside the crate is shadowed; one far away is not.
  const glm::mat4& m = w.get<WorldTransform>(crate).matrix;
  const AOFieldData& field = *w.get<AOFieldCaster>(crate).data;
  EXPECT_GT(evaluate(field, m, glm::vec3(0.6f, 0.0f, 0.0f), glm::vec3(0, 1, 0)), 0.1f);
  EXPECT_EQ(evaluate(field, m, glm::vec3(100.0f, 0.0f, 0.0f), glm::vec3(0, 1, 0)), 0.0f);
  // Attach to a fresh component.
  w.patch<AOFieldCaster>(crate).data = nullptr;
  ASSERT_TRUE(attach_bake(w, result->file).ok());
  EXPECT_NE(w.get<AOFieldCaster>(crate).data, nullptr);
  // Non-uniform scale: the bake fails naming the entity and the fix.
  w.patch<WorldTransform>(crate).matrix = glm::scale(glm::mat4(1.0f), glm::vec3(1, 2, 1));
  auto bad = bake_world(w, {"ao-field"}, BakeSettings{}, jobs);
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(bad.error().message.find("non-uniform scale"), std::string::npos);
  EXPECT_NE(bad.error().message.find("entity " + std::to_string(crate.index)), std::string::npos);
}

}  // namespace
}  // namespace penumbra
