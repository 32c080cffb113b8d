// Irradiance filtering (Kontkanen, Räsänen & Keller 2004): the gather over each pixel's window.
//
// The window is gathered a row at a time over structure-of-arrays copies of the pixels, in blocks
// of eight taps whose weights are added into eight interleaved partial sums. Two paths, chosen at
// run time: the portable one computes a row's weights into a small buffer by a loop without
// branches (the compiler turns it into 4-lane SSE code on x86-64); the AVX2 one (x86-64 CPUs that
// have it) computes eight taps at a time in intrinsics and keeps the sums in registers. Each lane
// of both does the same IEEE operations in the same order and nothing contracts a multiply and an
// add (no FMA), so they give the same bits. Every sum is taken in an order fixed by the image and
// the window alone, so the output does not depend on how the work is split either.
#include "penumbra/offline/irradiance_filter.h"

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <string>
#include <vector>

#include <glm/geometric.hpp>
#if defined(__x86_64__)
#include <immintrin.h>
#endif

#include "penumbra/core/isa.h"
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
// polynomial of 2^f on [0, 1), Taylor coefficients of e^(f ln 2), in Estrin's scheme: pairs of
// terms, then g^2 and g^4, so that the steps do not wait on one another). Written without branches
// or calls so that the row loop vectorises.
constexpr float kExpTaylor[8] = {1.0f,          1.0f,          0.5f,          1.6666667e-1f,
                                 4.1666668e-2f, 8.3333338e-3f, 1.3888889e-3f, 1.9841270e-4f};
