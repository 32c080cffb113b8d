// Irradiance filtering (Kontkanen, Räsänen & Keller 2004; thesis section 3.1): a spatially varying
// low-pass filter over noisy per-pixel indirect irradiance, driven by the predictor of irradiance
// caching (Ward 1988).
//
// Each pixel p holds its primary hit x_p (normal n_p), a noisy estimate Ê_p from N_p rays and the
// harmonic mean distance of those rays (misses count as infinitely far). The filtered irradiance is
//   Ē_p = sum_q K(ε_pq / a) N_q Ê_q / sum_q K(ε_pq / a) N_q,
//   ε_pq = |x_p - x_q| / min(m_p, m_q) + sqrt(1 - n_p . n_q)   (Ward's distance),
//   K(t) = exp(-t^2), 0 for t > 2,
// gathered over the screen window that covers the world-space radius 2 a m_p around x_p.
// - The predictor m_p is the harmonic mean distance of every ray of p's (2 r + 1)^2 neighbourhood
//   that lies on p's surface (predictor_radius r; the paper takes p's own rays, r = 0). The rays
//   that estimate Ê_p then no longer decide alone how widely p is blurred: with one ray per pixel,
//   a pixel whose ray escaped to the sky blurred over every other escaped ray and away from those
//   that met a wall, which made the courtyard 5 % too dark (net relative error 0.109 at 1 spp,
//   0.040 pooled; penumbra bench irradiance-filter).
// - The surface term takes the nearer geometry of the two pixels (the paper's predictor uses the
//   receiver's m_p alone): a corner pixel then stays out of an open neighbour's kernel as well as
//   the open one out of the corner's, which halved the courtyard's error at 8 rays per pixel.
// - Weighting by N_q averages every ray in the kernel once, so pixels given more rays (adaptive
//   sampling) count more.
// Where the predictor expects fast change (small m_p: corners, contacts) the kernel shrinks to the
// pixel itself; on open surfaces it spans many pixels. The filter is biased (pixels sample world
// space unevenly and the predictor can miss detail) and never creates light: every output is a
// convex combination of inputs, so a scene without indirect light filters to zero.
#pragma once

#include <cstdint>
#include <span>

#include <glm/vec3.hpp>

#include "penumbra/core/isa.h"
#include "penumbra/core/result.h"

namespace penumbra {

class JobContext;

// What the filter reads of one pixel.
struct FilterPixel {
  glm::vec3 position{0.0f};   // primary hit x_p
  glm::vec3 normal{0.0f};     // unit, on the side the camera sees
  float footprint = 0.0f;     // world-space width of the pixel at x_p (> 0)
  glm::vec3 irradiance{0.0f}; // noisy Ê_p, finite
  float harmonic_distance = 0.0f;  // of p's own rays (> 0; +inf when every ray escaped)
  std::uint32_t samples = 0;  // N_p; 0: no surface (not filtered, never gathered)
};

// The largest gather and predictor half-widths the filter takes, in pixels.
inline constexpr std::uint32_t kMaxFilterRadius = 256;
inline constexpr std::uint32_t kMaxPredictorRadius = 8;

struct IrradianceFilterSettings {
  // The kernel's reconstruction radius a (the paper uses about 0.1-0.3): larger is smoother and more
  // biased near changes of irradiance.
  float a = 0.2f;
  // The gather window's largest half-width in pixels, at most kMaxFilterRadius (the cost per pixel
  // is (2 r + 1)^2 taps).
  std::uint32_t max_radius = 12;
  // The half-width of the neighbourhood whose rays give the predictor m_p, at most
  // kMaxPredictorRadius (0: p's own rays). Neighbours count when on p's surface: normals within
  // about 25 degrees and within one pixel footprint of p's tangent plane.
  std::uint32_t predictor_radius = 1;
};

// The filter's support at each pixel: sum_q K(ε_pq / a) over its window (1 for a kernel that
// holds only the pixel itself; 0 where samples == 0), or a value of at least `limit` where the
// rows gathered so far reach it (the gather stops there: open surfaces cost a few rows). What
// adaptive sampling sizes the rays by: a pixel whose kernel holds few neighbours needs more rays
// of its own. Preconditions (else an InvalidArgument error): pixels.size() == out.size() ==
// width * height, a > 0 and the radii within their limits. Cost: O(pixels x (window taps +
// predictor taps)), the window's in parallel on `jobs` (stage "filter support"). Cancelled when
// the host cancels. `isa`: the gather's AVX2 and portable paths give the same bits (no fused
// multiply-adds, the same partial sums).
Status irradiance_filter_support(std::span<const FilterPixel> pixels, std::uint32_t width, std::uint32_t height,
                                 const IrradianceFilterSettings& settings, float limit, std::span<float> out,
                                 JobContext& jobs, Isa isa = Isa::Best);

// Ē at every pixel (0 where samples == 0). Same preconditions and cost (stage "irradiance filter").
// Deterministic: each output is a fixed-order sum over its window.
Status filter_irradiance(std::span<const FilterPixel> pixels, std::uint32_t width, std::uint32_t height,
                         const IrradianceFilterSettings& settings, std::span<glm::vec3> out, JobContext& jobs,
                         Isa isa = Isa::Best);

}  // namespace penumbra
