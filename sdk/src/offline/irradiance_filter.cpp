// Irradiance filtering (Kontkanen, Räsänen & Keller 2004): the gather over each pixel's window.
//
// The window is gathered a row at a time: the kernel weights of a row's taps are computed into a
// small buffer by a loop without branches over structure-of-arrays copies of the pixels (the
// compiler turns it into SIMD code), then added into eight interleaved partial sums. Every sum is
// taken in an order fixed by the image and the window alone, so the output does not depend on how
// the work is split.
#include "penumbra/offline/irradiance_filter.h"

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <string>
#include <vector>

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
  if (s.predictor_radius > kMaxPredictorRadius)
    return make_error(ErrorCode::InvalidArgument, std::string(what) + ": predictor_radius " +
                                                      std::to_string(s.predictor_radius) + " is above " +
                                                      std::to_string(kMaxPredictorRadius));
  if (s.max_radius > kMaxFilterRadius)
    return make_error(ErrorCode::InvalidArgument, std::string(what) + ": max_radius " + std::to_string(s.max_radius) +
                                                      " is above " + std::to_string(kMaxFilterRadius));
  return {};
}

// exp(-u) for u in [0, 4] (the kernel's support, t <= 2), within 1e-6 relative: 2^y with
// y = -u log2(e) split into an integer part (the exponent bits) and a fraction (a degree-7
// polynomial of 2^f on [0, 1), Taylor coefficients of e^(f ln 2)). Written without branches or
// calls so that the row loop vectorises.
inline float kernel_exp(float u) {
  const float y = -1.44269504f * u;          // in [-5.78, 0]
  const float yi = float(int(y));            // truncation: ceil for y <= 0
  const float n = yi > y ? yi - 1.0f : yi;   // floor
  const float f = y - n;                     // [0, 1)
  const float g = f * 0.69314718f;
  const float p =
      1.0f + g * (1.0f + g * (0.5f + g * (1.6666667e-1f + g * (4.1666668e-2f + g * (8.3333338e-3f + g * (1.3888889e-3f + g * 1.9841270e-4f))))));
  const float scale = std::bit_cast<float>((int(n) + 127) << 23);  // 2^n, n in [-6, 0]
  return p * scale;
}

// The gather's rows run in blocks of kLanes taps: the kernel loop and the partial sums (LaneSums)
// vectorise without a scalar tail.
constexpr std::size_t kLanes = 8;
std::vector<float> padded(std::span<const FilterPixel> pixels) { return std::vector<float>(pixels.size() + kLanes, 0.0f); }

// The pixels as the gather reads them: one array per quantity.
struct Columns {
  std::vector<float> x, y, z, nx, ny, nz;
  std::vector<float> inv_m;   // 1 / m_q, the pooled predictor (0: every ray escaped)
  std::vector<float> valid;   // 1 where samples > 0, else 0 (such a pixel gets weight 0)
  // Each array holds kLanes zeros past the last pixel, so a row's loop may run to a multiple of
  // kLanes.
  Columns(std::span<const FilterPixel> pixels, std::uint32_t width, std::uint32_t height, std::uint32_t pool)
      : x(padded(pixels)), y(padded(pixels)), z(padded(pixels)), nx(padded(pixels)), ny(padded(pixels)),
        nz(padded(pixels)), inv_m(padded(pixels)), valid(padded(pixels)) {
    for (std::size_t i = 0; i < pixels.size(); ++i) {
      const FilterPixel& p = pixels[i];
      const bool ok = p.samples != 0;
      x[i] = ok ? p.position.x : 0.0f;
      y[i] = ok ? p.position.y : 0.0f;
      z[i] = ok ? p.position.z : 0.0f;
      nx[i] = ok ? p.normal.x : 0.0f;
      ny[i] = ok ? p.normal.y : 0.0f;
      nz[i] = ok ? p.normal.z : 0.0f;
      valid[i] = ok ? 1.0f : 0.0f;
    }
    // The predictor: the harmonic mean distance of every ray of p's neighbourhood on p's surface,
    // N / sum(1 / d), with sum(1 / d) = N_q / m_q per pixel.
    for (std::size_t i = 0; i < pixels.size(); ++i) {
      const FilterPixel& p = pixels[i];
      if (p.samples == 0) continue;
      const auto px = static_cast<std::int64_t>(i % width), py = static_cast<std::int64_t>(i / width);
      const std::int64_t r = pool;
      double inverse = 0.0, rays = 0.0;
      for (std::int64_t yy = std::max<std::int64_t>(0, py - r); yy <= std::min<std::int64_t>(height - 1, py + r); ++yy) {
        for (std::int64_t xx = std::max<std::int64_t>(0, px - r); xx <= std::min<std::int64_t>(width - 1, px + r); ++xx) {
          const FilterPixel& q = pixels[std::size_t(yy) * width + std::size_t(xx)];
          if (q.samples == 0 || !on_surface_of(p, q)) continue;
          if (std::isfinite(q.harmonic_distance)) inverse += double(q.samples) / double(q.harmonic_distance);
          rays += double(q.samples);
        }
      }
      // p counts itself unless its normal is degenerate; then its own rays decide.
      inv_m[i] = rays > 0.0 ? float(inverse / rays)
                            : (std::isfinite(p.harmonic_distance) ? 1.0f / p.harmonic_distance : 0.0f);
    }
  }
  // Whether q lies on p's surface: normals within about 25 degrees and q within one pixel
  // footprint of p's tangent plane (a silhouette's background is not).
  static bool on_surface_of(const FilterPixel& p, const FilterPixel& q) {
    return glm::dot(p.normal, q.normal) >= 0.9f && std::abs(glm::dot(p.normal, q.position - p.position)) <= p.footprint;
  }
};

