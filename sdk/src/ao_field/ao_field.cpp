// Ambient occlusion fields (see ao_field.h): validation, the spherical-cap closed form and the
// CPU evaluation of Kontkanen & Laine 2005, section 3 (the runtime of the thesis, section 4.1).
#include "penumbra/ao_field/ao_field.h"

#include "penumbra/core/isa.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <string>

#include <glm/geometric.hpp>
#include <glm/matrix.hpp>

#if defined(__x86_64__) && defined(__GNUC__)
#include <immintrin.h>
#endif

namespace penumbra {

namespace {

constexpr double kPiD = std::numbers::pi;

Error bad_setting(std::string_view context, const std::string& what) {
  return make_error(ErrorCode::InvalidArgument, std::string(context) + ": " + what);
}

// The face, and the in-face coordinates (s, t) in [-1, 1], of direction d (finite, non-zero;
// inverse of cube_direction). Without branches: the major axis as 0/1 weights (a random
// receiver's face is unpredictable, and a mispredicted branch costs more than the arithmetic).
[[gnu::always_inline]] inline void cube_coordinates(glm::vec3 d, std::uint32_t& face, float& s, float& t) {
  const float ax = std::abs(d.x), ay = std::abs(d.y), az = std::abs(d.z);
  const int mx = (ax >= ay) & (ax >= az), my = (1 - mx) & (ay >= az), mz = 1 - mx - my;
  const float wx = static_cast<float>(mx), wy = static_cast<float>(my), wz = static_cast<float>(mz);
  const float major = wx * d.x + wy * d.y + wz * d.z;
  const float inv = 1.0f / std::abs(major);
  // Axis m's in-face coordinates are axes (m + 1) % 3 and (m + 2) % 3.
  s = (wx * d.y + wy * d.z + wz * d.x) * inv;
  t = (wx * d.z + wy * d.x + wz * d.y) * inv;
  face = static_cast<std::uint32_t>(2 * my + 4 * mz) + (major < 0.0f ? 1u : 0u);
}

// Bilinear interpolation of the texels of one face in direction w (any non-zero length; clamped
// at the face's edge texel centres, so each lookup reads a single face).
[[gnu::always_inline]] inline AOFieldTexel lookup(const AOFieldData& field, glm::vec3 w) {
  std::uint32_t face = 0;
  float s = 0.0f, t = 0.0f;
  cube_coordinates(w, face, s, t);
  const std::uint32_t res = field.resolution;
  const float last = static_cast<float>(res - 1);
  const float u = std::min(std::max(0.5f * (s + 1.0f) * static_cast<float>(res) - 0.5f, 0.0f), last);
  const float v = std::min(std::max(0.5f * (t + 1.0f) * static_cast<float>(res) - 0.5f, 0.0f), last);
  const auto u0 = static_cast<std::uint32_t>(u), v0 = static_cast<std::uint32_t>(v);
  const std::uint32_t u1 = std::min(u0 + 1, res - 1), v1 = std::min(v0 + 1, res - 1);
  const float fu = u - static_cast<float>(u0), fv = v - static_cast<float>(v0);
  const std::size_t base = std::size_t{face} * res * res;
  const AOFieldTexel& t00 = field.texels[base + std::size_t{v0} * res + u0];
  const AOFieldTexel& t01 = field.texels[base + std::size_t{v0} * res + u1];
  const AOFieldTexel& t10 = field.texels[base + std::size_t{v1} * res + u0];
  const AOFieldTexel& t11 = field.texels[base + std::size_t{v1} * res + u1];
  const float w00 = (1 - fu) * (1 - fv), w01 = fu * (1 - fv), w10 = (1 - fu) * fv, w11 = fu * fv;
  AOFieldTexel out;
  out.a = w00 * t00.a + w01 * t01.a + w10 * t10.a + w11 * t11.a;
  out.b = w00 * t00.b + w01 * t01.b + w10 * t10.b + w11 * t11.b;
  out.c = w00 * t00.c + w01 * t01.c + w10 * t10.c + w11 * t11.c;
  out.r0 = w00 * t00.r0 + w01 * t01.r0 + w10 * t10.r0 + w11 * t11.r0;
  out.c0 = w00 * t00.c0 + w01 * t01.c0 + w10 * t10.c0 + w11 * t11.c0;
  return out;
}

// The cap occlusion for alpha <= pi/2 (s = sin^2 alpha, cos_alpha >= 0), in double.
double cap_occlusion_small(double cos_alpha, double cos_beta) {
  const double s = 1.0 - cos_alpha * cos_alpha;
  const double sin_alpha = std::sqrt(s);
  if (s <= 0.0) return 0.0;
  if (cos_beta > sin_alpha) return s * cos_beta;  // the cap lies wholly above the horizon
  const double sin_beta = std::sqrt(std::max(0.0, 1.0 - cos_beta * cos_beta));
  // beta >= pi/2 + alpha, i.e. cos(beta) <= -sin(alpha): wholly below the horizon.
  if (cos_beta <= -sin_alpha) return 0.0;
  // Across the horizon: x = cot(alpha), y = -x cot(beta), z = sin(beta) sqrt(1 - y^2).
  const double x = cos_alpha / sin_alpha;
  const double y = std::clamp(-x * cos_beta / sin_beta, -1.0, 1.0);
  const double z = sin_beta * std::sqrt(1.0 - y * y);
  const double a = ((cos_beta * std::acos(y) - x * z) * s + std::atan2(z, x)) / kPiD;
  return std::clamp(a, 0.0, 1.0);
}

// The closed form tabulated over omega in [0, 4 pi] x cos(beta) in [-1, 1] for bilinear lookups
// (the runtime's "table" option of docs/algorithms.md, P2). Built once, on first use.
struct CapTable {
  static constexpr int kSize = kCapTableIntervals;  // intervals per axis
  std::vector<float> values;         // (kSize + 1)^2, omega-major
  CapTable() : values(static_cast<std::size_t>((kSize + 1) * (kSize + 1))) {
    for (int i = 0; i <= kSize; ++i)
      for (int j = 0; j <= kSize; ++j)
        values[static_cast<std::size_t>(i * (kSize + 1) + j)] =
            cap_occlusion(static_cast<float>(4.0 * kPiD * i / kSize), static_cast<float>(-1.0 + 2.0 * j / kSize));
  }
};

const CapTable& cap_table() {
  static const CapTable table;  // thread-safe initialisation
  return table;
}

// The bilinear table lookup of cap_occlusion_table on the table's values.
[[gnu::always_inline]] inline float cap_lookup(const float* values, float omega, float cos_beta) {
  constexpr float n = static_cast<float>(CapTable::kSize);
  // NaN inputs land on the clamps' lower ends through the comparisons below.
  float u = omega * (n / (4.0f * std::numbers::pi_v<float>));
  float v = (cos_beta + 1.0f) * (0.5f * n);
  u = std::min(std::max(0.0f, u), n);  // std::max(0, NaN) is 0
  v = std::min(std::max(0.0f, v), n);
  const int i = std::min(static_cast<int>(u), CapTable::kSize - 1);
  const int j = std::min(static_cast<int>(v), CapTable::kSize - 1);
  const float fu = u - static_cast<float>(i), fv = v - static_cast<float>(j);
  const float* row0 = values + (i * (CapTable::kSize + 1) + j);
  const float* row1 = row0 + (CapTable::kSize + 1);
  const float a0 = row0[0] + (row0[1] - row0[0]) * fv, a1 = row1[0] + (row1[1] - row1[0]) * fv;
  return a0 + (a1 - a0) * fu;
}

// What evaluate_local needs of a field, computed once per field (accumulate_open) or per call.
struct Prepared {
  const AOFieldData& field;
  const float* table;
  float r_far2;       // r_far^2
  float fade_scale;   // 1 / ((1 - fade_start) r_far)
  float inv_far;      // 1 / r_far (the grid's warp)
  bool grid;
  explicit Prepared(const AOFieldData& f)
      : field(f),
        table(cap_table().values.data()),
        r_far2(f.r_far * f.r_far),
        fade_scale(1.0f / ((1.0f - f.fade_start) * f.r_far)),
        inv_far(1.0f / f.r_far),
        grid(f.representation == AOFieldRepresentation::Grid) {}
};

// The cap behind an occlusion value (evaluate_cap): its solid angle and (unnormalised) axis.
struct CapOut {
  float omega = 0.0f;
  glm::vec3 axis{0.0f};
};

// Steps 2-4 for a RadialFit field at p = x - centre, r = |p| in (0, r_far), inv_r = 1 / r; the
// cap into `out` when it is not null.
[[gnu::always_inline]] inline float radial_occlusion(const Prepared& pr, glm::vec3 p, float r, float inv_r,
                                                     glm::vec3 n, CapOut* out) {
  const AOFieldData& field = pr.field;
  const AOFieldTexel t = lookup(field, p);
  // Outside the hull: r itself; inside: the hull point, then the blend towards A0.
  const float rc = std::max(r, t.r0);
  const float denom = (t.a * rc + t.b) * rc + t.c;
  const float capped = std::min(1.0f / denom, 4.0f * std::numbers::pi_v<float>);
  const float omega = denom > 0.0f ? capped : 0.0f;
  const glm::vec3 axis = t.c0 - (rc * inv_r) * p;
  const float len2 = glm::dot(axis, axis);
  const float cos_beta = len2 > 0.0f ? glm::dot(n, axis) / std::sqrt(len2) : -glm::dot(n, p) * inv_r;
  if (out != nullptr) *out = {omega, len2 > 0.0f ? axis : -p};
  float a = cap_lookup(pr.table, omega, cos_beta);
  if (r < t.r0) {
    const float A0 = field.inside_occlusion, q = r / t.r0;
    a = A0 + (a - A0) * (field.inside_exponent == 2.0f ? q * q : std::pow(q, field.inside_exponent));
  }
  return a;
}

// Steps 2-3 for a Grid field (Malmer et al. 2007): trilinear Omega and Omega x Upsilon on the
// warped grid.
[[gnu::always_inline]] inline float grid_occlusion(const Prepared& pr, glm::vec3 p, float inv_r, glm::vec3 n,
                                                   CapOut* out) {
  const AOFieldData& field = pr.field;
  const std::uint32_t size = field.grid_size;
  const float last = static_cast<float>(size - 1), inv_far = pr.inv_far;
  std::uint32_t i0[3];
  float f[3];
  for (int k = 0; k < 3; ++k) {
    const float u = std::copysign(std::sqrt(std::abs(p[k]) * inv_far), p[k]);  // the warp's inverse
    const float g = std::min(std::max((u + 1.0f) * 0.5f * last, 0.0f), last);
    i0[k] = std::min(static_cast<std::uint32_t>(g), size - 2);
    f[k] = g - static_cast<float>(i0[k]);
  }
  const std::size_t sx = 1, sy = size, sz = std::size_t{size} * size;
  const AOFieldGridNode* base = &field.nodes[i0[2] * sz + i0[1] * sy + i0[0]];
  float omega = 0.0f;
  glm::vec3 dir(0.0f);
  for (int corner = 0; corner < 8; ++corner) {
    const int cx = corner & 1, cy = (corner >> 1) & 1, cz = corner >> 2;
    const float w = (cx ? f[0] : 1.0f - f[0]) * (cy ? f[1] : 1.0f - f[1]) * (cz ? f[2] : 1.0f - f[2]);
    const AOFieldGridNode& node = base[cx * sx + cy * sy + cz * sz];
    omega += w * node.omega;
    dir += w * node.weighted_direction;
  }
  const float len2 = glm::dot(dir, dir);
  const float cos_beta = len2 > 0.0f ? glm::dot(n, dir) / std::sqrt(len2) : -glm::dot(n, p) * inv_r;
  if (out != nullptr) *out = {omega, len2 > 0.0f ? dir : -p};
  return cap_lookup(pr.table, omega, cos_beta);
}

// Steps 1-5 of evaluate_local for a valid field.
[[gnu::always_inline]] inline float occlusion(const Prepared& pr, glm::vec3 x, glm::vec3 n, CapOut* out = nullptr) {
  const AOFieldData& field = pr.field;
  const glm::vec3 p = x - field.centre;
  const float r2 = glm::dot(p, p);
  if (!(r2 < pr.r_far2)) return 0.0f;  // beyond the falloff (or not finite)
  if (r2 == 0.0f) {
    if (out != nullptr) *out = {4.0f * std::numbers::pi_v<float>, -n};
    return field.inside_occlusion;
  }
  const float r = std::sqrt(r2), inv_r = 1.0f / r;
  const float a = pr.grid ? grid_occlusion(pr, p, inv_r, n, out) : radial_occlusion(pr, p, r, inv_r, n, out);
  // Step 5: the linear fade to 0 between fade_start x r_far and r_far.
  const float fade = std::min((field.r_far - r) * pr.fade_scale, 1.0f);
  return std::min(std::max(0.0f, a * fade), 1.0f);
}

// ---- The batch on AVX2: eight receivers per step ---------------------------------------------
// The same steps as occlusion() with the same float operations in the same order (no fused
// multiply-adds), so that its results equal the one-at-a-time path's bit for bit; chosen at run
// time when the CPU has AVX2 (the gathers of texels, grid vertices and table values are what make
// it pay).

#if defined(__x86_64__) && defined(__GNUC__)
#define PENUMBRA_AO_FIELD_AVX2 1
#define PENUMBRA_AVX2 [[gnu::target("avx2"), gnu::always_inline]] inline

PENUMBRA_AVX2 __m256 S(float v) { return _mm256_set1_ps(v); }
PENUMBRA_AVX2 __m256 mul(__m256 a, __m256 b) { return _mm256_mul_ps(a, b); }
PENUMBRA_AVX2 __m256 add(__m256 a, __m256 b) { return _mm256_add_ps(a, b); }
PENUMBRA_AVX2 __m256 sub(__m256 a, __m256 b) { return _mm256_sub_ps(a, b); }
PENUMBRA_AVX2 __m256 dot3(__m256 ax, __m256 ay, __m256 az, __m256 bx, __m256 by, __m256 bz) {
  return _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(ax, bx), _mm256_mul_ps(ay, by)), _mm256_mul_ps(az, bz));
}
// std::min(std::max(v, 0), hi) for non-NaN v.
PENUMBRA_AVX2 __m256 clamp0(__m256 v, float hi) { return _mm256_min_ps(_mm256_max_ps(v, S(0.0f)), S(hi)); }

