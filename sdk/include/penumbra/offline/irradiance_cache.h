// Irradiance caching (Ward, Rubinstein & Clear 1988) with irradiance gradients (Ward & Heckbert
// 1992) and neighbour clamping (Křivánek et al. 2006): the baseline irradiance filtering is
// measured against (offline_renderer.h, mode IrradianceCache).
//
// A record at x_i (normal n_i) holds the irradiance E_i from M x N stratified cosine rays (M rings
// equal in projected solid angle, sin^2 theta = (j + u) / M; N = rays / M sectors), the harmonic
// mean distance R_i of those rays, and the gradients of E under translation along the surface and
// rotation of the normal, derived from the same rays: for the translation, the strata boundaries
// move by 1 / (distance seen at the boundary) (Ward & Heckbert's formula, each boundary at the
// nearer of its two strata's hits); for the rotation, d E / d n = pi / (M N) sum L tan(theta) e_rho.
// A point (x, n) is interpolated from the records whose Ward error
//   eps_i = |x - x_i| / R_i + sqrt(1 - n . n_i)
// is below the accuracy a, weighted by 1 / eps_i - 1 / a (zero at the edge: no seams), with each
// record extrapolated by its gradients; records in front of x are skipped.
//
// Records are made for the pixels of an image, coarse to fine (every 32nd pixel per axis first,
// then 16th, ... 1st): at each level the pixels that no record covers get one, made in parallel;
// then, in pixel order, each new record's R is clamped to [min_radius, max_radius] pixel footprints
// / a, to R_j + |x_i - x_j| for its neighbours j (neighbour clamping), and to E / |grad_t E| (so
// that the extrapolation stays positive), and inserted into the screen tiles its influence covers.
// The result is deterministic at any thread count.
#pragma once

#include <cstdint>
#include <functional>
#include <span>

#include <glm/mat3x3.hpp>
#include <glm/vec3.hpp>

#include "penumbra/core/random.h"
#include "penumbra/core/result.h"

namespace penumbra {

class JobContext;

// One incident sample: pi x the radiance arriving along the direction (the cosine-sampling
// estimate of E), and the distance to what it hit (+inf for a miss).
struct IncidentSample {
  glm::vec3 value{0.0f};
  float distance = 0.0f;
};
// Traces direction `dir` (unit) from surface point x (unit normal n); draws from rng.
using IncidentFn = std::function<IncidentSample(glm::vec3 x, glm::vec3 n, glm::vec3 dir, Rng& rng)>;

struct CacheRecord {
  glm::vec3 position{0.0f}, normal{0.0f};
  glm::vec3 irradiance{0.0f};
  float radius = 0.0f;  // R_i, metres (+inf before clamping when every ray escaped)
  // Column c: the gradient of channel c, in world space (both lie in the record's tangent plane).
  glm::mat3 translational{0.0f}, rotational{0.0f};
};

// A record at (x, n) from `rays` stratified cosine rays (rounded to M x N, M = max(2, round(sqrt(rays
// / pi))), N = max(3, round(rays / M))). Non-finite samples count as black and are added to
// *nonfinite. Cost: M x N incident samples.
CacheRecord make_cache_record(glm::vec3 x, glm::vec3 n, std::uint32_t rays, Rng& rng, const IncidentFn& incident,
                              std::uint32_t* nonfinite = nullptr);

// The rays make_cache_record traces for `rays` (M x N).
std::uint32_t cache_record_rays(std::uint32_t rays);

// The record's weight at (x, n): 1 / eps - 1 / a, or 0 when eps >= a or the record is in front of
// x; and its extrapolation there (each channel clamped at 0).
float cache_weight(const CacheRecord& record, glm::vec3 x, glm::vec3 n, float accuracy);
glm::vec3 cache_extrapolate(const CacheRecord& record, glm::vec3 x, glm::vec3 n);

// What the cache reads of one pixel.
struct CachePixel {
  glm::vec3 position{0.0f}, normal{0.0f};
  float footprint = 0.0f;  // world-space width of the pixel at position (> 0)
  bool surface = false;
};

struct IrradianceCacheSettings {
  float accuracy = 0.2f;         // a: larger is faster and coarser
  std::uint32_t rays = 256;      // per record
  float min_radius = 1.5f;       // a R_i at least this many pixel footprints
  float max_radius = 64.0f;      // and at most this many
  std::uint64_t seed = 1;
};

struct IrradianceCacheStats {
  std::uint64_t records = 0;
  std::uint64_t rays = 0;
  std::uint64_t nonfinite = 0;
};

// Irradiance at every surface pixel from a cache filled for the image (above); 0 elsewhere.
// InvalidArgument for sizes that do not match, accuracy <= 0, rays < 6 or radii out of order;
// Cancelled when the host cancels (stages "irradiance cache", "cache interpolation").
Status irradiance_cache(std::span<const CachePixel> pixels, std::uint32_t width, std::uint32_t height,
                        const IrradianceCacheSettings& settings, const IncidentFn& incident, std::span<glm::vec3> out,
                        IrradianceCacheStats& stats, JobContext& jobs);

}  // namespace penumbra
