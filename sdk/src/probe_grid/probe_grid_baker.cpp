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
#include <cstring>
#include <memory>
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

float channel_mean(glm::vec3 v) { return (v.x + v.y + v.z) / 3.0f; }

// Incident radiance from the lights at free point y, projected: each light sample is a delta in
// direction l carrying its irradiance at normal incidence (light models: light_sampling.h).
// Returns their part of the mean radiance over the sphere (channel mean).
float add_lights(const RayScene& scene, std::span<const WorldLight> lights, glm::vec3 y, Rng& rng, SH9rgb& sh) {
  float mean = 0.0f;
  for_each_light_sample(scene, lights, y, y, glm::vec3(0.0f), kRectLightSamples, rng, [&](glm::vec3 l, glm::vec3 e) {
    sh_add_sample(sh, l, e);
    mean += channel_mean(e) / (4.0f * kPi);
  });
  return mean;
}

// What one sample point contributes: its radiance expansion, whether it is in the domain, and for
// the noise target the mean incident radiance over the sphere (channel mean): from all its rays
// and the lights (`mean`), and from each half of its rays alone (`halves`: indices below rays / 2,
// the rest), two randomised QMC estimates of the rays' part.
struct PointSample {
  SH9rgb radiance;
  bool in_domain = false;
  float mean = 0.0f;
  glm::vec2 halves{0.0f};
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

  const std::uint32_t half = s.rays / 2;
  glm::vec2 sums(0.0f);
  for (std::uint32_t i = 0; i < s.rays; ++i) {
    const glm::vec3 dir = uniform_sphere(sobol_2d(i, scramble));
    if (!all_mask[i]) {  // the sky, which the renderer draws no light of: in Indirect grids too
      const glm::vec3 sky = scene.sky(dir);
      if (sky != glm::vec3(0.0f)) sh_add_sample(out.radiance, dir, sky * weight);
      sums[i < half ? 0 : 1] += channel_mean(sky);
      continue;
    }
    const Hit& h = all_hits[i];
    glm::vec3 radiance(0.0f);
    if (s.direct && (!h.back_face || h.material.double_sided)) radiance += h.material.emissive;
    if (s.shade_hits && h.material.albedo != glm::vec3(0.0f)) {
      const glm::vec3 p = y + h.t * dir;
      const glm::vec3 n = h.back_face ? -h.normal : h.normal;
      const Estimate e = irradiance(scene, lights, p, n, s.hit, rng);
      radiance += h.material.albedo * (e.value / kPi);
    }
    if (radiance != glm::vec3(0.0f)) sh_add_sample(out.radiance, dir, radiance * weight);
    sums[i < half ? 0 : 1] += channel_mean(radiance);
  }
  out.mean = (sums.x + sums.y) / float(s.rays);
  if (half > 0) out.halves = glm::vec2(sums.x / float(half), sums.y / float(s.rays - half));
  if (s.direct) out.mean += add_lights(scene, lights, y, rng, out.radiance);
  return out;
}

// The noise target's estimate for one node: the relative standard error of the mean over its
// averaged points of their mean radiance, from the halves of each point's rays (PointSample):
// var(v_k) ~ (a_k - b_k)^2 / 4 for the mean v_k of two estimates a_k, b_k.
struct NodeNoise {
  double sum = 0.0, variance = 0.0;
  std::uint32_t points = 0;
  void add(const PointSample& p) {
    sum += p.mean;
    const double d = double(p.halves.x) - double(p.halves.y);
    variance += d * d / 4.0;
    ++points;
  }
  float relative_error() const {
    if (points == 0 || !(sum > 0.0)) return 0.0f;  // nothing averaged, or black: nothing to refine
    return static_cast<float>(std::sqrt(variance) / sum);
  }
};