// Row i of m times (a, b, c), in glm's order.
PENUMBRA_AVX2 __m256 row(const glm::mat3& m, int i, __m256 a, __m256 b, __m256 c) {
  return add(add(mul(S(m[0][i]), a), mul(S(m[1][i]), b)), mul(S(m[2][i]), c));
}

// Eight receivers after step 1: p = x - centre and the unit normal in the caster's frame, r, 1 / r,
// and the lane masks. Lanes that are not live (beyond r_far, at the centre, not finite) carry
// p = (1, 0, 0), a safe lookup whose result is replaced.
struct Lanes {
  __m256 px, py, pz, nx, ny, nz, r, inv_r, live, at_centre, normal_ok;
};

PENUMBRA_AVX2 Lanes load_lanes(const Prepared& pr, const glm::mat3& m, glm::vec3 offset, const glm::vec3* x,
                               const glm::vec3* n) {
  const AOFieldData& f = pr.field;
  alignas(32) float buf[6][8];
  for (int i = 0; i < 8; ++i) {
    buf[0][i] = x[i].x; buf[1][i] = x[i].y; buf[2][i] = x[i].z;
    buf[3][i] = n[i].x; buf[4][i] = n[i].y; buf[5][i] = n[i].z;
  }
  const __m256 X = _mm256_load_ps(buf[0]), Y = _mm256_load_ps(buf[1]), Z = _mm256_load_ps(buf[2]);
  const __m256 NX = _mm256_load_ps(buf[3]), NY = _mm256_load_ps(buf[4]), NZ = _mm256_load_ps(buf[5]);
  Lanes l;
  // The world-to-local transform (mat3 x vec3 + offset) and the renormalised normal.
  const __m256 lx = add(row(m, 0, X, Y, Z), S(offset.x)), ly = add(row(m, 1, X, Y, Z), S(offset.y)),
               lz = add(row(m, 2, X, Y, Z), S(offset.z));
  l.nx = row(m, 0, NX, NY, NZ);
  l.ny = row(m, 1, NX, NY, NZ);
  l.nz = row(m, 2, NX, NY, NZ);
  const __m256 nlen2 = dot3(l.nx, l.ny, l.nz, l.nx, l.ny, l.nz);
  const __m256 ninv = _mm256_div_ps(S(1.0f), _mm256_sqrt_ps(nlen2));
  l.nx = mul(l.nx, ninv);
  l.ny = mul(l.ny, ninv);
  l.nz = mul(l.nz, ninv);
  l.normal_ok = _mm256_and_ps(_mm256_cmp_ps(nlen2, S(0.0f), _CMP_GT_OQ),
                              _mm256_cmp_ps(nlen2, S(std::numeric_limits<float>::infinity()), _CMP_LT_OQ));
  // Step 1.
  const __m256 px = sub(lx, S(f.centre.x)), py = sub(ly, S(f.centre.y)), pz = sub(lz, S(f.centre.z));
  const __m256 r2 = dot3(px, py, pz, px, py, pz);
  l.at_centre = _mm256_cmp_ps(r2, S(0.0f), _CMP_EQ_OQ);
  l.live = _mm256_andnot_ps(l.at_centre, _mm256_cmp_ps(r2, S(pr.r_far2), _CMP_LT_OQ));
  l.px = _mm256_blendv_ps(S(1.0f), px, l.live);
  l.py = _mm256_and_ps(py, l.live);
  l.pz = _mm256_and_ps(pz, l.live);
  l.r = _mm256_sqrt_ps(_mm256_blendv_ps(S(1.0f), r2, l.live));
  l.inv_r = _mm256_div_ps(S(1.0f), l.r);
  return l;
}

