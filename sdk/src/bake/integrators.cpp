// Monte Carlo integrators over a RayScene: ambient occlusion by cosine-weighted visibility rays,
// and irradiance by path tracing with next-event estimation (Kajiya 1986, "The Rendering
// Equation"; Veach 1997, ch. 10 for light sampling; Arvo & Kirk 1990 for Russian roulette).
// Light models follow KHR_lights_punctual; rect lights are one-sided Lambertian emitters.
#include "penumbra/bake/integrators.h"
#include "penumbra/bake/light_sampling.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <string>

#include <glm/common.hpp>
#include <glm/geometric.hpp>
#include <glm/mat3x3.hpp>

#include "penumbra/core/log.h"
#include "penumbra/core/sampling.h"
#include "penumbra/ecs/transform.h"

namespace penumbra {

namespace {

constexpr float kPi = 3.14159265358979323846f;
constexpr float kInf = std::numeric_limits<float>::infinity();

// Running mean and variance of a vector quantity (sums in double).
struct Accumulator {
  glm::dvec3 sum{0.0}, sum_sq{0.0};
  std::uint32_t n = 0;
  void add(glm::vec3 v) {
    const glm::dvec3 d(v);
    sum += d;
    sum_sq += d * d;
    ++n;
  }
  Estimate estimate() const {
    Estimate e;
    e.samples = n;
    if (n == 0) return e;
    const glm::dvec3 mean = sum / double(n);
    e.value = glm::vec3(mean);
    if (n > 1) {
      // Sample variance (Bessel-corrected), then the standard error of the mean.
      const glm::dvec3 var = glm::max((sum_sq - double(n) * mean * mean) / double(n - 1), glm::dvec3(0.0));
      e.std_error = glm::vec3(glm::sqrt(var / double(n)));
    }
    return e;
  }
};

// Direct irradiance at p (unit normal n) from every light, with shadow rays from p + eps n.
glm::vec3 direct_light(const RayScene& scene, std::span<const WorldLight> lights, glm::vec3 p, glm::vec3 n,
                       std::uint32_t rect_samples, Rng& rng) {
  glm::vec3 e(0.0f);
  for_each_light_sample(scene, lights, p, p + scene.ray_epsilon(p) * n, n, rect_samples, rng,
                        [&](glm::vec3 l, glm::vec3 e_normal) { e += e_normal * glm::dot(n, l); });
  return e;
}

Status check_points(std::size_t points, std::size_t out, const char* what) {
  if (points == out) return {};
  return make_error(ErrorCode::InvalidArgument, std::string(what) + ": " + std::to_string(points) +
                                                    " points but room for " + std::to_string(out) +
                                                    " results; size the output like the points");
}

}  // namespace

// Next-event estimation at x plus one cosine-sampled path. Each vertex adds the emission it sees
// (pi Le, the cosine-sampling estimator of \int Le cos) and, after the albedo is folded into the
// throughput, its own direct light.
glm::vec3 irradiance_sample(const RayScene& scene, std::span<const WorldLight> lights, glm::vec3 x, glm::vec3 n,
                            const IrradianceSettings& s, Rng& rng) {
  // Light arriving straight at x (the lights' and, below, the first hit's emission) is direct.
  const bool direct = s.content == LightingContent::All;
  glm::vec3 sum = direct ? direct_light(scene, lights, x, n, s.rect_light_samples, rng) : glm::vec3(0.0f);
  glm::vec3 throughput(1.0f);
  glm::vec3 p = x, pn = n;
  for (std::uint32_t depth = 0;; ++depth) {
    const float u0 = rng.next_float(), u1 = rng.next_float();
    const glm::vec3 dir = to_world(pn, cosine_hemisphere({u0, u1}));
    const Ray ray{p + scene.ray_epsilon(p) * pn, 0.0f, dir, kInf};
    Hit hit;
    if (!scene.intersect(ray, hit)) {  // the sky (pi L, as emission below); ambient: counted in Indirect too
      sum += throughput * (kPi * scene.sky(dir));
      break;
    }
    // Emission of the surface hit (front side, or both when double sided).
    if ((depth > 0 || direct) && (!hit.back_face || hit.material.double_sided))
      sum += throughput * (kPi * hit.material.emissive);
    if (!s.reference && depth >= s.bounces) break;
    // Reflect: Lambertian, on the side the path arrived from.
    throughput *= hit.material.albedo;
    if (s.reference && depth + 1 >= s.roulette_depth) {
      const float q = std::min(0.95f, std::max({hit.material.albedo.x, hit.material.albedo.y, hit.material.albedo.z}));
      if (!(q > 0.0f) || rng.next_float() >= q) break;
      throughput /= q;
    }
    if (throughput == glm::vec3(0.0f)) break;
    p = ray.origin + hit.t * dir;
    pn = hit.back_face ? -hit.normal : hit.normal;
    sum += throughput * direct_light(scene, lights, p, pn, s.rect_light_samples, rng);
  }
  return sum;
}

AoEstimate ambient_occlusion(const RayScene& scene, glm::vec3 x, glm::vec3 n, float max_distance,
                             std::uint32_t rays, Rng& rng, AoSampling sampling) {
  const glm::vec3 origin = x + scene.ray_epsilon(x) * n;
  glm::vec3 t, b;
  orthonormal_basis(n, t, b);
  const bool sobol = sampling == AoSampling::Sobol;
  // Sobol: replicate r holds rays [r m, (r + 1) m), points 0..m-1 of its own scramble.
  const std::uint32_t per_replicate = sobol ? (rays + kAoReplicates - 1) / kAoReplicates : rays;
  const std::uint32_t total = sobol ? per_replicate * kAoReplicates : rays;
  std::array<Sobol2D, kAoReplicates> scramble{Sobol2D(0), Sobol2D(0), Sobol2D(0), Sobol2D(0)};
  std::array<std::uint32_t, kAoReplicates> replicate_open{};
  if (sobol)
    for (Sobol2D& s : scramble) s = Sobol2D(rng.next_u32());
  // Trace in blocks of 64 (four packets of 16): generating a block, then tracing it.
  constexpr std::uint32_t kBlock = 64;
  std::array<Ray, kBlock> block;
  std::array<std::uint8_t, kBlock> hit{};
  std::uint32_t open = 0;
  std::uint32_t replicate = 0, point = 0;  // of the next Sobol' ray
  std::array<std::uint8_t, kBlock> of{};   // each ray's replicate
  for (std::uint32_t first = 0; first < total; first += kBlock) {
    const std::uint32_t count = std::min(kBlock, total - first);
    for (std::uint32_t i = 0; i < count; ++i) {
      glm::vec2 u;
      if (sobol) {
        u = scramble[replicate](point);
        of[i] = static_cast<std::uint8_t>(replicate);
        if (++point == per_replicate) {
          point = 0;
          ++replicate;
        }
      } else {
        u.x = rng.next_float();
        u.y = rng.next_float();
      }
      const glm::vec3 d = cosine_hemisphere(u);
      block[i] = Ray{origin, 0.0f, d.x * t + d.y * b + d.z * n, max_distance};
    }
    scene.occluded(std::span<const Ray>(block.data(), count), std::span<std::uint8_t>(hit.data(), count));
    for (std::uint32_t i = 0; i < count; ++i) {
      const std::uint32_t o = hit[i] == 0 ? 1u : 0u;
      open += o;
      if (sobol) replicate_open[of[i]] += o;
    }
  }
  AoEstimate e;
  e.samples = total;
  if (total == 0) return e;
  const double a = double(open) / double(total);
  e.value = float(a);
  if (sobol) {
    // The replicates' means are independent and unbiased: their sample variance / R.
    double var = 0.0;
    for (std::uint32_t o : replicate_open) {
      const double d = double(o) / double(per_replicate) - a;
      var += d * d;
    }
    e.std_error = float(std::sqrt(var / double(kAoReplicates - 1) / double(kAoReplicates)));
  } else if (total > 1) {
    // Bernoulli samples: mean a, Bessel-corrected variance a (1 - a) N / (N - 1).
    e.std_error = float(std::sqrt(a * (1.0 - a) / double(total - 1)));
  }
  return e;
}

Status ambient_occlusion(const RayScene& scene, std::span<const SurfacePoint> points, const AoSettings& settings,
                         std::span<AoEstimate> out, JobContext& jobs) {
  PENUMBRA_TRY(check_points(points.size(), out.size(), "ambient_occlusion"));
  if (settings.rays < 2) {
    return make_error(ErrorCode::InvalidArgument, "ambient_occlusion: AoSettings::rays is " +
                                                      std::to_string(settings.rays) + "; use at least 2");
  }
  if (!(settings.max_distance > 0.0f)) {
    return make_error(ErrorCode::InvalidArgument, "ambient_occlusion: AoSettings::max_distance is " +
                                                      std::to_string(settings.max_distance) +
                                                      "; use a positive distance (or infinity)");
  }
  jobs.begin_stage("ambient occlusion", points.size());
  return jobs.parallel_for(points.size(), 16, [&](std::size_t begin, std::size_t end) {
    for (std::size_t i = begin; i < end; ++i) {
      Rng rng = Rng::stream(settings.seed, settings.first_stream + i);
      out[i] = ambient_occlusion(scene, points[i].position, points[i].normal, settings.max_distance, settings.rays,
                                 rng, settings.sampling);
    }
  });
}

std::vector<WorldLight> gather_lights(World& world) {
  std::vector<WorldLight> lights;
  world.view<Light, WorldTransform>().each([&](Entity e, Light& light, WorldTransform& wt) {
    const LightFrame frame = light_frame(light, wt.matrix);
    WorldLight wl;
    wl.light = light;
    wl.entity = e;
    wl.position = frame.position;
    wl.half_x = frame.half_x;
    wl.half_y = frame.half_y;
    const bool zero_rect = frame.zero_rect;
    if (!frame.valid || zero_rect) {
      log(LogLevel::Warning, "gather_lights: light entity " + std::to_string(e.index) +
                                 (zero_rect ? " is a rect of zero area" : " has a non-finite or singular transform") +
                                 "; it is skipped (fix its Transform or Light::size)");
      return;
    }
    wl.direction = frame.direction;
    lights.push_back(wl);
  });
  std::sort(lights.begin(), lights.end(),
            [](const WorldLight& a, const WorldLight& b) { return a.entity.index < b.entity.index; });
  return lights;
}

std::vector<WorldLight> baked_lights(World& world) {
  std::vector<WorldLight> lights = gather_lights(world);
  std::erase_if(lights, [&](const WorldLight& l) {
    const DynamicLight* d = world.try_get<DynamicLight>(l.entity);
    return d != nullptr && d->enabled;
  });
  return lights;
}

Estimate irradiance(const RayScene& scene, std::span<const WorldLight> lights, glm::vec3 x, glm::vec3 n,
                    const IrradianceSettings& settings, Rng& rng) {
  Accumulator acc;
  for (std::uint32_t k = 0; k < settings.samples; ++k) acc.add(irradiance_sample(scene, lights, x, n, settings, rng));
  return acc.estimate();
}

Status irradiance(const RayScene& scene, std::span<const WorldLight> lights, std::span<const SurfacePoint> points,
                  const IrradianceSettings& settings, std::span<Estimate> out, JobContext& jobs) {
  PENUMBRA_TRY(check_points(points.size(), out.size(), "irradiance"));
  if (settings.samples < 2) {
    return make_error(ErrorCode::InvalidArgument, "irradiance: IrradianceSettings::samples is " +
                                                      std::to_string(settings.samples) + "; use at least 2");
  }
  jobs.begin_stage("irradiance", points.size());
  return jobs.parallel_for(points.size(), 4, [&](std::size_t begin, std::size_t end) {
    for (std::size_t i = begin; i < end; ++i) {
      Rng rng = Rng::stream(settings.seed, i);
      out[i] = irradiance(scene, lights, points[i].position, points[i].normal, settings, rng);
    }
  });
}

}  // namespace penumbra
