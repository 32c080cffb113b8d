// The offline renderer's passes (offline/offline_renderer.h): primary hits, direct light, indirect
// irradiance (per pixel, with the adaptive second pass and the filter of irradiance filtering, or
// from the irradiance cache), composition.
#include "penumbra/offline/offline_renderer.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <string>

#include <glm/common.hpp>
#include <glm/geometric.hpp>
#include <glm/mat4x4.hpp>

#include "penumbra/bake/light_sampling.h"
#include "penumbra/core/random.h"
#include "penumbra/core/sampling.h"

namespace penumbra {
namespace {

constexpr float kPi = 3.14159265358979323846f;
constexpr float kInf = std::numeric_limits<float>::infinity();
constexpr std::size_t kGrain = 64;  // pixels per parallel chunk (a run of one row)

// The random streams of each pass: pixel i of pass P draws from Rng::stream(mix64(seed + P), i).
enum Pass : std::uint64_t { kScramble = 1, kDirect, kIndirect, kAdaptive };
Rng pixel_stream(std::uint64_t seed, Pass pass, std::size_t pixel) { return Rng::stream(mix64(seed + pass), pixel); }

struct Primary {
  bool hit = false;
  glm::vec3 position{0.0f}, normal{0.0f}, albedo{0.0f}, emission{0.0f};
  float footprint = 0.0f;
  glm::vec3 background{0.0f};  // what a pixel without a surface shows: the sky, or a rect light's radiance
};

// Mean and spread of a pixel's samples (sums in double), with the harmonic mean distance's sum.
struct Accumulator {
  glm::dvec3 sum{0.0}, sum_sq{0.0};
  double inverse_distance = 0.0;  // sum of 1 / d over the rays (0 for a miss)
  std::uint32_t n = 0;
  std::uint32_t nonfinite = 0;
  void add(glm::vec3 v) {
    const glm::dvec3 d(v);
    sum += d;
    sum_sq += d * d;
    ++n;
  }
  glm::vec3 mean() const { return n ? glm::vec3(sum / double(n)) : glm::vec3(0.0f); }
  glm::vec3 std_error() const {
    if (n < 2) return glm::vec3(0.0f);
    const glm::dvec3 m = sum / double(n);
    const glm::dvec3 var = glm::max((sum_sq - double(n) * m * m) / double(n - 1), glm::dvec3(0.0));
    return glm::vec3(glm::sqrt(var / double(n)));
  }
  float harmonic_distance() const { return inverse_distance > 0.0 ? float(double(n) / inverse_distance) : kInf; }
};

bool finite(glm::vec3 v) { return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z); }

Status check(const OfflineSettings& s) {
  const auto bad = [](const std::string& what) { return make_error(ErrorCode::InvalidArgument, "render_offline: " + what); };
  if (s.width == 0 || s.height == 0 || s.width > 16384 || s.height > 16384)
    return bad("the image is " + std::to_string(s.width) + "x" + std::to_string(s.height) + "; use 1..16384 per side");
  if (s.spp == 0 || s.spp > (1u << 20)) return bad("spp is " + std::to_string(s.spp) + "; use 1..1048576");
  if (s.mode == OfflineMode::Reference && s.spp < 2) return bad("the reference needs spp >= 2 for its standard error");
  if (s.mode == OfflineMode::IrradianceCache && s.spp < 6)
    return bad("the irradiance cache needs spp >= 6 rays per record (2 x 3 strata)");
  if (!(s.cache.accuracy > 0.0f) || !std::isfinite(s.cache.accuracy) || !(s.cache.min_radius > 0.0f) ||
      !(s.cache.max_radius >= s.cache.min_radius) || !std::isfinite(s.cache.max_radius))
    return bad("the cache's accuracy must be positive and 0 < min_radius <= max_radius");
  if (s.direct_samples == 0 || s.rect_light_samples == 0 || s.path_rect_light_samples == 0)
    return bad("direct_samples, rect_light_samples and path_rect_light_samples must be at least 1");
  if (!(s.filter.a > 0.0f) || !std::isfinite(s.filter.a) || s.filter.max_radius > kMaxFilterRadius ||
      s.filter.predictor_radius > kMaxPredictorRadius)
    return bad("the filter's a must be positive, max_radius at most " + std::to_string(kMaxFilterRadius) +
               " and predictor_radius at most " + std::to_string(kMaxPredictorRadius));
  if (!(s.target_support > 0.0f) || !std::isfinite(s.target_support) || s.max_boost == 0 || s.max_boost > 1024)
    return bad("target_support must be positive and max_boost in 1..1024");
  return {};
}

// pi x the radiance arriving at x (unit normal n) along unit `dir`: the radiance leaving what it
// hits (emission on the front side, or both when double sided, plus albedo x one sample of the
// irradiance there: All content, unbiased paths) or the sky when it escapes; and the distance.
IncidentSample incident(const RayScene& scene, std::span<const WorldLight> lights, glm::vec3 x, glm::vec3 n,
                        glm::vec3 dir, const IrradianceSettings& path, Rng& rng) {
  const glm::vec3 origin = x + scene.ray_epsilon(x) * n;
  Hit hit;
  if (!scene.intersect(Ray{origin, 0.0f, dir, kInf}, hit)) return {kPi * scene.sky(dir), kInf};
  const glm::vec3 p = origin + hit.t * dir;
  const glm::vec3 pn = hit.back_face ? -hit.normal : hit.normal;
  glm::vec3 value = hit.material.albedo * irradiance_sample(scene, lights, p, pn, path, rng);
  if (!hit.back_face || hit.material.double_sided) value += kPi * hit.material.emissive;
  return {value, hit.t};
}

// Indirect samples `first`..`first + count - 1` at (x, n): cosine-distributed directions from the
// pixel's scrambled Sobol' net (or independent when qmc is null), each traced by incident().
void sample_indirect(const RayScene& scene, std::span<const WorldLight> lights, glm::vec3 x, glm::vec3 n,
                     const Sobol2D* qmc, std::uint32_t first, std::uint32_t count, const IrradianceSettings& path,
                     Rng& rng, Accumulator& acc) {
  for (std::uint32_t k = first; k < first + count; ++k) {
    const glm::vec2 u = qmc ? (*qmc)(k) : glm::vec2(rng.next_float(), rng.next_float());
    const IncidentSample s = incident(scene, lights, x, n, to_world(n, cosine_hemisphere(u)), path, rng);
    const float inverse_distance = std::isfinite(s.distance) ? 1.0f / std::max(s.distance, 1e-30f) : 0.0f;
    if (!finite(s.value) || !std::isfinite(inverse_distance)) {
      ++acc.nonfinite;
      continue;
    }
    acc.add(s.value);
    acc.inverse_distance += inverse_distance;
  }
}

// The radiance of the nearest rect light's emitting side that the ray meets before t_max, if any
// (a light, not geometry: the real-time renderer draws it as a quad of its radiance, and so here).
std::optional<glm::vec3> rect_emitter(std::span<const WorldLight> lights, const CameraRay& ray, float t_max) {
  std::optional<glm::vec3> seen;
  for (const WorldLight& wl : lights) {
    if (wl.light.type != Light::Type::Rect) continue;
    const float facing = glm::dot(ray.direction, wl.direction);
    if (!(facing < 0.0f)) continue;  // one-sided: seen only from where it shines
    const float t = glm::dot(wl.position - ray.origin, wl.direction) / facing;
    if (!(t > 0.0f && t < t_max)) continue;
    const glm::vec3 d = ray.origin + t * ray.direction - wl.position;
    const float u = glm::dot(d, wl.half_x) / glm::dot(wl.half_x, wl.half_x);
    const float v = glm::dot(d, wl.half_y) / glm::dot(wl.half_y, wl.half_y);
    if (std::abs(u) > 1.0f || std::abs(v) > 1.0f) continue;
    t_max = t;
    seen = wl.light.color * wl.light.intensity;
  }
  return seen;
}

}  // namespace