// cos(beta) = n . axis / |axis|, or -n . p / r when the axis is zero.
PENUMBRA_AVX2 __m256 cos_beta8(const Lanes& l, __m256 ax, __m256 ay, __m256 az) {
  const __m256 len2 = dot3(ax, ay, az, ax, ay, az);
  const __m256 along = _mm256_div_ps(dot3(l.nx, l.ny, l.nz, ax, ay, az), _mm256_sqrt_ps(len2));
  const __m256 radial = mul(sub(S(0.0f), dot3(l.nx, l.ny, l.nz, l.px, l.py, l.pz)), l.inv_r);
  return _mm256_blendv_ps(radial, along, _mm256_cmp_ps(len2, S(0.0f), _CMP_GT_OQ));
}

// Step 3: cap_lookup on eight lanes.
PENUMBRA_AVX2 __m256 cap8(const float* table, __m256 omega, __m256 cos_beta) {
  constexpr int kN = CapTable::kSize;
  const float nf = static_cast<float>(kN);
  const __m256 u = clamp0(mul(omega, S(nf / (4.0f * std::numbers::pi_v<float>))), nf);
  const __m256 v = clamp0(mul(add(cos_beta, S(1.0f)), S(0.5f * nf)), nf);
  const __m256i i = _mm256_min_epi32(_mm256_cvttps_epi32(u), _mm256_set1_epi32(kN - 1));
  const __m256i j = _mm256_min_epi32(_mm256_cvttps_epi32(v), _mm256_set1_epi32(kN - 1));
  const __m256 fu = sub(u, _mm256_cvtepi32_ps(i)), fv = sub(v, _mm256_cvtepi32_ps(j));
  const __m256i q0 = _mm256_add_epi32(_mm256_mullo_epi32(i, _mm256_set1_epi32(kN + 1)), j);
  const __m256i q1 = _mm256_add_epi32(q0, _mm256_set1_epi32(kN + 1));
  const __m256i one = _mm256_set1_epi32(1);
  const __m256 v00 = _mm256_i32gather_ps(table, q0, 4), v01 = _mm256_i32gather_ps(table, _mm256_add_epi32(q0, one), 4);
  const __m256 v10 = _mm256_i32gather_ps(table, q1, 4), v11 = _mm256_i32gather_ps(table, _mm256_add_epi32(q1, one), 4);
  const __m256 a0 = add(v00, mul(sub(v01, v00), fv)), a1 = add(v10, mul(sub(v11, v10), fv));
  return add(a0, mul(sub(a1, a0), fu));
}