// The rays factor for a node whose relative error is `ratio` x the target: the fewest of 2, 4, 8
// (up to kProbeMaxRayFactor) whose rays bring it to the target if the error falls as
// 1 / sqrt(rays) (quasi-Monte Carlo falls faster: the factor errs on the safe side).
std::uint32_t probe_ray_factor(float ratio) {
  std::uint32_t f = 2;
  while (f < kProbeMaxRayFactor && ratio * ratio > float(f)) f *= 2;
  return f;
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


// The settings finish() needs besides the layout (a group's header, with the layout).
struct ProbeFinishSettings {
  std::uint8_t sh_order = 0, sampling = 0, lighting = 0, leak_guard = 0;
  std::uint32_t samples_per_node = 0;
  float deringing_window = 0.0f;
  std::uint32_t bounces = 0;  // as baked (probe_bounces): kept in the chunk for its report
  float noise = 0.0f;         // the noise target, kept in the chunk for its report
};
static_assert(sizeof(ProbeFinishSettings) == 4 + 4 * 4, "written as its bytes: no padding");

// A grid as a group of nodes, node n drawing from Rng::stream(seed, n): prepare(), run() over
// node ranges (steps 0 and 1, which need only the node itself), finish_probe_grid() (steps 2-4,
// which need every node: the fill from neighbours, the least-squares fit, the convolution).
// Node n's results: its reach (leak guard; 6 bytes), validity (float), ray factor (1 byte: the
// noise target's, 1 when not refined), radiance SH (27 floats) and, fitted, its S samples' grid
// position, domain flag and radiance.
class ProbeBake {
 public:
  static Result<std::shared_ptr<ProbeBake>> prepare(const IrradianceProbeGrid& grid, const glm::mat4& world_matrix,
                                                    const RayScene& scene, std::vector<WorldLight> lights,
                                                    std::uint64_t seed, MemoryBudget& budget, std::string_view context);
  const ProbeGridLayout& layout() const { return layout_; }
  ProbeFinishSettings finish() const;  // the grid's, with the bounces resolved
  std::vector<std::byte> header() const;
  // Rays per node, roughly: samples x rays x (1 + hit paths when hits are shaded).
  double node_cost() const {
    return double(grid_.samples_per_node) * grid_.rays_per_sample * (grid_.bounces > 0 ? 1.0 + grid_.hit_samples : 1.0);
  }
  Result<std::vector<std::byte>> run(std::uint64_t begin, std::uint64_t end, JobContext& jobs) const;

 private:
  IrradianceProbeGrid grid_;
  ProbeGridLayout layout_;
  const RayScene* scene_ = nullptr;
  std::vector<WorldLight> lights_;
  std::uint64_t seed_ = 0;
  SampleSettings s_;
};

std::size_t probe_columns(std::uint8_t sh_order) {
  return static_cast<std::size_t>(sh_coefficients(static_cast<ProbeShOrder>(sh_order))) * 3;
}
// Bytes of one node's results.
std::size_t node_result_bytes(const ProbeFinishSettings& f) {
  const bool fitted = static_cast<ProbeSampling>(f.sampling) == ProbeSampling::Fitted;
  return (f.leak_guard ? 6 : 0) + sizeof(float) + 1 + sizeof(SH9rgb) +
         (fitted ? std::size_t{f.samples_per_node} * (sizeof(glm::vec3) + 1 + probe_columns(f.sh_order) * sizeof(float))
                 : 0);
}

ProbeFinishSettings finish_settings(const IrradianceProbeGrid& g) {
  return {static_cast<std::uint8_t>(g.sh_order), static_cast<std::uint8_t>(g.sampling),
          static_cast<std::uint8_t>(g.lighting), static_cast<std::uint8_t>(g.leak_guard ? 1 : 0), g.samples_per_node,
          g.deringing_window, g.bounces, g.noise};
}

ProbeFinishSettings ProbeBake::finish() const { return finish_settings(grid_); }

Result<std::shared_ptr<ProbeBake>> ProbeBake::prepare(const IrradianceProbeGrid& grid, const glm::mat4& world_matrix,
                                                      const RayScene& scene, std::vector<WorldLight> lights,
                                                      std::uint64_t seed, MemoryBudget& budget,
                                                      std::string_view context) {
  auto layout = probe_grid_layout(grid, world_matrix, context);
  if (!layout) return layout.error();
  const std::size_t nodes = layout->node_count();
  const std::size_t count = static_cast<std::size_t>(sh_coefficients(grid.sh_order));
  const bool point = grid.sampling == ProbeSampling::Point;
  const bool fitted = grid.sampling == ProbeSampling::Fitted;
  const std::size_t S = grid.samples_per_node;
  const std::size_t columns = count * 3;  // fitted: one least-squares column per coefficient and channel

  // Memory: the results, the working expansions plus the stored arrays, checked before any ray is
  // traced; fitted mode also keeps every sample and the solver's arrays.
  std::uint64_t need = std::uint64_t{nodes} * (node_result_bytes(finish_settings(grid)) + sizeof(SH9rgb) +
                                               count * sizeof(glm::vec3) + sizeof(float) + 1 + (grid.leak_guard ? 6 : 0));
  if (fitted)
    need += std::uint64_t{nodes} * S * (sizeof(glm::vec3) * (grid.leak_guard ? 2 : 1) + 1 + columns * sizeof(float)) +
            std::uint64_t{nodes} * columns * sizeof(float) + probe_fit_bytes(nodes, columns);
  if (auto st = budget.reserve(std::string(context) + " nodes", need); !st)
    return make_error(ErrorCode::OutOfBudget, st.error().message + " (" + std::to_string(layout->resolution.x) + "x" +
                                                  std::to_string(layout->resolution.y) + "x" +
                                                  std::to_string(layout->resolution.z) +
                                                  " nodes; use a larger spacing or a smaller box)");
  budget.release(need);

  auto bake = std::make_shared<ProbeBake>();
  bake->grid_ = grid;
  bake->grid_.data.reset();
  bake->grid_.bounces = probe_bounces(grid, scene.max_albedo());
  bake->grid_.truncation = 0.0f;
  bake->layout_ = *layout;
  bake->scene_ = &scene;
  bake->lights_ = std::move(lights);
  bake->seed_ = seed;
  const IrradianceProbeGrid& g = bake->grid_;
  SampleSettings& s = bake->s_;
  s.rays = point ? grid.samples_per_node * grid.rays_per_sample : grid.rays_per_sample;
  s.back_face_threshold = grid.back_face_threshold;
  s.skip_outside = !point;
  s.shade_hits = g.bounces > 0;
  s.direct = grid.lighting == LightingContent::All;
  s.hit.samples = grid.hit_samples;
  s.hit.reference = g.bounces == kProbeAllBounces;
  s.hit.bounces = g.bounces > 0 ? g.bounces - 1 : 0;
  s.hit.rect_light_samples = kRectLightSamples;
  return bake;
}

void write_layout(ByteWriter& w, const ProbeGridLayout& l) {
  w.write(l.resolution);
  w.write(l.grid_to_world);
  w.write(l.world_to_grid);
  w.write(l.spacing);
}

std::vector<std::byte> ProbeBake::header() const {
  ByteWriter w;
  write_layout(w, layout_);
  w.write(finish_settings(grid_));
  return w.take();
}

Result<std::vector<std::byte>> ProbeBake::run(std::uint64_t first, std::uint64_t last, JobContext& jobs) const {
  const IrradianceProbeGrid& grid = grid_;
  const ProbeGridLayout& layout = layout_;
  const RayScene& scene = *scene_;
  const std::size_t count = static_cast<std::size_t>(last - first);
  const bool point = grid.sampling == ProbeSampling::Point;
  const bool fitted = grid.sampling == ProbeSampling::Fitted;
  const std::size_t columns = probe_columns(static_cast<std::uint8_t>(grid.sh_order));
  const ProbeFinishSettings f = finish_settings(grid);
  const std::size_t each = node_result_bytes(f);
  std::vector<std::byte> out(count * each);
  const glm::uvec3 res = layout.resolution;
  const glm::vec3 cell = 1.0f / glm::vec3(res - 1u);
  const auto ijk_of = [&](std::size_t n) {
    return glm::uvec3(n % res.x, (n / res.x) % res.y, n / (std::size_t{res.x} * res.y));
  };
  const std::size_t reach_at = 0, validity_at = f.leak_guard ? 6 : 0, factor_at = validity_at + sizeof(float),
                    radiance_at = factor_at + 1, samples_at = radiance_at + sizeof(SH9rgb);
  const std::size_t sample_bytes = sizeof(glm::vec3) + 1 + columns * sizeof(float);

  // Step 0 (leak guard): each node's reach, which step 1 needs at the node (6 rays a node; the
  // stage counts each node once for it and once for its samples).
  jobs.begin_stage("probe samples", grid.leak_guard ? 2 * count : count);
  if (grid.leak_guard) {
    PENUMBRA_TRY(jobs.parallel_for(count, 64, [&](std::size_t begin, std::size_t end) {
      for (std::size_t i = begin; i < end; ++i)
        trace_reach(scene, layout, ijk_of(static_cast<std::size_t>(first) + i),
                    reinterpret_cast<std::uint8_t*>(out.data() + i * each + reach_at));
    }));
  }

  // Step 1: per node, radiance SH from its sample points (node n from its own stream), traced
  // again with more rays when the noise target asks for it (probe_ray_factor).
  PENUMBRA_TRY(jobs.parallel_for(count, 4, [&](std::size_t begin, std::size_t end) {
    for (std::size_t i = begin; i < end; ++i) {
      const std::size_t n = static_cast<std::size_t>(first) + i;
      std::byte* o = out.data() + i * each;
      const std::uint8_t* reach = reinterpret_cast<const std::uint8_t*>(o + reach_at);
      const glm::uvec3 ijk = ijk_of(n);
      const glm::vec3 u = glm::vec3(ijk) * cell;
      float validity = 0.0f;
      SH9rgb radiance;
      // One pass at `rays` rays per point: validity, radiance (fitted: the samples in `o`) and the
      // estimated relative standard error of the mean radiance over the points it averages.
      const auto trace = [&](std::uint32_t rays) {
        SampleSettings settings = s_;
        settings.rays = rays;
        Rng rng = Rng::stream(seed_, n);
        NodeNoise noise;
        radiance = SH9rgb{};
        if (point) {
          // The classic irradiance volume: everything at the node.
          const PointSample p = sample_point(scene, lights_, layout.node_position(ijk), settings, rng);
          radiance = p.radiance;
          validity = p.in_domain ? 1.0f : 0.0f;
          if (p.in_domain) noise.add(p);
          return noise.relative_error();
        }
        // Supersampling: S points from the tent B_i, averaged over those in the domain (and, with
        // the leak guard, seen by the node); fitted mode keeps each one for the least-squares step.
        const std::array<std::uint32_t, 3> scrambles{rng.next_u32(), rng.next_u32(), rng.next_u32()};
        SH9rgb sum;
        std::uint32_t inside = 0;
        for (std::uint32_t k = 0; k < grid.samples_per_node; ++k) {
          const glm::vec3 t = tent_offset(k, scrambles, ijk, res, fitted);
          // The lookup's test (probe_node_sees): a node averages only what it will be used for.
          const bool seen = !grid.leak_guard || probe_node_sees(reach, t);
          if (!seen && !fitted) continue;  // supersampled: no rays for a point the node never serves
          const glm::vec3 y(layout.grid_to_world * glm::vec4(u + t * cell, 1.0f));
          const PointSample p = sample_point(scene, lights_, y, settings, rng);
          if (fitted) {
            std::byte* smp = o + samples_at + k * sample_bytes;
            const glm::vec3 at = glm::vec3(ijk) + t;
            const std::uint8_t in_domain = p.in_domain ? 1 : 0;
            std::memcpy(smp, &at, sizeof at);
            std::memcpy(smp + sizeof at, &in_domain, 1);
            for (std::size_t c = 0; c < columns; ++c) {
              const float v = p.radiance[static_cast<int>(c / 3)][static_cast<int>(c % 3)];
              std::memcpy(smp + sizeof at + 1 + c * sizeof(float), &v, sizeof v);
            }
          }
          if (!p.in_domain || !seen) continue;
          sum += p.radiance;
          noise.add(p);
          ++inside;
        }
        validity = float(inside) / float(grid.samples_per_node);
        if (inside > 0) radiance = sum * (1.0f / float(inside));
        return noise.relative_error();
      };
      std::uint8_t factor = 1;
      const float error = trace(s_.rays);
      if (grid.noise > 0.0f && error > grid.noise) {
        factor = static_cast<std::uint8_t>(probe_ray_factor(error / grid.noise));
        trace(s_.rays * factor);
      }
      std::memcpy(o + validity_at, &validity, sizeof validity);
      std::memcpy(o + factor_at, &factor, 1);
      std::memcpy(o + radiance_at, &radiance, sizeof radiance);
    }
  }));
  return out;
}

// Steps 2-4 from the layout, the settings and every node's results (nodes in index order).
Result<ProbeGridData> finish_probe_grid(const ProbeGridLayout& layout, const ProbeFinishSettings& f,
                                        std::span<const std::byte> results, JobContext& jobs,
                                        std::string_view context) {
  const std::size_t nodes = layout.node_count();
  const auto sampling = static_cast<ProbeSampling>(f.sampling);
  if (f.sh_order > static_cast<std::uint8_t>(ProbeShOrder::L2) || f.sampling > static_cast<std::uint8_t>(ProbeSampling::Fitted) ||
      f.leak_guard > 1 || (f.lighting != static_cast<std::uint8_t>(LightingContent::All) &&
                           f.lighting != static_cast<std::uint8_t>(LightingContent::Indirect)) ||
      f.samples_per_node == 0 || !(f.noise >= 0.0f && f.noise <= 1.0f) ||
      glm::any(glm::lessThan(layout.resolution, glm::uvec3(2u))) ||
      nodes > kMaxProbeNodes || results.size() / node_result_bytes(f) != nodes ||
      results.size() % node_result_bytes(f) != 0)
    return make_error(ErrorCode::InvalidInput, std::string(context) + ": the header or the " +
                                                   std::to_string(results.size()) +
                                                   " bytes of node results do not describe a grid; the part is "
                                                   "corrupt, re-bake it");
  const bool point = sampling == ProbeSampling::Point;
  const bool fitted = sampling == ProbeSampling::Fitted;
  const std::size_t S = f.samples_per_node;
  const std::size_t count = static_cast<std::size_t>(sh_coefficients(static_cast<ProbeShOrder>(f.sh_order)));
  const std::size_t columns = count * 3;
  const std::size_t each = node_result_bytes(f);
  const std::size_t validity_at = f.leak_guard ? 6 : 0, factor_at = validity_at + sizeof(float),
                    radiance_at = factor_at + 1, samples_at = radiance_at + sizeof(SH9rgb);
  const std::size_t sample_bytes = sizeof(glm::vec3) + 1 + columns * sizeof(float);

  ProbeGridData data;
  data.layout = layout;
  data.sh_order = static_cast<ProbeShOrder>(f.sh_order);
  data.sampling = sampling;
  data.lighting = static_cast<LightingContent>(f.lighting);
  data.bounces = f.bounces;
  data.noise = f.noise;
  std::vector<SH9rgb> radiance(nodes);
  data.validity.assign(nodes, 0.0f);
  data.filled.assign(nodes, 0);
  if (f.leak_guard) data.reach.assign(nodes * 6, 0);
  std::vector<glm::vec3> sample_position(fitted ? nodes * S : 0);
  std::vector<std::uint8_t> sample_in_domain(fitted ? nodes * S : 0);
  std::vector<float> sample_values(fitted ? nodes * S * columns : 0);
  std::uint64_t factor_sum = 0;
  for (std::size_t n = 0; n < nodes; ++n) {
    const std::byte* o = results.data() + n * each;
    if (f.leak_guard) std::memcpy(&data.reach[6 * n], o, 6);
    std::memcpy(&data.validity[n], o + validity_at, sizeof(float));
    std::memcpy(&radiance[n], o + radiance_at, sizeof(SH9rgb));
    const auto factor = static_cast<std::uint32_t>(o[factor_at]);
    if (!(data.validity[n] >= 0.0f && data.validity[n] <= 1.0f) || factor == 0 || factor > kProbeMaxRayFactor)
      return make_error(ErrorCode::InvalidInput, std::string(context) + ": node " + std::to_string(n) +
                                                     " has validity " + std::to_string(data.validity[n]) +
                                                     " and ray factor " + std::to_string(factor) +
                                                     "; the part is corrupt, re-bake it");
    factor_sum += factor;
    data.refined_nodes += factor > 1 ? 1 : 0;
    for (std::size_t k = 0; fitted && k < S; ++k) {
      const std::byte* smp = o + samples_at + k * sample_bytes;
      const std::size_t i = n * S + k;
      std::memcpy(&sample_position[i], smp, sizeof(glm::vec3));
      std::memcpy(&sample_in_domain[i], smp + sizeof(glm::vec3), 1);
      std::memcpy(&sample_values[i * columns], smp + sizeof(glm::vec3) + 1, columns * sizeof(float));
      const glm::vec3 at = sample_position[i];
      if (!(glm::all(glm::greaterThanEqual(at, glm::vec3(0.0f))) &&
            glm::all(glm::lessThanEqual(at, glm::vec3(layout.resolution - 1u)))))
        return make_error(ErrorCode::InvalidInput, std::string(context) + ": node " + std::to_string(n) + " sample " +
                                                       std::to_string(k) +
                                                       " lies outside the grid; the part is corrupt, re-bake it");
    }
  }

  data.ray_factor = static_cast<float>(double(factor_sum) / double(nodes));

  // Step 2: fill nodes with no in-domain sample (supersampled and fitted; point mode keeps the
  // classic values).
  if (!point) {
    if (std::all_of(data.validity.begin(), data.validity.end(), [](float v) { return v == 0.0f; }))
      return make_error(ErrorCode::InvalidInput,
                        std::string(context) + ": no node has a sample in the domain of interest (every probe is "
                                               "inside geometry or sees back faces); move or enlarge the grid, or "
                                               "raise back_face_threshold for open geometry");
    if (!dilate(layout, radiance, data.validity, data.filled, jobs))
      return make_error(ErrorCode::Cancelled, std::string(context) + ": the bake was cancelled");
  } else {
    jobs.begin_stage("probe fill", 1);
    jobs.advance(1);
  }

  // Step 3 (fitted): the node values that minimise the reconstruction error over the in-domain
  // samples, pulled towards the averages of steps 1-2 where support is thin (probe_fit.h); with the
  // leak guard, each sample at the lookup fraction the runtime will use for it (which reads the
  // reach of the cell's eight nodes).
  if (fitted) {
    std::vector<glm::vec3> sample_lookup(f.leak_guard ? nodes * S : 0);
    for (std::size_t i = 0; i < sample_lookup.size(); ++i) {
      const glm::vec3 at = sample_position[i];
      const glm::uvec3 base = probe_fit_cell(at, layout.resolution);
      sample_lookup[i] = probe_lookup_fraction(data, base, at - glm::vec3(base), glm::vec3(0.0f));
    }
    std::vector<float> values(nodes * columns);
    for (std::size_t n = 0; n < nodes; ++n)
      for (std::size_t c = 0; c < columns; ++c)
        values[n * columns + c] = radiance[n][static_cast<int>(c / 3)][static_cast<int>(c % 3)];
    ProbeFitInput input;
    input.resolution = layout.resolution;
    input.samples_per_node = f.samples_per_node;
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
    if (f.deringing_window > 0.0f) e = sh_apply_window(e, sh_lanczos_window(f.deringing_window));
    for (std::size_t c = 0; c < count; ++c) data.coefficients[n * count + c] = e[static_cast<int>(c)];
  }
  return data;
}

}  // namespace