// Calls row(q0, w, n) for each row of p's window, in order, until it returns false: w[k] = K(ε_pq / a) for the pixel
// q = q0 + k (0 where q has no samples or lies beyond the kernel's support t = 2, and for the taps
// past the row's end that round n up to a multiple of kLanes).
template <class Row>
void gather(const Columns& c, std::span<const FilterPixel> pixels, std::uint32_t width, std::uint32_t height,
            const IrradianceFilterSettings& s, std::size_t p, float* w, Row&& row) {
  const FilterPixel& centre = pixels[p];
  // The window covering the world-space radius 2 a m_p (the kernel is zero beyond t = 2).
  std::uint32_t radius = s.max_radius;
  if (c.inv_m[p] > 0.0f) {
    const float r = std::ceil(2.0f * s.a / (c.inv_m[p] * centre.footprint));
    radius = r < float(s.max_radius) ? static_cast<std::uint32_t>(std::max(r, 0.0f)) : s.max_radius;
  }
  const auto px = static_cast<std::int64_t>(p % width), py = static_cast<std::int64_t>(p / width);
  const std::int64_t r = radius;
  const std::int64_t x0 = std::max<std::int64_t>(0, px - r), x1 = std::min<std::int64_t>(width - 1, px + r);
  const std::int64_t y0 = std::max<std::int64_t>(0, py - r), y1 = std::min<std::int64_t>(height - 1, py + r);
  const std::size_t count = std::size_t(x1 - x0 + 1), blocks = (count + kLanes - 1) / kLanes * kLanes;
  const float cx = c.x[p], cy = c.y[p], cz = c.z[p], cnx = c.nx[p], cny = c.ny[p], cnz = c.nz[p];
  const float inv_m = c.inv_m[p], inv_a = 1.0f / s.a;
  for (std::int64_t yy = y0; yy <= y1; ++yy) {
    const std::size_t q0 = std::size_t(yy) * width + std::size_t(x0);
    const float *__restrict qx = &c.x[q0], *__restrict qy = &c.y[q0], *__restrict qz = &c.z[q0],
                           *__restrict qnx = &c.nx[q0], *__restrict qny = &c.ny[q0], *__restrict qnz = &c.nz[q0],
                           *__restrict qm = &c.inv_m[q0], *__restrict qv = &c.valid[q0];
    float* __restrict out = w;
    for (std::size_t k = 0; k < blocks; ++k) {
      // Ward's distance: the change predicted by moving along the surface and by turning, the
      // surface term by the nearer geometry of the two pixels (a corner's pixel does not blur
      // into an open neighbour's kernel, nor the open one into the corner's).
      const float dx = qx[k] - cx, dy = qy[k] - cy, dz = qz[k] - cz;
      const float turn = std::max(0.0f, 1.0f - (cnx * qnx[k] + cny * qny[k] + cnz * qnz[k]));
      const float eps = std::sqrt(dx * dx + dy * dy + dz * dz) * std::max(inv_m, qm[k]) + std::sqrt(turn);
      const float t = eps * inv_a;
      const float u = t * t < 4.0f ? t * t : 4.0f;  // also maps a NaN (a degenerate pixel) into range
      const float k_u = kernel_exp(u) * qv[k];
      out[k] = t <= 2.0f ? k_u : 0.0f;
    }
    for (std::size_t k = count; k < blocks; ++k) out[k] = 0.0f;  // taps of the next row, or padding
    if (!row(q0, w, blocks)) return;
  }
}