// Step 5 and the product: open *= 1 - A for the lanes with a usable normal.
PENUMBRA_AVX2 void store_open(const Prepared& pr, const Lanes& l, __m256 a, float* open) {
  const AOFieldData& f = pr.field;
  const __m256 one = S(1.0f);
  const __m256 fade = _mm256_min_ps(mul(sub(S(f.r_far), l.r), S(pr.fade_scale)), one);
  __m256 result = _mm256_min_ps(_mm256_max_ps(mul(a, fade), S(0.0f)), one);
  result = _mm256_blendv_ps(_mm256_and_ps(S(f.inside_occlusion), l.at_centre), result, l.live);
  const __m256 factor = _mm256_blendv_ps(one, sub(one, result), l.normal_ok);
  _mm256_storeu_ps(open, mul(_mm256_loadu_ps(open), factor));
}

// The bilinear interpolation of float k of the four texels at float offsets i00..i11.
PENUMBRA_AVX2 __m256 bilinear(const float* texels, int k, __m256i i00, __m256i i01, __m256i i10, __m256i i11,
                              __m256 w00, __m256 w01, __m256 w10, __m256 w11) {
  const __m256i kk = _mm256_set1_epi32(k);
  const __m256 g00 = _mm256_i32gather_ps(texels, _mm256_add_epi32(i00, kk), 4);
  const __m256 g01 = _mm256_i32gather_ps(texels, _mm256_add_epi32(i01, kk), 4);
  const __m256 g10 = _mm256_i32gather_ps(texels, _mm256_add_epi32(i10, kk), 4);
  const __m256 g11 = _mm256_i32gather_ps(texels, _mm256_add_epi32(i11, kk), 4);
  return add(add(add(mul(w00, g00), mul(w01, g01)), mul(w10, g10)), mul(w11, g11));
}

