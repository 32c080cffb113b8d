// Irradiance filtering (Kontkanen, Räsänen & Keller 2004): the gather over each pixel's window.
#include "penumbra/offline/irradiance_filter.h"

#include <algorithm>
#include <cmath>
#include <string>

#include <glm/geometric.hpp>

#include "penumbra/core/jobs.h"

namespace penumbra {
namespace {

Status check(std::size_t pixels, std::size_t out, std::uint32_t width, std::uint32_t height,
             const IrradianceFilterSettings& s, const char* what) {
  if (pixels != std::size_t(width) * height || out != pixels)
    return make_error(ErrorCode::InvalidArgument, std::string(what) + ": " + std::to_string(pixels) + " pixels and " +
                                                      std::to_string(out) + " outputs for a " + std::to_string(width) +
                                                      "x" + std::to_string(height) + " image; size both as the image");
  if (!(s.a > 0.0f) || !std::isfinite(s.a))
    return make_error(ErrorCode::InvalidArgument, std::string(what) + ": the kernel radius a must be positive");
  return {};
}

// Calls fn(q, K(ε_pq / a)) for each pixel q of p's window with a non-zero weight, in row-major
// order (the order every sum is taken in).
template <class Fn>
void gather(std::span<const FilterPixel> pixels, std::uint32_t width, std::uint32_t height,
            const IrradianceFilterSettings& s, std::size_t p, Fn&& fn) {
  const FilterPixel& c = pixels[p];
  // The window covering the world-space radius 2 a m_p (the kernel is zero beyond t = 2).
  std::uint32_t radius = s.max_radius;
  if (std::isfinite(c.harmonic_distance)) {
    const float r = std::ceil(2.0f * s.a * c.harmonic_distance / c.footprint);
    radius = r < float(s.max_radius) ? static_cast<std::uint32_t>(std::max(r, 0.0f)) : s.max_radius;
  }
  const auto px = static_cast<std::int64_t>(p % width), py = static_cast<std::int64_t>(p / width);
  const std::int64_t r = radius;
  const std::int64_t x0 = std::max<std::int64_t>(0, px - r), x1 = std::min<std::int64_t>(width - 1, px + r);
  const std::int64_t y0 = std::max<std::int64_t>(0, py - r), y1 = std::min<std::int64_t>(height - 1, py + r);
  const float inv_m = std::isfinite(c.harmonic_distance) ? 1.0f / c.harmonic_distance : 0.0f;
  const float inv_a = 1.0f / s.a;
  for (std::int64_t y = y0; y <= y1; ++y) {
    for (std::int64_t x = x0; x <= x1; ++x) {
      const std::size_t q = std::size_t(y) * width + std::size_t(x);
      const FilterPixel& o = pixels[q];
      if (o.samples == 0) continue;
      // Ward's distance: the change predicted by moving along the surface and by turning, the
      // surface term by the nearer geometry of the two pixels (a corner's pixel does not blur
      // into an open neighbour's kernel, nor the open one into the corner's).
      const float inv_mq = std::isfinite(o.harmonic_distance) ? 1.0f / o.harmonic_distance : 0.0f;
      const float eps = glm::distance(c.position, o.position) * std::max(inv_m, inv_mq) +
                        std::sqrt(std::max(0.0f, 1.0f - glm::dot(c.normal, o.normal)));
      const float t = eps * inv_a;
      if (!(t <= 2.0f)) continue;
      fn(q, std::exp(-t * t));
    }
  }
}

}  // namespace

Status irradiance_filter_support(std::span<const FilterPixel> pixels, std::uint32_t width, std::uint32_t height,
                                 const IrradianceFilterSettings& settings, std::span<float> out, JobContext& jobs) {
  PENUMBRA_TRY(check(pixels.size(), out.size(), width, height, settings, "irradiance_filter_support"));
  jobs.begin_stage("filter support", pixels.size());
  return jobs.parallel_for(pixels.size(), 256, [&](std::size_t begin, std::size_t end) {
    for (std::size_t p = begin; p < end; ++p) {
      float sum = 0.0f;
      if (pixels[p].samples != 0) gather(pixels, width, height, settings, p, [&](std::size_t, float w) { sum += w; });
      out[p] = sum;
    }
  });
}

Status filter_irradiance(std::span<const FilterPixel> pixels, std::uint32_t width, std::uint32_t height,
                         const IrradianceFilterSettings& settings, std::span<glm::vec3> out, JobContext& jobs) {
  PENUMBRA_TRY(check(pixels.size(), out.size(), width, height, settings, "filter_irradiance"));
  jobs.begin_stage("irradiance filter", pixels.size());
  return jobs.parallel_for(pixels.size(), 256, [&](std::size_t begin, std::size_t end) {
    for (std::size_t p = begin; p < end; ++p) {
      glm::dvec3 sum(0.0);
      double weight = 0.0;
      if (pixels[p].samples != 0) {
        gather(pixels, width, height, settings, p, [&](std::size_t q, float w) {
          const double wq = double(w) * double(pixels[q].samples);
          sum += wq * glm::dvec3(pixels[q].irradiance);
          weight += wq;
        });
      }
      // The pixel itself always has weight K(0) N_p > 0, so weight is 0 only without a surface.
      out[p] = weight > 0.0 ? glm::vec3(sum / weight) : glm::vec3(0.0f);
    }
  });
}

}  // namespace penumbra