// Sums of w[k] v_j[k] over a row, kept in kLanes interleaved partial sums per quantity j (lane
// k % kLanes) so that the loop vectorises; total() adds the partial sums in a fixed order.
template <std::size_t J>
struct LaneSums {
  float lane[J][kLanes] = {};
  // Adds w[k] * v[j][q0 + k] for k < n to quantity j. Precondition: n is a multiple of kLanes.
  void add(const float* w, std::size_t n, const std::array<const float*, J>& v, std::size_t q0) {
    for (std::size_t k = 0; k < n; k += kLanes)
      for (std::size_t j = 0; j < J; ++j)
        for (std::size_t l = 0; l < kLanes; ++l) lane[j][l] += w[k + l] * v[j][q0 + k + l];
  }
  float total(std::size_t j) const {
    const float* a = lane[j];
    return ((a[0] + a[1]) + (a[2] + a[3])) + ((a[4] + a[5]) + (a[6] + a[7]));
  }
};

}  // namespace

Status irradiance_filter_support(std::span<const FilterPixel> pixels, std::uint32_t width, std::uint32_t height,
                                 const IrradianceFilterSettings& settings, float limit, std::span<float> out,
                                 JobContext& jobs) {
  PENUMBRA_TRY(check(pixels.size(), out.size(), width, height, settings, "irradiance_filter_support"));
  const Columns columns(pixels, width, height, settings.predictor_radius);
  jobs.begin_stage("filter support", pixels.size());
  const std::array<const float*, 1> ones{columns.valid.data()};  // the weights are already 0 off the surface
  return jobs.parallel_for(pixels.size(), 256, [&](std::size_t begin, std::size_t end) {
    float w[(2 * kMaxFilterRadius + kLanes) / kLanes * kLanes];
    for (std::size_t p = begin; p < end; ++p) {
      LaneSums<1> sum;
      if (pixels[p].samples != 0)
        gather(columns, pixels, width, height, settings, p, w,
               [&](std::size_t q0, const float* row, std::size_t n) {
                 sum.add(row, n, ones, q0);
                 return sum.total(0) < limit;
               });
      out[p] = sum.total(0);
    }
  });
}

Status filter_irradiance(std::span<const FilterPixel> pixels, std::uint32_t width, std::uint32_t height,
                         const IrradianceFilterSettings& settings, std::span<glm::vec3> out, JobContext& jobs) {
  PENUMBRA_TRY(check(pixels.size(), out.size(), width, height, settings, "filter_irradiance"));
  const Columns columns(pixels, width, height, settings.predictor_radius);
  // Each pixel's rays N_q and their sum N_q Ê_q, so the kernel's weight K N_q averages every ray once.
  std::vector<float> rays(padded(pixels)), red(padded(pixels)), green(padded(pixels)), blue(padded(pixels));
  for (std::size_t i = 0; i < pixels.size(); ++i) {
    const float n = float(pixels[i].samples);
    rays[i] = n;
    red[i] = n * pixels[i].irradiance.x;
    green[i] = n * pixels[i].irradiance.y;
    blue[i] = n * pixels[i].irradiance.z;
  }
  const std::array<const float*, 4> values{red.data(), green.data(), blue.data(), rays.data()};
  jobs.begin_stage("irradiance filter", pixels.size());
  return jobs.parallel_for(pixels.size(), 256, [&](std::size_t begin, std::size_t end) {
    float w[(2 * kMaxFilterRadius + kLanes) / kLanes * kLanes];
    for (std::size_t p = begin; p < end; ++p) {
      LaneSums<4> sum;
      if (pixels[p].samples != 0)
        gather(columns, pixels, width, height, settings, p, w,
               [&](std::size_t q0, const float* row, std::size_t n) {
                 sum.add(row, n, values, q0);
                 return true;
               });
      // The pixel itself always has weight K(0) N_p > 0, so the weight is 0 only without a surface.
      const float weight = sum.total(3);
      out[p] = weight > 0.0f ? glm::vec3(sum.total(0), sum.total(1), sum.total(2)) / weight : glm::vec3(0.0f);
    }
  });
}

}  // namespace penumbra