// Steps 2-5 of a RadialFit field (inside_exponent 2) for eight receivers.
[[gnu::target("avx2")]] void radial_batch8(const Prepared& pr, const glm::mat3& m, glm::vec3 offset,
                                           const glm::vec3* x, const glm::vec3* n, float* open) {
  const AOFieldData& f = pr.field;
  const Lanes l = load_lanes(pr, m, offset, x, n);
  // Step 2: the face and (s, t), then the texels.
  const __m256 sign = S(-0.0f);
  const __m256 ax = _mm256_andnot_ps(sign, l.px), ay = _mm256_andnot_ps(sign, l.py), az = _mm256_andnot_ps(sign, l.pz);
  const __m256 mx = _mm256_and_ps(_mm256_cmp_ps(ax, ay, _CMP_GE_OQ), _mm256_cmp_ps(ax, az, _CMP_GE_OQ));
  const __m256 my = _mm256_andnot_ps(mx, _mm256_cmp_ps(ay, az, _CMP_GE_OQ));
  const __m256 major = _mm256_blendv_ps(_mm256_blendv_ps(l.pz, l.py, my), l.px, mx);
  const __m256 inv = _mm256_div_ps(S(1.0f), _mm256_andnot_ps(sign, major));
  const __m256 s = mul(_mm256_blendv_ps(_mm256_blendv_ps(l.px, l.pz, my), l.py, mx), inv);
  const __m256 t = mul(_mm256_blendv_ps(_mm256_blendv_ps(l.py, l.px, my), l.pz, mx), inv);
  const __m256i face = _mm256_add_epi32(
      _mm256_blendv_epi8(_mm256_blendv_epi8(_mm256_set1_epi32(4), _mm256_set1_epi32(2), _mm256_castps_si256(my)),
                         _mm256_set1_epi32(0), _mm256_castps_si256(mx)),
      _mm256_srli_epi32(_mm256_castps_si256(major), 31));
  const int res = static_cast<int>(f.resolution);
  const float resf = static_cast<float>(res), last = static_cast<float>(res - 1);
  const __m256 u = clamp0(sub(mul(mul(S(0.5f), add(s, S(1.0f))), S(resf)), S(0.5f)), last);
  const __m256 v = clamp0(sub(mul(mul(S(0.5f), add(t, S(1.0f))), S(resf)), S(0.5f)), last);
  const __m256i u0 = _mm256_cvttps_epi32(u), v0 = _mm256_cvttps_epi32(v);
  const __m256i u1 = _mm256_min_epi32(_mm256_add_epi32(u0, _mm256_set1_epi32(1)), _mm256_set1_epi32(res - 1));
  const __m256i v1 = _mm256_min_epi32(_mm256_add_epi32(v0, _mm256_set1_epi32(1)), _mm256_set1_epi32(res - 1));
  const __m256 fu = sub(u, _mm256_cvtepi32_ps(u0)), fv = sub(v, _mm256_cvtepi32_ps(v0));
  const __m256i base = _mm256_mullo_epi32(face, _mm256_set1_epi32(res * res));
  const __m256i row0 = _mm256_add_epi32(base, _mm256_mullo_epi32(v0, _mm256_set1_epi32(res)));
  const __m256i row1 = _mm256_add_epi32(base, _mm256_mullo_epi32(v1, _mm256_set1_epi32(res)));
  const __m256i seven = _mm256_set1_epi32(7);
  const __m256i i00 = _mm256_mullo_epi32(_mm256_add_epi32(row0, u0), seven);
  const __m256i i01 = _mm256_mullo_epi32(_mm256_add_epi32(row0, u1), seven);
  const __m256i i10 = _mm256_mullo_epi32(_mm256_add_epi32(row1, u0), seven);
  const __m256i i11 = _mm256_mullo_epi32(_mm256_add_epi32(row1, u1), seven);
  const __m256 one = S(1.0f);
  const __m256 w00 = mul(sub(one, fu), sub(one, fv)), w01 = mul(fu, sub(one, fv)), w10 = mul(sub(one, fu), fv),
               w11 = mul(fu, fv);
  static_assert(sizeof(AOFieldTexel) == 7 * sizeof(float));
  const float* texels = &f.texels[0].a;
  __m256 g[7];
  for (int k = 0; k < 7; ++k) g[k] = bilinear(texels, k, i00, i01, i10, i11, w00, w01, w10, w11);
  const __m256 ta = g[0], tb = g[1], tc = g[2], tr0 = g[3];
  const __m256 rc = _mm256_max_ps(tr0, l.r);  // std::max(r, r0)
  const __m256 denom = add(mul(add(mul(ta, rc), tb), rc), tc);
  const __m256 capped = _mm256_min_ps(_mm256_div_ps(one, denom), S(4.0f * std::numbers::pi_v<float>));
  const __m256 omega = _mm256_and_ps(capped, _mm256_cmp_ps(denom, S(0.0f), _CMP_GT_OQ));
  const __m256 k = mul(rc, l.inv_r);
  const __m256 cos_beta = cos_beta8(l, sub(g[4], mul(k, l.px)), sub(g[5], mul(k, l.py)), sub(g[6], mul(k, l.pz)));
  __m256 a = cap8(pr.table, omega, cos_beta);
  // Step 4 (inside_exponent 2; the caller takes the scalar path otherwise).
  const __m256 A0 = S(f.inside_occlusion);
  const __m256 q = _mm256_div_ps(l.r, tr0);
  a = _mm256_blendv_ps(a, add(A0, mul(sub(a, A0), mul(q, q))), _mm256_cmp_ps(l.r, tr0, _CMP_LT_OQ));
  store_open(pr, l, a, open);
}

