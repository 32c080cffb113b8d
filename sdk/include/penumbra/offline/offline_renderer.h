// The offline renderer: a CPU ray tracer over a RayScene that renders the same frame as the
// real-time renderer (scene/camera.h: one ray through each pixel's centre), with the light the
// real-time path approximates computed properly. It is the SDK's reference image and its
// showcase of irradiance filtering (P1, offline/irradiance_filter.h).
//
// Per pixel: the primary hit (albedo, emission, geometric normal on the side the camera sees;
// misses show the sky, rect lights their radiance from the side they shine to, as a light that is
// not geometry: not covered, like the real-time renderer's emitter quads); direct light from every light by next-event estimation with area lights
// sampled over their area (soft shadows; bake/light_sampling.h); indirect irradiance E_i (all
// light arriving at x that is not a light's: bounces, the sky, emissive surfaces) by cosine-
// distributed paths with next-event estimation at every vertex and Russian roulette (unbiased;
// bake/integrators.h). Radiance: lit = Le + albedo / pi (E_d + E_i); the views "direct" and
// "indirect" hold albedo / pi E_d and albedo / pi E_i, as the real-time views of those names.
// The albedo at the primary hit is textured when `textures` are given (offline/surface_textures.h;
// deeper path vertices take the surface's mean albedo, as the bakes do); the normal is the
// geometric one, so smooth-shaded meshes come out flat-shaded.
//
// Indirect modes:
//   MonteCarlo        spp cosine rays per pixel (a scrambled Sobol' net per pixel), averaged.
//   IrradianceFilter  spp rays per pixel, then (adaptive) more rays where the filter's support is
//                     small (irradiance_filter_support below target_support), up to max_boost x
//                     spp, then filter_irradiance; the albedo multiplies the filtered irradiance.
//   IrradianceCache   records of spp stratified rays with gradients where no record covers a
//                     pixel, interpolated (offline/irradiance_cache.h; the paper's baseline).
//   Reference         spp independent rays and max(direct_samples, spp) direct estimates per
//                     pixel, with the standard error of every pixel of each view.
//
// Determinism: pixel i draws from Rng::stream(seed, i) in each pass (and the filter is a fixed-
// order gather), so the image is bit-identical at any thread count. Samples that come out
// non-finite are dropped and counted (OfflineImage::nonfinite_samples); they never reach a pixel.
#pragma once

#include <cstdint>
#include <optional>
#include <span>
#include <string_view>
#include <vector>

#include <glm/vec3.hpp>

#include "penumbra/bake/integrators.h"
#include "penumbra/bake/ray_scene.h"
#include "penumbra/core/jobs.h"
#include "penumbra/core/result.h"
#include "penumbra/offline/irradiance_cache.h"
#include "penumbra/offline/irradiance_filter.h"
#include "penumbra/offline/surface_textures.h"
#include "penumbra/scene/camera.h"

namespace penumbra {

enum class OfflineMode : std::uint8_t { MonteCarlo, IrradianceFilter, IrradianceCache, Reference };
// "mc", "irradiance-filter", "irradiance-cache", "reference".
std::string_view to_string(OfflineMode mode);
std::optional<OfflineMode> parse_offline_mode(std::string_view name);
// Every mode's name, comma separated (for usage messages).
std::string_view offline_mode_names();

struct OfflineSettings {
  OfflineMode mode = OfflineMode::IrradianceFilter;
  std::uint32_t width = 640, height = 360;
  // Indirect rays per pixel: the count for MonteCarlo and Reference, the first pass of
  // IrradianceFilter, the rays per record of IrradianceCache. At least 1 (2 for Reference, which
  // needs a spread; 6 for IrradianceCache, 2 x 3 strata).
  std::uint32_t spp = 16;
  // Direct-light estimates per pixel (each with rect_light_samples points per rect light);
  // Reference takes max(this, spp).
  std::uint32_t direct_samples = 4;
  std::uint32_t rect_light_samples = 16;
  std::uint32_t path_rect_light_samples = 4;  // per rect light at each vertex of an indirect path
  IrradianceFilterSettings filter;
  float target_support = 32.0f;   // IrradianceFilter: the support below which a pixel gets more rays
  std::uint32_t max_boost = 16;   // IrradianceFilter: at most this x spp rays in a pixel
  IrradianceCacheSettings cache;  // IrradianceCache: accuracy and radius bounds (rays = spp, seed = seed)
  std::uint64_t seed = 1;
};

struct OfflineImage {
  std::uint32_t width = 0, height = 0;
  // Linear radiance per pixel, row-major from the top-left.
  std::vector<glm::vec3> lit, direct, indirect, albedo;
  // Reference: the standard error of `lit`, `direct` and `indirect` (per channel); other modes: empty.
  std::vector<glm::vec3> lit_std_error, direct_std_error, indirect_std_error;
  std::vector<std::uint8_t> covered;  // 1 where the pixel's ray hit a surface
  std::uint64_t covered_pixels = 0;
  std::uint64_t indirect_samples = 0;   // paths traced for E_i, all pixels
  std::uint64_t cache_records = 0;      // IrradianceCache: records made
  std::uint64_t nonfinite_samples = 0;  // dropped
  double seconds = 0.0;                 // wall-clock time of render_offline
};

// Renders the camera's frame. InvalidArgument for a zero size, spp 0 (or 1 in Reference) or a
// filter setting out of range; Cancelled when the host cancels. Progress: stages "primary",
// "direct", "indirect" (and for IrradianceFilter "filter support", "adaptive indirect",
// "irradiance filter"). Cost: about pixels x spp x (path length) x (1 + lights + rect samples)
// rays; IrradianceFilter adds at most (max_boost - 1) x spp rays where its support is small and
// O(pixels x window) for the filter. Thread-safe on a const scene.
Result<OfflineImage> render_offline(const RayScene& scene, std::span<const WorldLight> lights, const CameraView& camera,
                                    const OfflineSettings& settings, JobContext& jobs,
                                    const SurfaceTextures* textures = nullptr);

}  // namespace penumbra
