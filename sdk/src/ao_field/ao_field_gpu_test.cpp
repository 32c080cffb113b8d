// The GPU layout of ambient occlusion fields: the buffer's documented layout, the reference
// evaluation from the buffer alone against the CPU evaluation of the same casters (radial fit and
// grid, rotated, translated, scaled), and packing errors.
#include "penumbra/ao_field/ao_field_gpu.h"

#include <gtest/gtest.h>

#include <memory>
#include <vector>

#include <glm/geometric.hpp>
#include <glm/gtc/matrix_transform.hpp>

#include "penumbra/ao_field/ao_field_baker.h"
#include "penumbra/core/random.h"
#include "penumbra/core/sampling.h"
#include "penumbra/ecs/transform.h"
#include "penumbra/scene/mesh.h"

namespace penumbra {
namespace {

AOFieldData bake(const AOFieldCaster& c, const MeshData& mesh) {
  JobContext jobs;
  MemoryBudget budget;
  auto d = bake_ao_field(c, mesh, 5, jobs, budget);
  EXPECT_TRUE(d.ok());
  return d.ok() ? std::move(*d) : AOFieldData{};
}

struct Fixture {
  AOFieldData radial, grid;
  std::vector<AOFieldGpuCaster> casters;
  Fixture() {
    AOFieldCaster r;
    r.resolution = 8;
    r.radial_samples = 8;
    r.rays_per_sample = 64;
    radial = bake(r, make_box(glm::vec3(0.5f, 0.3f, 0.4f)));
    AOFieldCaster g;
    g.representation = AOFieldRepresentation::Grid;
    g.grid_size = 12;
    g.rays_per_sample = 32;
    grid = bake(g, make_icosphere(0.6f, 2));
    casters.push_back({&radial, glm::translate(glm::mat4(1.0f), glm::vec3(0, 0.3f, 0))});
    casters.push_back({&grid, glm::scale(glm::rotate(glm::translate(glm::mat4(1.0f), glm::vec3(1.5f, 0.6f, 0.2f)), 0.9f,
                                                     glm::vec3(0, 1, 1)),
                                         glm::vec3(1.3f))});
    casters.push_back({&radial, glm::scale(glm::rotate(glm::translate(glm::mat4(1.0f), glm::vec3(-0.8f, 0.5f, 1.2f)),
                                                       2.1f, glm::vec3(1, 0, 0.3f)),
                                           glm::vec3(0.7f))});
  }
};

TEST(AOFieldGpu, LayoutIsAsDocumented) {
  const Fixture f;
  auto packed = pack_ao_fields_gpu(f.casters);
  ASSERT_TRUE(packed.ok()) << packed.error().message;
  const std::vector<glm::vec4>& d = packed->data;
  EXPECT_EQ(packed->casters, 3u);
  EXPECT_EQ(d[0].x, 3.0f);
  EXPECT_EQ(d[0].z, float(kCapTableIntervals + 1));
  const std::size_t table = static_cast<std::size_t>(d[0].y);
  const std::span<const float> values = cap_occlusion_table_values();
  for (std::size_t q = 0; q < values.size(); q += 97) EXPECT_EQ(d[table + q / 4][static_cast<int>(q % 4)], values[q]);
  EXPECT_EQ(d.size(), table + (values.size() + 3) / 4);
  // Caster 0: the radial field at a translation; its texel 5 where the record says.
  EXPECT_EQ(d[1 + 3], glm::vec4(f.radial.centre, f.radial.r_far));
  EXPECT_EQ(d[1 + 4].w, 0.0f);
  EXPECT_EQ(d[1 + 5].x, float(f.radial.resolution));
  const std::size_t off = static_cast<std::size_t>(d[1 + 5].y);
  const AOFieldTexel& t = f.radial.texels[5];
  EXPECT_EQ(d[off + 10], glm::vec4(t.a, t.b, t.c, t.r0));
  EXPECT_EQ(d[off + 11], glm::vec4(t.c0, 0.0f));
  EXPECT_NEAR(d[1 + 0].w, -0.0f, 1e-7f);
  EXPECT_NEAR(d[1 + 1].w, -0.3f, 1e-7f);  // world-to-local undoes the translation
  // Caster 1: the grid; vertex 7.
  EXPECT_EQ(d[8 + 4].w, 1.0f);
  const std::size_t goff = static_cast<std::size_t>(d[8 + 5].y);
  EXPECT_EQ(d[goff + 7], glm::vec4(f.grid.nodes[7].omega, f.grid.nodes[7].weighted_direction));
  EXPECT_NEAR(d[8 + 6].w, f.grid.r_far * 1.3f, 1e-4f);  // the reach in world units
  EXPECT_EQ(packed->bytes(), d.size() * 16u);
}

TEST(AOFieldGpu, BufferEvaluationMatchesTheCpu) {
  const Fixture f;
  auto packed = pack_ao_fields_gpu(f.casters);
  ASSERT_TRUE(packed.ok());
  Rng rng = Rng::stream(12, 0);
  double worst = 0.0;
  int shaded = 0;
  for (int i = 0; i < 3000; ++i) {
    const glm::vec3 x(-3.0f + 6.0f * rng.next_float(), -0.5f + 3.0f * rng.next_float(), -3.0f + 6.0f * rng.next_float());
    const glm::vec3 n = uniform_sphere({rng.next_float(), rng.next_float()});
    float open = 1.0f;
    for (const AOFieldGpuCaster& c : f.casters) {
      const glm::mat4 to_local = glm::inverse(c.world);
      accumulate_open(*c.field, to_local, std::span<const glm::vec3>(&x, 1), std::span<const glm::vec3>(&n, 1),
                      std::span<float>(&open, 1));
    }
    const float cpu = 1.0f - open;
    const float gpu = evaluate_packed(*packed, x, n);
    worst = std::max(worst, double(std::abs(cpu - gpu)));
    if (cpu > 0.01f) ++shaded;
  }
  RecordProperty("max_abs_difference", std::to_string(worst));
  EXPECT_LT(worst, 2e-5);  // measured 1e-6
  EXPECT_GT(shaded, 300);  // the points do fall within the casters' reach
}

TEST(AOFieldGpu, PackingErrorsAndEdgeCases) {
  const Fixture f;
  // Null and unbaked fields are skipped; an empty list packs the header and the table.
  const AOFieldData empty;
  std::vector<AOFieldGpuCaster> some = {{nullptr, glm::mat4(1.0f)}, {&empty, glm::mat4(1.0f)}, f.casters[0]};
  auto packed = pack_ao_fields_gpu(some);
  ASSERT_TRUE(packed.ok());
  EXPECT_EQ(packed->casters, 1u);
  auto none = pack_ao_fields_gpu(std::span<const AOFieldGpuCaster>());
  ASSERT_TRUE(none.ok());
  EXPECT_EQ(evaluate_packed(*none, glm::vec3(0.0f), glm::vec3(0, 1, 0)), 0.0f);
  // A singular matrix is an error naming the caster.
  some[2].world = glm::scale(glm::mat4(1.0f), glm::vec3(0.0f));
  auto bad = pack_ao_fields_gpu(some);
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(bad.error().message.find("caster 2"), std::string::npos);
  // A truncated buffer evaluates to 0 instead of reading past its end.
  auto full = pack_ao_fields_gpu(f.casters);
  ASSERT_TRUE(full.ok());
  AOFieldGpuBuffer cut = *full;
  cut.data.resize(cut.data.size() / 2);
  EXPECT_EQ(evaluate_packed(cut, glm::vec3(0.6f, 0.0f, 0.0f), glm::vec3(0, 1, 0)), 0.0f);
  EXPECT_EQ(evaluate_packed(AOFieldGpuBuffer{}, glm::vec3(0.6f, 0.0f, 0.0f), glm::vec3(0, 1, 0)), 0.0f);
}

}  // namespace
}  // namespace penumbra