// Steps 2-5 of a Grid field for eight receivers.
[[gnu::target("avx2")]] void grid_batch8(const Prepared& pr, const glm::mat3& m, glm::vec3 offset,
                                         const glm::vec3* x, const glm::vec3* n, float* open) {
  const AOFieldData& f = pr.field;
  const Lanes l = load_lanes(pr, m, offset, x, n);
  const int size = static_cast<int>(f.grid_size);
  const float last = static_cast<float>(size - 1);
  const __m256 sign = S(-0.0f);
  __m256i i0[3];
  __m256 fr[3];
  const __m256 p[3] = {l.px, l.py, l.pz};
  for (int k = 0; k < 3; ++k) {
    // The warp's inverse: u = sign(p) sqrt(|p| / r_far).
    const __m256 mag = _mm256_sqrt_ps(mul(_mm256_andnot_ps(sign, p[k]), S(pr.inv_far)));
    const __m256 u = _mm256_or_ps(mag, _mm256_and_ps(sign, p[k]));
    const __m256 gk = clamp0(mul(mul(add(u, S(1.0f)), S(0.5f)), S(last)), last);
    i0[k] = _mm256_min_epi32(_mm256_cvttps_epi32(gk), _mm256_set1_epi32(size - 2));
    fr[k] = sub(gk, _mm256_cvtepi32_ps(i0[k]));
  }
  const __m256i base = _mm256_add_epi32(
      _mm256_mullo_epi32(_mm256_add_epi32(_mm256_mullo_epi32(i0[2], _mm256_set1_epi32(size)), i0[1]),
                         _mm256_set1_epi32(size)),
      i0[0]);
  const __m256i four = _mm256_set1_epi32(4);
  static_assert(sizeof(AOFieldGridNode) == 4 * sizeof(float));
  const float* nodes = &f.nodes[0].omega;
  const __m256 one = S(1.0f);
  __m256 omega = S(0.0f), dx = S(0.0f), dy = S(0.0f), dz = S(0.0f);
  for (int corner = 0; corner < 8; ++corner) {
    const int cx = corner & 1, cy = (corner >> 1) & 1, cz = corner >> 2;
    const __m256 w = mul(mul(cx ? fr[0] : sub(one, fr[0]), cy ? fr[1] : sub(one, fr[1])), cz ? fr[2] : sub(one, fr[2]));
    const __m256i corner_offset = _mm256_set1_epi32(cx + cy * size + cz * size * size);
    const __m256i at = _mm256_mullo_epi32(_mm256_add_epi32(base, corner_offset), four);
    omega = add(omega, mul(w, _mm256_i32gather_ps(nodes, at, 4)));
    dx = add(dx, mul(w, _mm256_i32gather_ps(nodes + 1, at, 4)));
    dy = add(dy, mul(w, _mm256_i32gather_ps(nodes + 2, at, 4)));
    dz = add(dz, mul(w, _mm256_i32gather_ps(nodes + 3, at, 4)));
  }
  store_open(pr, l, cap8(pr.table, omega, cos_beta8(l, dx, dy, dz)), open);
}

#undef PENUMBRA_AVX2
#endif

}  // namespace

const char* to_string(AOFieldRepresentation representation) {
  return representation == AOFieldRepresentation::Grid ? "grid" : "radial-fit";
}

