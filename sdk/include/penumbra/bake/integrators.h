// Integrators over a RayScene: ambient occlusion and irradiance (direct light from every light
// type, N indirect bounces, and an unbiased brute-force reference), at one point or in batches.
//
// Definitions (docs/algorithms.md): A(x, n) = (1/pi) \int V(x, w) max(0, w.n) dw (1 = open);
// E(x, n) = \int L(x, w) max(0, w.n) dw, in W/m^2 per RGB channel. Surfaces are Lambertian with the
// hit's SurfaceMaterial; emissive surfaces radiate from their front side (both sides when double
// sided); rect lights are not geometry, so light reaches a point either from a light (next-event
// estimation) or from an emissive surface (when a path hits it), never both. A path that leaves
// the scene brings the sky (RayScene::sky).
//
// Every estimate returns its standard error (sample standard deviation / sqrt(samples)), so a
// caller can judge whether a difference is noise. Determinism: the batch APIs draw point i's
// samples from Rng::stream(seed, i) and write by index: bit-identical at any thread count.
#pragma once

#include <cstdint>
#include <limits>
#include <span>
#include <vector>

#include <glm/vec3.hpp>

#include "penumbra/bake/ray_scene.h"
#include "penumbra/core/jobs.h"
#include "penumbra/core/random.h"
#include "penumbra/core/result.h"
#include "penumbra/ecs/world.h"
#include "penumbra/lighting/settings.h"
#include "penumbra/scene/components.h"

namespace penumbra {

// A Monte Carlo estimate: mean, standard error of the mean, number of samples.
struct AoEstimate {
  float value = 0.0f;
  float std_error = 0.0f;
  std::uint32_t samples = 0;
};
struct Estimate {
  glm::vec3 value{0.0f};
  glm::vec3 std_error{0.0f};
  std::uint32_t samples = 0;
};

// A receiver: position and unit normal (the hemisphere that is integrated).
struct SurfacePoint {
  glm::vec3 position{0.0f};
  glm::vec3 normal{0.0f, 1.0f, 0.0f};
};

// How an AO estimate places its rays over the hemisphere.
enum class AoSampling : std::uint8_t {
  // kAoReplicates independently Owen-scrambled Sobol' nets (Burley 2020) of rays / kAoReplicates
  // rays each (rays rounded up to a multiple of kAoReplicates): randomised QMC, unbiased, with
  // an error bar from the spread of the replicates' means. Reaches the noise of `Independent`
  // with fewer rays (penumbra bench rays: the rays-for-equal-noise ratio).
  Sobol,
  // Independent uniform samples: the Bernoulli error bar a (1 - a) / (N - 1).
  Independent,
};
inline constexpr std::uint32_t kAoReplicates = 4;

// Ambient occlusion at (x, n): the fraction of `rays` cosine-distributed rays that travel
// max_distance (may be +inf) without a hit. The origin is offset along n by scene.ray_epsilon(x).
// Random numbers (samples, or the Sobol' scrambles) come from `rng`, so std_error is an honest
// error bar either way; rays are traced in packets of 16. Precondition: n unit length, rays >= 2.
// Cost: `rays` occlusion rays (rounded up as above for Sobol). Thread-safe.
AoEstimate ambient_occlusion(const RayScene& scene, glm::vec3 x, glm::vec3 n, float max_distance,
                             std::uint32_t rays, Rng& rng, AoSampling sampling = AoSampling::Independent);

struct AoSettings {
  float max_distance = std::numeric_limits<float>::infinity();
  std::uint32_t rays = 256;
  std::uint64_t seed = 0;
  AoSampling sampling = AoSampling::Sobol;
  std::uint64_t first_stream = 0;  // point i draws from stream first_stream + i (a range of a larger set)
};
// AO at every point, point i from Rng::stream(settings.seed, settings.first_stream + i), in parallel on `jobs` (one
// progress stage, "ambient occlusion"). Fails with InvalidArgument for rays < 2 or a non-positive
// max_distance, Cancelled when the host cancels. out.size() must equal points.size().
Status ambient_occlusion(const RayScene& scene, std::span<const SurfacePoint> points, const AoSettings& settings,
                         std::span<AoEstimate> out, JobContext& jobs);

// A light of the World in world space (Light + WorldTransform).
struct WorldLight {
  Light light;
  glm::vec3 position{0.0f};   // point, spot, rect: centre
  glm::vec3 direction{0.0f, 0.0f, -1.0f};  // unit; directional, spot, rect: where light goes (local -Z)
  glm::vec3 half_x{0.5f, 0.0f, 0.0f};      // rect: half-size vectors along local X and Y, world space
  glm::vec3 half_y{0.0f, 0.5f, 0.0f};
  Entity entity;
};
// The lights of the World, in entity-index order. Lights with non-finite transforms or a zero-area
// rect are skipped with a logged warning. Cost: O(lights).
std::vector<WorldLight> gather_lights(World& world);
// The lights a bake of fixed lighting takes: gather_lights() less the enabled DynamicLights
// (scene/components.h), whose bounce the indirect transport carries.
std::vector<WorldLight> baked_lights(World& world);

struct IrradianceSettings {
  std::uint32_t samples = 64;             // paths per point (each also does next-event estimation at x)
  LightingContent content = LightingContent::All;  // Indirect: no light arriving straight at x
  std::uint32_t bounces = 1;              // indirect bounces (0: direct light and emitters seen from x)
  std::uint32_t rect_light_samples = 16;  // stratified (scrambled Sobol') points per rect light per vertex
  // Reference mode: unbounded bounces, Russian roulette after roulette_depth vertices (survival
  // probability = max albedo channel, at most 0.95). Unbiased; `bounces` is ignored.
  bool reference = false;
  std::uint32_t roulette_depth = 3;
  std::uint64_t seed = 0;
};

// Irradiance E(x, n) (W/m^2 per channel) from the lights (shadow rays to each; directional: one
// ray; point/spot: inverse square with the KHR_lights_punctual range window and spot cone;
// rect: stratified area sampling of L cos_x cos_l / d^2 dA) plus indirect light by cosine-sampled
// paths with next-event estimation at every vertex and emission of surfaces they hit.
// With content Indirect the next-event estimation at x and the emission of the first hit are left
// out (All - Indirect is then the lights' and emitters' direct part, up to both estimates' noise);
// the sky is ambient light, which a renderer does not draw itself: counted in both, also where x
// sees it directly.
// Precondition: n unit length, settings.samples >= 2. Cost: samples x (bounces + 1) x (lights +
// rect samples) rays. Thread-safe.
Estimate irradiance(const RayScene& scene, std::span<const WorldLight> lights, glm::vec3 x, glm::vec3 n,
                    const IrradianceSettings& settings, Rng& rng);

// One sample of irradiance() (the mean of `samples` of these): for estimators that combine the
// samples themselves. settings.samples is not read. Cost: one path. Thread-safe.
glm::vec3 irradiance_sample(const RayScene& scene, std::span<const WorldLight> lights, glm::vec3 x, glm::vec3 n,
                            const IrradianceSettings& settings, Rng& rng);

// Irradiance at every point, point i from Rng::stream(settings.seed, i), in parallel on `jobs`
// (one progress stage, "irradiance"). Fails with InvalidArgument for samples < 2, Cancelled when
// the host cancels. out.size() must equal points.size().
Status irradiance(const RayScene& scene, std::span<const WorldLight> lights, std::span<const SurfacePoint> points,
                  const IrradianceSettings& settings, std::span<Estimate> out, JobContext& jobs);

}  // namespace penumbra