inline float kernel_exp(float u) {
  const float y = -1.44269504f * u;          // in [-5.78, 0]
  const float yi = float(int(y));            // truncation: ceil for y <= 0
  const float n = yi > y ? yi - 1.0f : yi;   // floor
  const float f = y - n;                     // [0, 1)
  const float g = f * 0.69314718f;
  const float g2 = g * g, g4 = g2 * g2;
  const float* c = kExpTaylor;
  const float p = ((c[0] + c[1] * g) + g2 * (c[2] + c[3] * g)) + g4 * ((c[4] + c[5] * g) + g2 * (c[6] + c[7] * g));
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
  explicit Columns(std::span<const FilterPixel> pixels)
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
  }
  // The predictor, inv_m: the harmonic mean distance of every ray of p's (2 pool + 1)^2
  // neighbourhood on p's surface, N / sum(1 / d), with sum(1 / d) = N_q / m_q per pixel. In
  // parallel on `jobs` (each pixel's sum in a fixed order).
  Status predict(std::span<const FilterPixel> pixels, std::uint32_t width, std::uint32_t height, std::uint32_t pool,
                 JobContext& jobs) {
    return jobs.parallel_for(pixels.size(), 256, [&](std::size_t begin, std::size_t end) {
      for (std::size_t i = begin; i < end; ++i) {
        const FilterPixel& p = pixels[i];
        if (p.samples == 0) continue;
        const auto px = static_cast<std::int64_t>(i % width), py = static_cast<std::int64_t>(i / width);
        const std::int64_t r = pool;
        double inverse = 0.0, rays = 0.0;
        for (std::int64_t yy = std::max<std::int64_t>(0, py - r); yy <= std::min<std::int64_t>(height - 1, py + r);
             ++yy) {
          for (std::int64_t xx = std::max<std::int64_t>(0, px - r); xx <= std::min<std::int64_t>(width - 1, px + r);
               ++xx) {
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
    });
  }
  // Whether q lies on p's surface: normals within about 25 degrees and q within one pixel
  // footprint of p's tangent plane (a silhouette's background is not).
  static bool on_surface_of(const FilterPixel& p, const FilterPixel& q) {
    return glm::dot(p.normal, q.normal) >= 0.9f && std::abs(glm::dot(p.normal, q.position - p.position)) <= p.footprint;
  }
};

// Pixel p's gather: its window (the screen rectangle covering the world-space radius 2 a m_p, the
// kernel being zero beyond t = 2) and what each tap's weight needs of p.
struct Window {
  std::size_t x0 = 0, y0 = 0, y1 = 0;  // columns [x0, x0 + count), rows [y0, y1]
  std::size_t count = 0, blocks = 0;   // taps per row, and that rounded up to a multiple of kLanes
  float cx = 0, cy = 0, cz = 0, cnx = 0, cny = 0, cnz = 0, inv_m = 0, inv_a2 = 0;
};

Window window_of(const Columns& c, std::span<const FilterPixel> pixels, std::uint32_t width, std::uint32_t height,
                 const IrradianceFilterSettings& s, std::size_t p) {
  std::uint32_t radius = s.max_radius;
  if (c.inv_m[p] > 0.0f) {
    const float r = std::ceil(2.0f * s.a / (c.inv_m[p] * pixels[p].footprint));
    radius = r < float(s.max_radius) ? static_cast<std::uint32_t>(std::max(r, 0.0f)) : s.max_radius;
  }
  const std::size_t px = p % width, py = p / width;
  Window w;
  w.x0 = px > radius ? px - radius : 0;
  w.y0 = py > radius ? py - radius : 0;
  w.y1 = std::min<std::size_t>(height - 1, py + radius);
  w.count = std::min<std::size_t>(width - 1, px + radius) - w.x0 + 1;
  w.blocks = (w.count + kLanes - 1) / kLanes * kLanes;
  w.cx = c.x[p], w.cy = c.y[p], w.cz = c.z[p], w.cnx = c.nx[p], w.cny = c.ny[p], w.cnz = c.nz[p];
  w.inv_m = c.inv_m[p];
  w.inv_a2 = 1.0f / (s.a * s.a);
  return w;
}

// w[k] = K(ε_pq / a) for the `blocks` taps q = q0 + k of one row of p's window (0 where q has no
// samples or lies beyond the kernel's support, and for the taps past the row's end that round the
// row up to a multiple of kLanes). Ward's distance, ε = d M + sqrt(τ) with d = |x_p - x_q|,
// M = max(1 / m_p, 1 / m_q) (the surface term by the nearer geometry of the two pixels: a corner's
// pixel does not blur into an open neighbour's kernel, nor the open one into the corner's) and
// τ = 1 - n_p . n_q (the turn), is squared as d^2 M^2 + 2 M sqrt(d^2 τ) + τ: one square root per
// tap.
void row_weights(const Columns& c, const Window& win, std::size_t q0, float* __restrict w) {
  const float *__restrict qx = &c.x[q0], *__restrict qy = &c.y[q0], *__restrict qz = &c.z[q0],
                         *__restrict qnx = &c.nx[q0], *__restrict qny = &c.ny[q0], *__restrict qnz = &c.nz[q0],
                         *__restrict qm = &c.inv_m[q0], *__restrict qv = &c.valid[q0];
  const float cx = win.cx, cy = win.cy, cz = win.cz, cnx = win.cnx, cny = win.cny, cnz = win.cnz;
  const float inv_m = win.inv_m, inv_a2 = win.inv_a2;
  const std::size_t blocks = win.blocks;
  for (std::size_t k = 0; k < blocks; ++k) {
    const float dx = qx[k] - cx, dy = qy[k] - cy, dz = qz[k] - cz;
    const float d2 = dx * dx + dy * dy + dz * dz;
    const float cos_turn = 1.0f - (cnx * qnx[k] + cny * qny[k] + cnz * qnz[k]);
    const float turn = 0.0f < cos_turn ? cos_turn : 0.0f;
    const float m = inv_m < qm[k] ? qm[k] : inv_m;
    const float t2 = (d2 * (m * m) + 2.0f * m * std::sqrt(d2 * turn) + turn) * inv_a2;
    const float u = t2 < 4.0f ? t2 : 4.0f;  // also maps a NaN (a degenerate pixel) into range
    const float k_u = kernel_exp(u) * qv[k];
    w[k] = t2 <= 4.0f ? k_u : 0.0f;
  }
  for (std::size_t k = win.count; k < blocks; ++k) w[k] = 0.0f;  // taps of the next row, or padding
}

#if defined(__x86_64__) && defined(__GNUC__)
#define PENUMBRA_FILTER_AVX2 1
#define PENUMBRA_FILTER_AVX2_INLINE [[gnu::target("avx2"), gnu::always_inline]] inline
PENUMBRA_FILTER_AVX2_INLINE __m256 mul(__m256 a, __m256 b) { return _mm256_mul_ps(a, b); }
PENUMBRA_FILTER_AVX2_INLINE __m256 add(__m256 a, __m256 b) { return _mm256_add_ps(a, b); }
PENUMBRA_FILTER_AVX2_INLINE __m256 sub(__m256 a, __m256 b) { return _mm256_sub_ps(a, b); }
// a < b ? x : y (y where either is NaN), as the portable loop's ternaries.
PENUMBRA_FILTER_AVX2_INLINE __m256 select_lt(__m256 a, __m256 b, __m256 x, __m256 y) {
  return _mm256_blendv_ps(y, x, _mm256_cmp_ps(a, b, _CMP_LT_OQ));
}

// kernel_exp's c[i] + c[i + 1] g.
PENUMBRA_FILTER_AVX2_INLINE __m256 taylor_pair(int i, __m256 g) {
  return add(_mm256_set1_ps(kExpTaylor[i]), mul(_mm256_set1_ps(kExpTaylor[i + 1]), g));
}

// What weights8 needs of p, broadcast to the eight lanes.
struct Centre8 {
  __m256 cx, cy, cz, cnx, cny, cnz, inv_m, inv_a2;
};
PENUMBRA_FILTER_AVX2_INLINE Centre8 centre8(const Window& win) {
  return {_mm256_set1_ps(win.cx),  _mm256_set1_ps(win.cy),  _mm256_set1_ps(win.cz),    _mm256_set1_ps(win.cnx),
          _mm256_set1_ps(win.cny), _mm256_set1_ps(win.cnz), _mm256_set1_ps(win.inv_m), _mm256_set1_ps(win.inv_a2)};
}

// row_weights for the eight taps q.. q + 7, operation for operation.
PENUMBRA_FILTER_AVX2_INLINE __m256 weights8(const Columns& c, const Centre8& p, std::size_t q) {
  const __m256 zero = _mm256_setzero_ps(), one = _mm256_set1_ps(1.0f), four = _mm256_set1_ps(4.0f);
  const __m256 dx = sub(_mm256_loadu_ps(&c.x[q]), p.cx), dy = sub(_mm256_loadu_ps(&c.y[q]), p.cy),
               dz = sub(_mm256_loadu_ps(&c.z[q]), p.cz);
  const __m256 d2 = add(add(mul(dx, dx), mul(dy, dy)), mul(dz, dz));
  const __m256 dot = add(add(mul(p.cnx, _mm256_loadu_ps(&c.nx[q])), mul(p.cny, _mm256_loadu_ps(&c.ny[q]))),
                         mul(p.cnz, _mm256_loadu_ps(&c.nz[q])));
  const __m256 cos_turn = sub(one, dot);
  const __m256 turn = select_lt(zero, cos_turn, cos_turn, zero);
  const __m256 qm = _mm256_loadu_ps(&c.inv_m[q]);
  const __m256 m = select_lt(p.inv_m, qm, qm, p.inv_m);
  const __m256 t2 = mul(add(add(mul(d2, mul(m, m)), mul(mul(_mm256_set1_ps(2.0f), m), _mm256_sqrt_ps(mul(d2, turn)))),
                            turn),
                        p.inv_a2);
  const __m256 u = select_lt(t2, four, t2, four);
  // kernel_exp(u)
  const __m256 y = mul(_mm256_set1_ps(-1.44269504f), u);
  const __m256 n = _mm256_round_ps(y, _MM_FROUND_TO_NEG_INF | _MM_FROUND_NO_EXC);  // the same floor, in one step
  const __m256 g = mul(sub(y, n), _mm256_set1_ps(0.69314718f));
  const __m256 g2 = mul(g, g), g4 = mul(g2, g2);
  const __m256 poly =
      add(add(taylor_pair(0, g), mul(g2, taylor_pair(2, g))), mul(g4, add(taylor_pair(4, g), mul(g2, taylor_pair(6, g)))));
  const __m256 scale =
      _mm256_castsi256_ps(_mm256_slli_epi32(_mm256_add_epi32(_mm256_cvttps_epi32(n), _mm256_set1_epi32(127)), 23));
  const __m256 k_u = mul(mul(poly, scale), _mm256_loadu_ps(&c.valid[q]));
  return _mm256_blendv_ps(zero, k_u, _mm256_cmp_ps(t2, four, _CMP_LE_OQ));  // t2 <= 4 ? k_u : 0 (0 for NaN)
}

// LaneSums::total of eight lanes.
PENUMBRA_FILTER_AVX2_INLINE float total8(__m256 lanes) {
  alignas(32) float a[8];
  _mm256_store_ps(a, lanes);
  return ((a[0] + a[1]) + (a[2] + a[3])) + ((a[4] + a[5]) + (a[6] + a[7]));
}

// Adds row yy of p's window to the eight-lane sums of `values` (J of them), as gather_row does:
// the taps past the row's end (the last block's lanes from `count` on) weigh 0.
template <std::size_t J>
PENUMBRA_FILTER_AVX2_INLINE void row8(const Columns& c, const Window& win, const Centre8& p, std::size_t q0,
                                      const std::array<const float*, J>& values, __m256 (&sums)[J]) {
  const __m256i lane = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
  for (std::size_t k = 0; k < win.blocks; k += kLanes) {
    __m256 w = weights8(c, p, q0 + k);
    if (k + kLanes > win.count) {
      const __m256i inside = _mm256_cmpgt_epi32(_mm256_set1_epi32(int(win.count - k)), lane);
      w = _mm256_and_ps(w, _mm256_castsi256_ps(inside));
    }
    for (std::size_t j = 0; j < J; ++j) sums[j] = add(sums[j], mul(w, _mm256_loadu_ps(values[j] + q0 + k)));
  }
}
#endif

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

// What a worker reads: the image, its columns and the settings.
struct Gather {
  std::span<const FilterPixel> pixels;
  std::uint32_t width = 0, height = 0;
  const IrradianceFilterSettings* settings = nullptr;
  const Columns* columns = nullptr;
};

// Adds row yy of p's window to `sum`: the row's weights into w, then w x values.
template <std::size_t J>
void gather_row(const Gather& g, const Window& win, std::size_t yy, float* w, LaneSums<J>& sum,
                const std::array<const float*, J>& values) {
  const std::size_t q0 = yy * g.width + win.x0;
  row_weights(*g.columns, win, q0, w);
  sum.add(w, win.blocks, values, q0);
}

// The support of pixels [begin, end): sum_q K over the window's rows, p's own row first and then
// outwards (p - 1, p + 1, p - 2, ...: the rows of the largest weights first), until it reaches
// `limit`.
void support_portable(const Gather& g, float limit, std::size_t begin, std::size_t end, float* out) {
  float w[(2 * kMaxFilterRadius + kLanes) / kLanes * kLanes];
  const std::array<const float*, 1> ones{g.columns->valid.data()};  // the weights are already 0 off the surface
  for (std::size_t p = begin; p < end; ++p) {
    LaneSums<1> sum;
    if (g.pixels[p].samples != 0) {
      const Window win = window_of(*g.columns, g.pixels, g.width, g.height, *g.settings, p);
      const std::size_t py = p / g.width;
      gather_row(g, win, py, w, sum, ones);
      for (std::size_t k = 1; sum.total(0) < limit && (py >= win.y0 + k || py + k <= win.y1); ++k) {
        if (py >= win.y0 + k) gather_row(g, win, py - k, w, sum, ones);
        if (py + k <= win.y1 && sum.total(0) < limit) gather_row(g, win, py + k, w, sum, ones);
      }
    }
    out[p] = sum.total(0);
  }
}

// Ē of pixels [begin, end) from `values` = {N E_r, N E_g, N E_b, N} per pixel.
void filter_portable(const Gather& g, const std::array<const float*, 4>& values, std::size_t begin, std::size_t end,
                     glm::vec3* out) {
  float w[(2 * kMaxFilterRadius + kLanes) / kLanes * kLanes];
  for (std::size_t p = begin; p < end; ++p) {
    LaneSums<4> sum;
    if (g.pixels[p].samples != 0) {
      const Window win = window_of(*g.columns, g.pixels, g.width, g.height, *g.settings, p);
      for (std::size_t yy = win.y0; yy <= win.y1; ++yy) gather_row(g, win, yy, w, sum, values);
    }
    // The pixel itself always has weight K(0) N_p > 0, so the weight is 0 only without a surface.
    const float weight = sum.total(3);
    out[p] = weight > 0.0f ? glm::vec3(sum.total(0), sum.total(1), sum.total(2)) / weight : glm::vec3(0.0f);
  }
}

#if PENUMBRA_FILTER_AVX2
// support_portable and filter_portable eight lanes wide, the sums in registers.
[[gnu::target("avx2")]] void support_avx2(const Gather& g, float limit, std::size_t begin, std::size_t end,
                                          float* out) {
  const Columns& c = *g.columns;
  const std::array<const float*, 1> ones{c.valid.data()};
  for (std::size_t p = begin; p < end; ++p) {
    __m256 sum[1] = {_mm256_setzero_ps()};
    if (g.pixels[p].samples != 0) {
      const Window win = window_of(c, g.pixels, g.width, g.height, *g.settings, p);
      const Centre8 centre = centre8(win);
      const std::size_t py = p / g.width;
      row8(c, win, centre, py * g.width + win.x0, ones, sum);
      for (std::size_t k = 1; total8(sum[0]) < limit && (py >= win.y0 + k || py + k <= win.y1); ++k) {
        if (py >= win.y0 + k) row8(c, win, centre, (py - k) * g.width + win.x0, ones, sum);
        if (py + k <= win.y1 && total8(sum[0]) < limit) row8(c, win, centre, (py + k) * g.width + win.x0, ones, sum);
      }
    }
    out[p] = total8(sum[0]);
  }
}
[[gnu::target("avx2")]] void filter_avx2(const Gather& g, const std::array<const float*, 4>& values,
                                         std::size_t begin, std::size_t end, glm::vec3* out) {
  const Columns& c = *g.columns;
  for (std::size_t p = begin; p < end; ++p) {
    __m256 sum[4] = {_mm256_setzero_ps(), _mm256_setzero_ps(), _mm256_setzero_ps(), _mm256_setzero_ps()};
    if (g.pixels[p].samples != 0) {
      const Window win = window_of(c, g.pixels, g.width, g.height, *g.settings, p);
      const Centre8 centre = centre8(win);
      for (std::size_t yy = win.y0; yy <= win.y1; ++yy) row8(c, win, centre, yy * g.width + win.x0, values, sum);
    }
    const float weight = total8(sum[3]);
    out[p] = weight > 0.0f ? glm::vec3(total8(sum[0]), total8(sum[1]), total8(sum[2])) / weight : glm::vec3(0.0f);
  }
}
#endif

}  // namespace

Status irradiance_filter_support(std::span<const FilterPixel> pixels, std::uint32_t width, std::uint32_t height,
                                 const IrradianceFilterSettings& settings, float limit, std::span<float> out,
                                 JobContext& jobs, Isa isa) {
  PENUMBRA_TRY(check(pixels.size(), out.size(), width, height, settings, "irradiance_filter_support"));
  Columns columns(pixels);
  jobs.begin_stage("filter support", 2 * pixels.size());
  PENUMBRA_TRY(columns.predict(pixels, width, height, settings.predictor_radius, jobs));
  const Gather g{pixels, width, height, &settings, &columns};
  const bool avx2 = isa == Isa::Best && cpu_has_avx2();
  return jobs.parallel_for(pixels.size(), 256, [&](std::size_t begin, std::size_t end) {
#if PENUMBRA_FILTER_AVX2
    if (avx2) return support_avx2(g, limit, begin, end, out.data());
#endif
    support_portable(g, limit, begin, end, out.data());
  });
}

Status filter_irradiance(std::span<const FilterPixel> pixels, std::uint32_t width, std::uint32_t height,
                         const IrradianceFilterSettings& settings, std::span<glm::vec3> out, JobContext& jobs,
                         Isa isa) {
  PENUMBRA_TRY(check(pixels.size(), out.size(), width, height, settings, "filter_irradiance"));
  Columns columns(pixels);
  jobs.begin_stage("irradiance filter", 2 * pixels.size());
  PENUMBRA_TRY(columns.predict(pixels, width, height, settings.predictor_radius, jobs));
  const Gather g{pixels, width, height, &settings, &columns};
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
  const bool avx2 = isa == Isa::Best && cpu_has_avx2();
  return jobs.parallel_for(pixels.size(), 256, [&](std::size_t begin, std::size_t end) {
#if PENUMBRA_FILTER_AVX2
    if (avx2) return filter_avx2(g, values, begin, end, out.data());
#endif
    filter_portable(g, values, begin, end, out.data());
  });
}

}  // namespace penumbra