AOFieldCaster AOFieldCaster::preset(Preset preset) {
  AOFieldCaster c;
  switch (preset) {
    case Preset::Draft: c.resolution = 8; c.radial_samples = 16; c.rays_per_sample = 64; c.grid_size = 16; break;
    case Preset::Medium: c.resolution = 16; c.radial_samples = 32; c.rays_per_sample = 256; c.grid_size = 32; break;
    case Preset::High: c.resolution = 32; c.radial_samples = 48; c.rays_per_sample = 512; c.grid_size = 48; break;
  }
  return c;
}

bool ao_field_origin(const MeshData& mesh, glm::dvec3& centre, double& radius) {
  glm::dvec3 centroid(0.0);
  double area = 0.0;
  for (std::size_t t = 0; t < mesh.triangle_count(); ++t) {
    const glm::dvec3 p0(mesh.positions[mesh.indices[3 * t]]), p1(mesh.positions[mesh.indices[3 * t + 1]]),
        p2(mesh.positions[mesh.indices[3 * t + 2]]);
    const double a = 0.5 * glm::length(glm::cross(p1 - p0, p2 - p0));
    centroid += a * (p0 + p1 + p2) / 3.0;
    area += a;
  }
  centre = area > 0.0 ? centroid / area : glm::dvec3(mesh.bounds.center());
  radius = 0.0;
  for (const glm::vec3& v : mesh.positions) radius = std::max(radius, glm::length(glm::dvec3(v) - centre));
  return area > 0.0;
}

Status validate_ao_field_caster(const AOFieldCaster& c, const glm::mat4& m, std::string_view context) {
  // Each setting's range: the field list (ao_field_fields.cpp).
  PENUMBRA_TRY(check_fields(ao_field_caster_info(), &c, context));
  for (int col = 0; col < 4; ++col)
    for (int row = 0; row < 4; ++row)
      if (!std::isfinite(m[col][row])) return bad_setting(context, "the world transform is not finite");
  const glm::mat3 axes(m);
  const float sx = glm::length(axes[0]), sy = glm::length(axes[1]), sz = glm::length(axes[2]);
  if (!(sx > 0.0f && sy > 0.0f && sz > 0.0f) || glm::determinant(axes) == 0.0f)
    return bad_setting(context, "the world transform is singular (a zero scale); give the caster a non-zero scale");
  const float lo = std::min({sx, sy, sz}), hi = std::max({sx, sy, sz});
  if (hi - lo > 1e-4f * hi)
    return bad_setting(context, "non-uniform scale (" + std::to_string(sx) + ", " + std::to_string(sy) + ", " +
                                    std::to_string(sz) +
                                    ") is not supported by ambient occlusion fields; apply the scale to the mesh "
                                    "and give the entity a uniform scale");
  // Shear would also distort the field: the axes must be orthogonal.
  if (std::abs(glm::dot(axes[0], axes[1])) > 1e-4f * hi * hi || std::abs(glm::dot(axes[0], axes[2])) > 1e-4f * hi * hi ||
      std::abs(glm::dot(axes[1], axes[2])) > 1e-4f * hi * hi)
    return bad_setting(context, "the world transform shears the caster; use rotation, translation and uniform scale");
  return {};
}

std::uint64_t AOFieldData::bytes() const {
  return texels.size() * 7ull * sizeof(float) + nodes.size() * 4ull * sizeof(float);
}

bool AOFieldData::valid() const {
  if (representation == AOFieldRepresentation::RadialFit)
    return resolution > 0 && texels.size() == 6 * std::size_t{resolution} * resolution;
  return representation == AOFieldRepresentation::Grid && grid_size >= 2 &&
         nodes.size() == std::size_t{grid_size} * grid_size * grid_size;
}

glm::vec3 cube_direction(std::uint32_t face, float s, float t) {
  const int m = static_cast<int>(face / 2);
  glm::vec3 d(0.0f);
  d[m] = (face % 2) != 0 ? -1.0f : 1.0f;
  d[(m + 1) % 3] = s;
  d[(m + 2) % 3] = t;
  return glm::normalize(d);
}

float cap_occlusion(float omega, float cos_beta) {
  // NaN inputs count as an empty cap / a perpendicular axis.
  const double om = omega > 0.0f ? std::min(static_cast<double>(omega), 4.0 * kPiD) : 0.0;
  const double cb = cos_beta == cos_beta ? std::clamp(static_cast<double>(cos_beta), -1.0, 1.0) : 0.0;
  const double cos_alpha = 1.0 - om / (2.0 * kPiD);
  // Omega > 2 pi: the complement of the cap is a cap of half-angle pi - alpha around the
  // opposite axis (angle pi - beta to n), so A(alpha, beta) = 1 - A(pi - alpha, pi - beta).
  if (cos_alpha < 0.0) return static_cast<float>(1.0 - cap_occlusion_small(-cos_alpha, -cb));
  return static_cast<float>(cap_occlusion_small(cos_alpha, cb));
}

std::span<const float> cap_occlusion_table_values() { return cap_table().values; }

float cap_occlusion_table(float omega, float cos_beta) {
  return cap_lookup(cap_table().values.data(), omega, cos_beta);
}

float evaluate_local(const AOFieldData& field, glm::vec3 x, glm::vec3 n) {
  if (!field.valid()) return 0.0f;
  return occlusion(Prepared(field), x, n);
}