std::string_view to_string(OfflineMode mode) {
  switch (mode) {
    case OfflineMode::MonteCarlo: return "mc";
    case OfflineMode::IrradianceFilter: return "irradiance-filter";
    case OfflineMode::Reference: return "reference";
    case OfflineMode::IrradianceCache: return "irradiance-cache";
  }
  return "unknown";
}

std::optional<OfflineMode> parse_offline_mode(std::string_view name) {
  for (const OfflineMode m :
       {OfflineMode::MonteCarlo, OfflineMode::IrradianceFilter, OfflineMode::IrradianceCache, OfflineMode::Reference})
    if (name == to_string(m)) return m;
  return std::nullopt;
}

std::string_view offline_mode_names() { return "mc, irradiance-filter, irradiance-cache, reference"; }

Result<OfflineImage> render_offline(const RayScene& scene, std::span<const WorldLight> lights, const CameraView& camera,
                                    const OfflineSettings& s, JobContext& jobs, const SurfaceTextures* textures) {
  PENUMBRA_TRY(check(s));
  const auto start = std::chrono::steady_clock::now();
  const std::uint32_t width = s.width, height = s.height;
  const std::size_t count = std::size_t(width) * height;
  const bool filtered = s.mode == OfflineMode::IrradianceFilter;
  const bool reference = s.mode == OfflineMode::Reference;
  const bool cached = s.mode == OfflineMode::IrradianceCache;
  jobs.set_stage_count(filtered ? 6 : cached ? 4 : 3);

  // Primary hits: one ray through each pixel's centre, as the real-time renderer samples it.
  const glm::mat4 clip_to_world = glm::inverse(camera.projection * camera.view);
  std::vector<Primary> primary(count);
  jobs.begin_stage("primary", count);
  PENUMBRA_TRY(jobs.parallel_for(count, kGrain, [&](std::size_t begin, std::size_t end) {
    for (std::size_t i = begin; i < end; ++i) {
      const glm::vec2 centre(float(i % width) + 0.5f, float(i / width) + 0.5f);
      const CameraRay ray = camera_ray(clip_to_world, centre, width, height);
      Primary& pr = primary[i];
      Hit hit;
      const bool surface = scene.intersect(Ray{ray.origin, 0.0f, ray.direction, kInf}, hit);
      if (const auto emitter = rect_emitter(lights, ray, surface ? hit.t : kInf)) {
        pr.background = *emitter;
        continue;
      }
      if (!surface) {
        pr.background = scene.sky(ray.direction);
        continue;
      }
      pr.hit = true;
      pr.position = ray.origin + hit.t * ray.direction;
      pr.normal = hit.back_face ? -hit.normal : hit.normal;
      pr.albedo = textures ? textures->albedo(hit) : hit.material.albedo;
      if (!hit.back_face || hit.material.double_sided) pr.emission = hit.material.emissive;
      // The pixel's width where it meets the surface: distance x the angle between neighbouring rays.
      const CameraRay next = camera_ray(clip_to_world, centre + glm::vec2(1.0f, 0.0f), width, height);
      pr.footprint = std::max(glm::distance(camera.position, pr.position) * glm::length(next.direction - ray.direction),
                              1e-30f);
    }
  }));

  // Direct light: next-event estimation to every light, rect lights over their area (soft shadows).
  const std::uint32_t direct_samples = reference ? std::max(s.direct_samples, s.spp) : s.direct_samples;
  std::vector<Accumulator> direct(count);
  jobs.begin_stage("direct", count);
  PENUMBRA_TRY(jobs.parallel_for(count, kGrain, [&](std::size_t begin, std::size_t end) {
    for (std::size_t i = begin; i < end; ++i) {
      const Primary& pr = primary[i];
      if (!pr.hit) continue;
      Rng rng = pixel_stream(s.seed, kDirect, i);
      const glm::vec3 origin = pr.position + scene.ray_epsilon(pr.position) * pr.normal;
      for (std::uint32_t k = 0; k < direct_samples; ++k) {
        glm::vec3 e(0.0f);
        for_each_light_sample(scene, lights, pr.position, origin, pr.normal, s.rect_light_samples, rng,
                              [&](glm::vec3 l, glm::vec3 e_normal) { e += e_normal * glm::dot(pr.normal, l); });
        if (finite(e)) {
          direct[i].add(e);
        } else {
          ++direct[i].nonfinite;
        }
      }
    }
  }));

  // Indirect irradiance: spp rays per pixel.
  IrradianceSettings path;
  path.content = LightingContent::All;
  path.reference = true;
  path.rect_light_samples = s.path_rect_light_samples;
  std::vector<Accumulator> indirect(count);
  const auto scramble = [&](std::size_t i) { return Sobol2D(pixel_stream(s.seed, kScramble, i).next_u32()); };
  const auto indirect_pass = [&](Pass pass, const std::vector<std::uint32_t>* extra) -> Status {
    return jobs.parallel_for(count, kGrain, [&](std::size_t begin, std::size_t end) {
      for (std::size_t i = begin; i < end; ++i) {
        const Primary& pr = primary[i];
        if (!pr.hit) continue;
        const std::uint32_t first = extra ? s.spp : 0, n = extra ? (*extra)[i] : s.spp;
        if (n == 0) continue;
        Rng rng = pixel_stream(s.seed, pass, i);
        const Sobol2D qmc = scramble(i);
        // The net continues across passes (indices spp.. in the adaptive one), so a pixel's rays stay stratified.
        sample_indirect(scene, lights, pr.position, pr.normal, reference ? nullptr : &qmc, first, n, path, rng,
                        indirect[i]);
      }
    });
  };
  std::vector<glm::vec3> irradiance(count, glm::vec3(0.0f));
  std::uint64_t cache_rays = 0, cache_nonfinite = 0, cache_records = 0;
  if (cached) {
    // Irradiance caching: records of spp rays where no record covers a pixel, interpolated.
    std::vector<CachePixel> pixels(count);
    for (std::size_t i = 0; i < count; ++i)
      pixels[i] = {primary[i].position, primary[i].normal, primary[i].footprint, primary[i].hit};
    IrradianceCacheSettings cache = s.cache;
    cache.rays = s.spp;
    cache.seed = s.seed;
    IrradianceCacheStats stats;
    const IncidentFn trace = [&](glm::vec3 x, glm::vec3 n, glm::vec3 dir, Rng& rng) {
      return incident(scene, lights, x, n, dir, path, rng);
    };
    PENUMBRA_TRY(irradiance_cache(pixels, width, height, cache, trace, irradiance, stats, jobs));
    cache_rays = stats.rays;
    cache_nonfinite = stats.nonfinite;
    cache_records = stats.records;
  } else {
    jobs.begin_stage("indirect", count);
    PENUMBRA_TRY(indirect_pass(kIndirect, nullptr));
  }

  if (filtered) {
    std::vector<FilterPixel> pixels(count);
    const auto fill = [&] {
      for (std::size_t i = 0; i < count; ++i) {
        if (!primary[i].hit || indirect[i].n == 0) {
          pixels[i] = FilterPixel{};
          continue;
        }
        pixels[i] = {primary[i].position, primary[i].normal, primary[i].footprint, indirect[i].mean(),
                     indirect[i].harmonic_distance(), indirect[i].n};
      }
    };
    fill();
    // Adaptive sampling: a pixel whose kernel holds less than target_support of neighbours (its
    // predictor expects fast change) gets rays in proportion, up to max_boost x spp in all.
    std::vector<float> support(count);
    PENUMBRA_TRY(irradiance_filter_support(pixels, width, height, s.filter, s.target_support, support, jobs));
    std::vector<std::uint32_t> extra(count, 0);
    for (std::size_t i = 0; i < count; ++i) {
      if (pixels[i].samples == 0 || !(support[i] < s.target_support)) continue;
      const double wanted = std::ceil(double(s.spp) * double(s.target_support) / std::max(double(support[i]), 1.0));
      const double total = std::min(wanted, double(s.spp) * double(s.max_boost));
      extra[i] = static_cast<std::uint32_t>(std::max(total - double(s.spp), 0.0));
    }
    jobs.begin_stage("adaptive indirect", count);
    PENUMBRA_TRY(indirect_pass(kAdaptive, &extra));
    fill();
    PENUMBRA_TRY(filter_irradiance(pixels, width, height, s.filter, irradiance, jobs));
  } else if (!cached) {
    for (std::size_t i = 0; i < count; ++i) irradiance[i] = indirect[i].mean();
  }

  // Composition: lit = Le + albedo / pi (E_d + E_i); the sky where the ray escaped.
  OfflineImage image;
  image.width = width;
  image.height = height;
  image.lit.assign(count, glm::vec3(0.0f));
  image.direct.assign(count, glm::vec3(0.0f));
  image.indirect.assign(count, glm::vec3(0.0f));
  image.albedo.assign(count, glm::vec3(0.0f));
  image.covered.assign(count, 0);
  if (reference) {
    image.lit_std_error.assign(count, glm::vec3(0.0f));
    image.direct_std_error.assign(count, glm::vec3(0.0f));
    image.indirect_std_error.assign(count, glm::vec3(0.0f));
  }
  for (std::size_t i = 0; i < count; ++i) {
    const Primary& pr = primary[i];
    image.indirect_samples += indirect[i].n + indirect[i].nonfinite;
    image.nonfinite_samples += indirect[i].nonfinite + direct[i].nonfinite;
    if (!pr.hit) {
      image.lit[i] = pr.background;
      continue;
    }
    const glm::vec3 brdf = pr.albedo / kPi;
    image.covered[i] = 1;
    ++image.covered_pixels;
    image.albedo[i] = pr.albedo;
    image.direct[i] = brdf * direct[i].mean();
    image.indirect[i] = brdf * irradiance[i];
    image.lit[i] = pr.emission + image.direct[i] + image.indirect[i];
    if (reference) {
      const glm::vec3 sd = brdf * direct[i].std_error(), si = brdf * indirect[i].std_error();
      image.direct_std_error[i] = sd;
      image.indirect_std_error[i] = si;
      image.lit_std_error[i] = glm::sqrt(sd * sd + si * si);
    }
  }
  image.indirect_samples += cache_rays;
  image.nonfinite_samples += cache_nonfinite;
  image.cache_records = cache_records;
  image.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return image;
}

}  // namespace penumbra