Result<ProbeGridData> bake_probe_grid(const IrradianceProbeGrid& grid, const glm::mat4& world_matrix,
                                      const RayScene& scene, std::span<const WorldLight> lights, std::uint64_t seed,
                                      JobContext& jobs, MemoryBudget& budget, std::string_view context) {
  auto bake = ProbeBake::prepare(grid, world_matrix, scene, std::vector<WorldLight>(lights.begin(), lights.end()),
                                 seed, budget, context);
  if (!bake) return bake.error();
  auto results = (*bake)->run(0, (*bake)->layout().node_count(), jobs);
  if (!results) return results.error();
  return finish_probe_grid((*bake)->layout(), (*bake)->finish(), *results, jobs, context);
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

constexpr std::uint64_t kNodeBlock = 16;  // probe nodes per work item

// A group per grid entity, its nodes the elements.
Result<BakeWork> plan_probes(BakeInputs& in) {
  const std::vector<Entity> entities = grid_entities(in.world);
  auto keys = bake_keys(in, entities, "probe grid");
  if (!keys) return keys.error();
  const std::vector<WorldLight> lights = entities.empty() ? std::vector<WorldLight>{} : baked_lights(in.world);
  BakeWork work;
  auto bakes = std::make_shared<std::vector<std::shared_ptr<ProbeBake>>>();
  for (std::size_t i = 0; i < entities.size(); ++i) {
    const Entity e = entities[i];
    auto bake = ProbeBake::prepare(in.world.get<IrradianceProbeGrid>(e), in.world.get<WorldTransform>(e).matrix,
                                   in.rays, lights, in.settings.seed, in.budget, grid_context(in.world, e));
    if (!bake) return bake.error();
    work.groups.push_back(BakeGroup{std::move((*keys)[i]), (*bake)->layout().node_count(), kNodeBlock,
                                    (*bake)->node_cost(), (*bake)->header()});
    bakes->push_back(std::move(*bake));
  }
  work.run = [bakes](std::size_t g, std::uint64_t begin, std::uint64_t end, JobContext& jobs) {
    return (*bakes)[g]->run(begin, end, jobs);
  };
  return work;
}

// One PRBG chunk per grid, in entity order.
Result<std::vector<BakeChunk>> finish_probes(std::span<const BakedGroup> groups, JobContext& jobs) {
  std::vector<BakeChunk> chunks;
  for (const BakedGroup& g : groups) {
    const std::string context = "probe grid '" + g.group->name + "'";
    ByteReader header(g.group->header, context + " header");
    ProbeGridLayout layout;
    ProbeFinishSettings f;
    PENUMBRA_TRY(header.read(layout.resolution));
    PENUMBRA_TRY(header.read(layout.grid_to_world));
    PENUMBRA_TRY(header.read(layout.world_to_grid));
    PENUMBRA_TRY(header.read(layout.spacing));
    PENUMBRA_TRY(header.read(f));
    PENUMBRA_TRY(header.finish());
    if (std::uint64_t{layout.resolution.x} * layout.resolution.y * layout.resolution.z != g.group->elements)
      return make_error(ErrorCode::InvalidInput, context + ": the layout does not have the group's " +
                                                     std::to_string(g.group->elements) + " nodes; the part is corrupt");
    auto data = finish_probe_grid(layout, f, g.results, jobs, context);
    if (!data) return data.error();
    data->key = g.group->name;
    chunks.push_back(write_probe_grid_chunk(*data));
  }
  return chunks;
}

void hash_probe_inputs(World& world, const BakeSettings&, Hasher& h) {
  h.add(kProbeGridChunkVersion);
  // The fit fits the leak guard's lookup (step 3 of finish_probe_grid): its rules are inputs.
  for (const float c : {kProbeReachSlack, kProbeNormalBias, kProbeStaticNormalBias, kProbePlaneSlack, kProbeSolidValidity})
    h.add(c);
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
  b.plan = plan_probes;
  b.finish = finish_probes;
  world.resource<BakerRegistry>().add(std::move(b));
}

}  // namespace penumbra