void accumulate_open(const AOFieldData& field, const glm::mat4& world_to_local, std::span<const glm::vec3> x,
                     std::span<const glm::vec3> n, std::span<float> open) {
  const glm::mat3 linear(world_to_local);
  const glm::vec3 offset(world_to_local[3]);
  const std::size_t count = std::min({x.size(), n.size(), open.size()});
  if (!field.valid()) return;
  const Prepared pr(field);
  std::size_t i = 0;
#ifdef PENUMBRA_AO_FIELD_AVX2
  if (cpu_has_avx2() && (pr.grid || field.inside_exponent == 2.0f)) {
    const auto batch = pr.grid ? grid_batch8 : radial_batch8;
    for (; i + 8 <= count; i += 8) batch(pr, linear, offset, &x[i], &n[i], &open[i]);
  }
#endif
  for (; i < count; ++i) {
    const glm::vec3 nl = linear * n[i];
    const float len2 = glm::dot(nl, nl);
    if (!(len2 > 0.0f) || !std::isfinite(len2)) continue;
    open[i] *= 1.0f - occlusion(pr, linear * x[i] + offset, nl * (1.0f / std::sqrt(len2)));
  }
}

AOFieldCap evaluate_cap(const AOFieldData& field, const glm::mat4& caster_world, glm::vec3 x, glm::vec3 n) {
  AOFieldCap cap;
  if (!field.valid()) return cap;
  const glm::mat4 inv = glm::inverse(caster_world);
  const glm::vec3 xl = glm::vec3(inv * glm::vec4(x, 1.0f));
  const glm::vec3 nl = glm::mat3(inv) * n;
  const float len = glm::length(nl);
  if (!(len > 0.0f) || !std::isfinite(len)) return cap;
  CapOut out;
  cap.occlusion = occlusion(Prepared(field), xl, nl / len, &out);
  // The axis back in world space (the matrix's rotation; its uniform scale drops out).
  const glm::vec3 axis = glm::mat3(caster_world) * out.axis;
  const float axis_len = glm::length(axis);
  if (out.omega > 0.0f && axis_len > 0.0f && std::isfinite(axis_len)) {
    cap.omega = out.omega;
    cap.axis = axis / axis_len;
  }
  return cap;
}

float combine_caps(std::span<const AOFieldCap> caps) {
  constexpr float kTwoPi = 2.0f * std::numbers::pi_v<float>;
  // Out-of-range and NaN inputs count as nothing (the comparisons below are false for NaN).
  const auto occlusion_of = [](const AOFieldCap& c) { return c.occlusion > 0.0f ? std::min(c.occlusion, 1.0f) : 0.0f; };
  const auto radius_of = [](const AOFieldCap& c) {  // alpha = acos(1 - omega / 2 pi)
    const float omega = c.omega > 0.0f ? std::min(c.omega, 2.0f * kTwoPi) : 0.0f;
    return std::acos(std::clamp(1.0f - omega / kTwoPi, -1.0f, 1.0f));
  };
  float sum = 0.0f, largest = 0.0f, overlap = 0.0f;
  for (std::size_t i = 0; i < caps.size(); ++i) {
    const float ai = occlusion_of(caps[i]), alpha_i = radius_of(caps[i]);
    sum += ai;
    largest = std::max(largest, ai);
    for (std::size_t j = 0; j < i; ++j) {
      const float aj = occlusion_of(caps[j]), alpha_j = radius_of(caps[j]);
      const float c = glm::dot(caps[i].axis, caps[j].axis);
      const float gamma = std::acos(c > -1.0f ? std::min(c, 1.0f) : -1.0f);  // NaN: opposite, no overlap
      const float smaller = std::min(alpha_i, alpha_j);
      // The fraction of the smaller cap inside the larger: 0 when they are apart (gamma >= the
      // sum of the radii), 1 when nested (gamma <= their difference), a ramp between.
      const float ramp = smaller > 0.0f ? (alpha_i + alpha_j - gamma) / (2.0f * smaller) : 0.0f;
      const float f = ramp > 0.0f ? std::min(ramp, 1.0f) : 0.0f;
      overlap += f * std::min(ai, aj);
    }
  }
  return std::clamp(sum - overlap, largest, 1.0f);
}

float evaluate(const AOFieldData& field, const glm::mat4& caster_world, glm::vec3 x, glm::vec3 n) {
  const glm::mat4 inv = glm::inverse(caster_world);
  const glm::vec3 xl = glm::vec3(inv * glm::vec4(x, 1.0f));
  const glm::vec3 nl = glm::mat3(inv) * n;  // rotation / scale only: normalise below
  const float len = glm::length(nl);
  if (!(len > 0.0f) || !std::isfinite(len)) return 0.0f;
  return evaluate_local(field, xl, nl / len);
}

float hull_distance(const AOFieldData& field, glm::vec3 w) {
  const float len = glm::length(w);
  if (field.representation != AOFieldRepresentation::RadialFit || !field.valid() || !(len > 0.0f) ||
      !std::isfinite(len))
    return 0.0f;
  return lookup(field, w / len).r0;
}

float combine_occlusion(std::span<const float> occlusions) {
  float open = 1.0f;  // prod (1 - A_i): stays in [0, 1], underflow only reaches 0
  for (float a : occlusions) open *= 1.0f - (a > 0.0f ? std::min(a, 1.0f) : 0.0f);  // NaN counts as 0
  return std::clamp(1.0f - open, 0.0f, 1.0f);
}

}  // namespace penumbra
