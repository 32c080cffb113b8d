// Probe-grid bake (see probe_grid_baker.h): Kontkanen & Laine 2006, "Sampling Precomputed Volumetric
// Lighting", section 3 (supersampling over the trilinear basis functions, the domain of interest)
// against the point-sampled irradiance volume of Greger et al. 1998.
#include "penumbra/probe_grid/probe_grid_baker.h"

#include "penumbra/bake/baker.h"
#include "penumbra/bake/light_sampling.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <string>

#include <glm/common.hpp>
#include <glm/geometric.hpp>
#include <glm/matrix.hpp>

#include "penumbra/core/random.h"
#include "penumbra/core/sampling.h"
#include "penumbra/core/sh.h"
#include "penumbra/ecs/transform.h"
#include "penumbra/probe_grid/probe_grid_system.h"
#include "penumbra/scene/entity_key.h"
#include "probe_fit.h"

namespace penumbra {

namespace {

constexpr float kPi = 3.14159265358979323846f;
constexpr float kInf = std::numeric_limits<float>::infinity();
constexpr std::uint32_t kRectLightSamples = 16;
constexpr std::uint32_t kRayBlock = 64;  // rays traced per packet call (four packets of 16)

// Incident radiance from the lights at free point y, projected: each light sample is a delta in
// direction l carrying its irradiance at normal incidence (light models: light_sampling.h).
void add_lights(const RayScene& scene, std::span<const WorldLight> lights, glm::vec3 y, Rng& rng, SH9rgb& sh) {
  for_each_light_sample(scene, lights, y, y, glm::vec3(0.0f), kRectLightSamples, rng,
                        [&](glm::vec3 l, glm::vec3 e) { sh_add_sample(sh, l, e); });
}

// What one sample point contributes: its radiance expansion and whether it is in the domain.
struct PointSample {
  SH9rgb radiance;
  bool in_domain = false;
};

struct SampleSettings {
  std::uint32_t rays = 0;
  float back_face_threshold = 0.0f;
  bool skip_outside = false;  // do not shade points outside the domain (supersampled mode)
  IrradianceSettings hit;     // the integrator at ray hits (all the light that reaches them)
  bool shade_hits = true;     // bounces > 0
  bool direct = true;         // LightingContent::All: the lights and the hits' emission at y
};

// Radiance SH at y: stratified rays over the sphere (first pass: closest hits, which also decide
// the domain), then emission + albedo / pi x irradiance at each hit, plus the lights. Indirect
// content keeps only the reflected part (no emission at the hits, no lights at y).
PointSample sample_point(const RayScene& scene, std::span<const WorldLight> lights, glm::vec3 y,
                         const SampleSettings& s, Rng& rng) {
  PointSample out;
  const std::uint32_t scramble = rng.next_u32();
  const float weight = 4.0f * kPi / float(s.rays);  // 1 / (pdf x count), uniform sphere
  std::array<Ray, kRayBlock> rays;
  std::array<Hit, kRayBlock> hits;
  std::array<std::uint8_t, kRayBlock> mask{};
  // Closest hits of every ray, block by block; hits are kept for shading.
  std::vector<Hit> all_hits(s.rays);
  std::vector<std::uint8_t> all_mask(s.rays, 0);
  std::uint32_t back = 0;
  for (std::uint32_t first = 0; first < s.rays; first += kRayBlock) {
    const std::uint32_t count = std::min(kRayBlock, s.rays - first);
    for (std::uint32_t i = 0; i < count; ++i)
      rays[i] = Ray{y, 0.0f, uniform_sphere(sobol_2d(first + i, scramble)), kInf};
    scene.intersect(std::span<const Ray>(rays.data(), count), std::span<Hit>(hits.data(), count),
                    std::span<std::uint8_t>(mask.data(), count));
    for (std::uint32_t i = 0; i < count; ++i) {
      all_mask[first + i] = mask[i];
      if (!mask[i]) continue;
      all_hits[first + i] = hits[i];
      if (hits[i].back_face && !hits[i].material.double_sided) ++back;
    }
  }
  // Domain of interest: no more than the threshold's fraction of back-face hits.
  out.in_domain = float(back) <= s.back_face_threshold * float(s.rays);
  if (!out.in_domain && s.skip_outside) return out;

  for (std::uint32_t i = 0; i < s.rays; ++i) {
    if (!all_mask[i]) continue;  // no sky: an escaping ray brings nothing
    const Hit& h = all_hits[i];
    const glm::vec3 dir = uniform_sphere(sobol_2d(i, scramble));
    glm::vec3 radiance(0.0f);
    if (s.direct && (!h.back_face || h.material.double_sided)) radiance += h.material.emissive;
    if (s.shade_hits && h.material.albedo != glm::vec3(0.0f)) {
      const glm::vec3 p = y + h.t * dir;
      const glm::vec3 n = h.back_face ? -h.normal : h.normal;
      const Estimate e = irradiance(scene, lights, p, n, s.hit, rng);
      radiance += h.material.albedo * (e.value / kPi);
    }
    if (radiance != glm::vec3(0.0f)) sh_add_sample(out.radiance, dir, radiance * weight);
  }
  if (s.direct) add_lights(scene, lights, y, rng, out.radiance);
  return out;
}

// Per axis tent offset in cells: xi1 + xi2 - 1 has the density max(0, 1 - |t|) on [-1, 1]
// (the node's trilinear basis B_i). xi from an Owen-scrambled (0,2)-net, one scramble per axis.
// `fold` (fitted mode) keeps the points in the grid's box, the only region the fit measures
// (receivers are clamped to the box): on a boundary node's outer axis the offset is folded inwards
// (|t| has the density 2 (1 - |t|) on [0, 1], the tent's inner half), so none of the node's rays
// is spent outside the box; probe_fit_weight() undoes the extra density in the boundary cells.
// Supersampled mode keeps the paper's whole tent: its average over a half tent would be biased a
// third of a cell inwards wherever the lighting has a gradient across the box's face.
glm::vec3 tent_offset(std::uint32_t k, const std::array<std::uint32_t, 3>& scrambles, glm::uvec3 ijk,
                      glm::uvec3 res, bool fold) {
  glm::vec3 t;
  for (int a = 0; a < 3; ++a) {
    const glm::vec2 u = sobol_2d(k, scrambles[static_cast<std::size_t>(a)]);
    t[a] = u.x + u.y - 1.0f;
    if (fold && ijk[a] == 0) t[a] = std::abs(t[a]);
    if (fold && ijk[a] + 1 == res[a]) t[a] = -std::abs(t[a]);
  }
  return t;
}

// Leak guard (probe_grid.h): node n's reach along the six grid axis directions, the closest hit
// within one spacing in units of the spacing, quantised to 0..255 (rounded down, so a surface is
// never reported farther than it is). A node inside a thick solid (its rays hit only back faces,
// and on no axis both ways: a block's interior near a face) is left open on every side: the
// paper's in-domain average extrapolates the light outside the block into it, which is what the
// receivers outside need. A node inside a thin solid (back faces both ways along an axis: a wall
// thinner than a cell) stays hidden, since its tent takes light from both sides of the wall.
void trace_reach(const RayScene& scene, const ProbeGridLayout& layout, glm::uvec3 ijk, std::uint8_t* out) {
  const glm::mat3 axes(layout.grid_to_world);
  std::array<Ray, 6> rays;
  std::array<Hit, 6> hits;
  std::array<std::uint8_t, 6> mask{};
  const glm::vec3 x = layout.node_position(ijk);
  for (int d = 0; d < 6; ++d) {
    const int a = d / 2;
    const glm::vec3 dir = glm::normalize(axes[a]) * (d % 2 ? -1.0f : 1.0f);
    rays[static_cast<std::size_t>(d)] = Ray{x, 0.0f, dir, layout.spacing[a]};
  }
  scene.intersect(rays, hits, mask);
  bool front = false, back = false, thin = false;
  for (int d = 0; d < 6; ++d) {
    const std::size_t i = static_cast<std::size_t>(d);
    const bool back_face = mask[i] && hits[i].back_face && !hits[i].material.double_sided;
    front = front || (mask[i] && !back_face);
    back = back || back_face;
    if (d % 2 == 1 && back_face) {
      const Hit& other = hits[i - 1];
      thin = thin || (mask[i - 1] && other.back_face && !other.material.double_sided);
    }
    const float t = mask[i] ? std::clamp(hits[i].t / layout.spacing[d / 2], 0.0f, 1.0f) : 1.0f;
    out[i] = static_cast<std::uint8_t>(std::floor(t * 255.0f));
  }
  if (back && !front && !thin) std::fill(out, out + 6, std::uint8_t{255});
}

// Fill nodes without an in-domain sample from valid neighbours, one 26-neighbourhood ring per
// pass (Jacobi passes, so the result does not depend on visiting order). Weights: the coverage of
// valid neighbours, 1/4 for neighbours filled in an earlier pass. Returns false if cancelled.
bool dilate(const ProbeGridLayout& layout, std::vector<SH9rgb>& values, std::vector<float>& validity,
            std::vector<std::uint8_t>& filled, JobContext& jobs) {
  const glm::ivec3 res(layout.resolution);
  std::vector<float> known(validity);  // weight of each node as a source (0: unknown)
  std::size_t unknown = static_cast<std::size_t>(std::count(known.begin(), known.end(), 0.0f));
  jobs.begin_stage("probe fill", unknown);
  while (unknown > 0) {
    if (jobs.cancelled()) return false;
    std::vector<std::size_t> newly;
    std::vector<SH9rgb> next_values;
    for (int z = 0; z < res.z; ++z)
      for (int y = 0; y < res.y; ++y)
        for (int x = 0; x < res.x; ++x) {
          const std::size_t n = layout.node_index(glm::uvec3(x, y, z));
          if (known[n] > 0.0f) continue;
          SH9rgb sum;
          float wsum = 0.0f;
          for (int dz = -1; dz <= 1; ++dz)
            for (int dy = -1; dy <= 1; ++dy)
              for (int dx = -1; dx <= 1; ++dx) {
                const glm::ivec3 q(x + dx, y + dy, z + dz);
                if (q.x < 0 || q.y < 0 || q.z < 0 || q.x >= res.x || q.y >= res.y || q.z >= res.z) continue;
                const std::size_t m = layout.node_index(glm::uvec3(q));
                if (known[m] > 0.0f) {
                  sum += values[m] * known[m];
                  wsum += known[m];
                }
              }
          if (wsum > 0.0f) {
            newly.push_back(n);
            next_values.push_back(sum * (1.0f / wsum));
          }
        }
    for (std::size_t i = 0; i < newly.size(); ++i) {
      values[newly[i]] = next_values[i];
      known[newly[i]] = 0.25f;
      filled[newly[i]] = 1;
    }
    unknown -= newly.size();
    jobs.advance(newly.size());
  }
  return true;
}

}  // namespace

Result<ProbeGridData> bake_probe_grid(const IrradianceProbeGrid& grid, const glm::mat4& world_matrix,
                                      const RayScene& scene, std::span<const WorldLight> lights, std::uint64_t seed,
                                      JobContext& jobs, MemoryBudget& budget, std::string_view context) {
  auto layout = probe_grid_layout(grid, world_matrix, context);
  if (!layout) return layout.error();
  const std::size_t nodes = layout->node_count();
  const std::size_t count = static_cast<std::size_t>(sh_coefficients(grid.sh_order));

  const bool point = grid.sampling == ProbeSampling::Point;
  const bool fitted = grid.sampling == ProbeSampling::Fitted;
  const std::size_t S = grid.samples_per_node;
  const std::size_t columns = count * 3;  // fitted: one least-squares column per coefficient and channel

  // Memory: the working expansions plus the stored arrays, checked before allocating; fitted mode
  // also keeps every sample (position, domain flag, coefficients) and the solver's arrays.
  const std::uint64_t reach_bytes = grid.leak_guard ? 6 : 0;
  std::uint64_t need =
      std::uint64_t{nodes} * (sizeof(SH9rgb) + count * sizeof(glm::vec3) + sizeof(float) + 1 + reach_bytes);
  if (fitted)
    need += std::uint64_t{nodes} * S * (sizeof(glm::vec3) * (grid.leak_guard ? 2 : 1) + 1 + columns * sizeof(float)) +
            std::uint64_t{nodes} * columns * sizeof(float) + probe_fit_bytes(nodes, columns);
  if (auto st = budget.reserve(std::string(context) + " nodes", need); !st)
    return make_error(ErrorCode::OutOfBudget, st.error().message + " (" + std::to_string(layout->resolution.x) + "x" +
                                                  std::to_string(layout->resolution.y) + "x" +
                                                  std::to_string(layout->resolution.z) +
                                                  " nodes; use a larger spacing or a smaller box)");
  struct Release {
    MemoryBudget& b;
    std::uint64_t n;
    ~Release() { b.release(n); }
  } release{budget, need};

  ProbeGridData data;
  data.layout = *layout;
  data.sh_order = grid.sh_order;
  data.sampling = grid.sampling;
  data.lighting = grid.lighting;
  std::vector<SH9rgb> radiance(nodes);
  data.validity.assign(nodes, 0.0f);
  data.filled.assign(nodes, 0);
  std::vector<glm::vec3> sample_position(fitted ? nodes * S : 0);
  std::vector<std::uint8_t> sample_in_domain(fitted ? nodes * S : 0);
  std::vector<float> sample_values(fitted ? nodes * S * columns : 0);
  std::vector<glm::vec3> sample_lookup(fitted && grid.leak_guard ? nodes * S : 0);

  SampleSettings s;
  s.rays = point ? grid.samples_per_node * grid.rays_per_sample : grid.rays_per_sample;
  s.back_face_threshold = grid.back_face_threshold;
  s.skip_outside = !point;
  s.shade_hits = grid.bounces > 0;
  s.direct = grid.lighting == LightingContent::All;
  s.hit.samples = grid.hit_samples;
  s.hit.reference = grid.bounces == kProbeAllBounces;
  s.hit.bounces = grid.bounces > 0 ? grid.bounces - 1 : 0;
  s.hit.rect_light_samples = kRectLightSamples;
  const glm::uvec3 res = layout->resolution;
  const glm::vec3 cell = 1.0f / glm::vec3(res - 1u);

  // Step 0 (leak guard): every node's reach, which step 1 needs around each node (6 rays a node;
  // the first stage counts each node once for it and once for its samples).
  jobs.begin_stage("probe samples", grid.leak_guard ? 2 * nodes : nodes);
  if (grid.leak_guard) {
    data.reach.assign(nodes * 6, 0);
    const Status reached = jobs.parallel_for(nodes, 64, [&](std::size_t begin, std::size_t end) {
      for (std::size_t n = begin; n < end; ++n)
        trace_reach(scene, *layout, glm::uvec3(n % res.x, (n / res.x) % res.y, n / (std::size_t{res.x} * res.y)),
                    &data.reach[6 * n]);
    });
    if (!reached) return reached.error();
  }

  // Step 1: per node, radiance SH from its sample points (node n from its own stream).
  const Status traced = jobs.parallel_for(nodes, 4, [&](std::size_t begin, std::size_t end) {
    for (std::size_t n = begin; n < end; ++n) {
      Rng rng = Rng::stream(seed, n);
      const glm::uvec3 ijk(n % res.x, (n / res.x) % res.y, n / (std::size_t{res.x} * res.y));
      const glm::vec3 u = glm::vec3(ijk) * cell;
      if (point) {
        // The classic irradiance volume: everything at the node.
        const PointSample p = sample_point(scene, lights, layout->node_position(ijk), s, rng);
        radiance[n] = p.radiance;
        data.validity[n] = p.in_domain ? 1.0f : 0.0f;
        continue;
      }
      // Supersampling: S points from the tent B_i, averaged over those in the domain (and, with
      // the leak guard, seen by the node); fitted mode keeps each one for the least-squares step,
      // with the lookup fraction the runtime will use for it.
      const std::array<std::uint32_t, 3> scrambles{rng.next_u32(), rng.next_u32(), rng.next_u32()};
      SH9rgb sum;
      std::uint32_t inside = 0;
      for (std::uint32_t k = 0; k < grid.samples_per_node; ++k) {
        const glm::vec3 t = tent_offset(k, scrambles, ijk, res, fitted);
        // The lookup's test (probe_node_sees): a node averages only what it will be used for.
        const bool seen = !grid.leak_guard || probe_node_sees(&data.reach[6 * n], t);
        if (!seen && !fitted) continue;  // supersampled: no rays for a point the node never serves
        const glm::vec3 y(layout->grid_to_world * glm::vec4(u + t * cell, 1.0f));
        const PointSample p = sample_point(scene, lights, y, s, rng);
        if (fitted) {
          const std::size_t i = n * S + k;
          const glm::vec3 at = glm::vec3(ijk) + t;
          sample_position[i] = at;
          sample_in_domain[i] = p.in_domain ? 1 : 0;
          for (std::size_t c = 0; c < columns; ++c)
            sample_values[i * columns + c] = p.radiance[static_cast<int>(c / 3)][static_cast<int>(c % 3)];
          if (grid.leak_guard) {
            const glm::uvec3 base = probe_fit_cell(at, res);
            sample_lookup[i] = probe_lookup_fraction(data, base, at - glm::vec3(base), glm::vec3(0.0f));
          }
        }
        if (!p.in_domain || !seen) continue;
        sum += p.radiance;
        ++inside;
      }
      data.validity[n] = float(inside) / float(grid.samples_per_node);
      if (inside > 0) radiance[n] = sum * (1.0f / float(inside));
    }
  });
  if (!traced) return traced.error();

  // Step 2: fill nodes with no in-domain sample (supersampled and fitted; point mode keeps the
  // classic values).
  if (!point) {
    if (std::all_of(data.validity.begin(), data.validity.end(), [](float v) { return v == 0.0f; }))
      return make_error(ErrorCode::InvalidInput,
                        std::string(context) + ": no node has a sample in the domain of interest (every probe is "
                                               "inside geometry or sees back faces); move or enlarge the grid, or "
                                               "raise back_face_threshold for open geometry");
    if (!dilate(*layout, radiance, data.validity, data.filled, jobs))
      return make_error(ErrorCode::Cancelled, std::string(context) + ": the bake was cancelled");
  } else {
    jobs.begin_stage("probe fill", 1);
    jobs.advance(1);
  }

  // Step 3 (fitted): the node values that minimise the reconstruction error over the in-domain
  // samples, pulled towards the averages of steps 1-2 where support is thin (probe_fit.h).
  if (fitted) {
    std::vector<float> values(nodes * columns);
    for (std::size_t n = 0; n < nodes; ++n)
      for (std::size_t c = 0; c < columns; ++c)
        values[n * columns + c] = radiance[n][static_cast<int>(c / 3)][static_cast<int>(c % 3)];
    ProbeFitInput input;
    input.resolution = layout->resolution;
    input.samples_per_node = grid.samples_per_node;
    input.columns = columns;
    input.positions = sample_position;
    input.in_domain = sample_in_domain;
    input.values = sample_values;
    input.lookup = sample_lookup;
    auto fit = fit_probe_nodes(input, values, ProbeFitSettings{}, jobs);
    if (!fit) return make_error(fit.error().code, std::string(context) + ": " + fit.error().message);
    for (std::size_t n = 0; n < nodes; ++n)
      for (std::size_t c = 0; c < columns; ++c)
        radiance[n][static_cast<int>(c / 3)][static_cast<int>(c % 3)] = values[n * columns + c];
  } else {
    jobs.begin_stage("probe fit", 0);
  }

  // Step 4: irradiance = radiance convolved with the clamped cosine (optionally windowed).
  data.coefficients.resize(nodes * count);
  for (std::size_t n = 0; n < nodes; ++n) {
    SH9rgb e = sh_convolve_cosine(radiance[n]);
    if (grid.deringing_window > 0.0f) e = sh_apply_window(e, sh_lanczos_window(grid.deringing_window));
    for (std::size_t c = 0; c < count; ++c) data.coefficients[n * count + c] = e[static_cast<int>(c)];
  }
  return data;
}

namespace {

// The grids to bake, in entity-index order.
std::vector<Entity> grid_entities(World& world) {
  return world.view<IrradianceProbeGrid, WorldTransform>().sorted_entities();
}

std::string grid_context(World& world, Entity e) {
  const Name* name = world.try_get<Name>(e);
  return "probe grid " + (name ? "'" + name->value + "' " : std::string()) + "(entity " + std::to_string(e.index) +
         ")";
}

Result<std::vector<BakeChunk>> bake_probes(BakeInputs& in) {
  const std::vector<Entity> entities = grid_entities(in.world);
  auto keys = bake_keys(in, entities, "probe grid");
  if (!keys) return keys.error();
  const std::vector<WorldLight> lights = gather_lights(in.world);
  std::vector<BakeChunk> chunks;
  for (std::size_t i = 0; i < entities.size(); ++i) {
    const Entity e = entities[i];
    const IrradianceProbeGrid grid = in.world.get<IrradianceProbeGrid>(e);
    auto data = bake_probe_grid(grid, in.world.get<WorldTransform>(e).matrix, in.rays, lights, in.settings.seed,
                                in.jobs, in.budget, grid_context(in.world, e));
    if (!data) return data.error();
    data->key = std::move((*keys)[i]);
    chunks.push_back(write_probe_grid_chunk(*data));
    in.world.patch<IrradianceProbeGrid>(e).data = std::make_shared<const ProbeGridData>(std::move(*data));
  }
  return chunks;
}

void hash_probe_inputs(World& world, const BakeSettings&, Hasher& h) {
  h.add(kProbeGridChunkVersion);
  for (Entity e : grid_entities(world)) {
    const IrradianceProbeGrid& g = world.get<IrradianceProbeGrid>(e);
    h.add(std::string_view(entity_key(world, e)));
    hash_fields(irradiance_probe_grid_info(), &g, h);
    h.add(world.get<WorldTransform>(e).matrix);
  }
}

}  // namespace

void register_probe_grid_baker(World& world) {
  Baker b = baker_for(probe_grid_module());
  b.stages = 3;  // per grid (samples, fill, fit); a scene usually has one
  b.hash_inputs = hash_probe_inputs;
  b.bake = bake_probes;
  world.resource<BakerRegistry>().add(std::move(b));
}

}  // namespace penumbra
