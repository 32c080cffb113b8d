// Quasi-Monte Carlo point sets and direction mappings (see penumbra/core/sampling.h).
//
// Sobol' direction numbers: Joe & Kuo 2008, "Constructing Sobol sequences with better
// two-dimensional projections" (primitive polynomials and initial m_k of dimensions 2-4 of their
// new-joe-kuo-6.21201 table). Owen scrambling: Burley 2020, "Practical Hash-based Owen
// Scrambling" (JCGT 9(4)), with its Laine-Karras style hash and index shuffling.
#include "penumbra/core/sampling.h"

#include <algorithm>
#include <array>
#include <cassert>
#include <cmath>

#include "penumbra/core/random.h"

namespace penumbra {
namespace {

constexpr float kPi = 3.14159265358979323846f;
constexpr float kOneMinusEpsilon = 0x1.fffffep-1f;  // the largest float below 1

// ---- Sobol' generator matrices --------------------------------------------------------------

struct SobolPolynomial {
  unsigned degree;        // s
  unsigned coefficients;  // a: the inner coefficients a_1..a_{s-1}, a_1 in the highest bit
  std::array<std::uint64_t, 3> initial;  // m_1..m_s (odd, m_k < 2^k)
};

// Dimensions 1-3 (dimension 0 is the van der Corput sequence).
constexpr std::array<SobolPolynomial, 3> kSobolPolynomials = {{
    {1, 0, {1, 0, 0}},  // x + 1
    {2, 1, {1, 3, 0}},  // x^2 + x + 1
    {3, 1, {1, 3, 1}},  // x^3 + x + 1
}};

using DirectionTable = std::array<std::array<std::uint32_t, 32>, 4>;

// Direction numbers v_k = m_k / 2^k as 32-bit fractions, with the Bratley-Fox recurrence
//   m_k = 2 a_1 m_{k-1} ^ 4 a_2 m_{k-2} ^ ... ^ 2^(s-1) a_(s-1) m_(k-s+1) ^ 2^s m_(k-s) ^ m_(k-s).
constexpr DirectionTable make_sobol_directions() {
  DirectionTable v{};
  for (unsigned k = 0; k < 32; ++k) v[0][k] = 1u << (31 - k);
  for (unsigned d = 1; d < 4; ++d) {
    const SobolPolynomial& p = kSobolPolynomials[d - 1];
    std::array<std::uint64_t, 33> m{};  // 1-based
    for (unsigned k = 1; k <= 32; ++k) {
      if (k <= p.degree) {
        m[k] = p.initial[k - 1];
      } else {
        m[k] = m[k - p.degree] ^ (m[k - p.degree] << p.degree);
        for (unsigned j = 1; j < p.degree; ++j) {
          if ((p.coefficients >> (p.degree - 1 - j)) & 1u) m[k] ^= m[k - j] << j;
        }
      }
      v[d][k - 1] = static_cast<std::uint32_t>(m[k] << (32 - k));
    }
  }
  return v;
}

constexpr DirectionTable kSobolDirections = make_sobol_directions();

// The generator matrix times the index, a byte at a time: kSobolBytes[dim][b][v] is the XOR of
// the direction numbers of the bits set in byte value v at byte position b (4 look-ups per point
// instead of a data-dependent branch per bit).
using ByteTable = std::array<std::array<std::array<std::uint32_t, 256>, 4>, 4>;
constexpr ByteTable make_sobol_bytes() {
  ByteTable t{};
  for (unsigned d = 0; d < 4; ++d)
    for (unsigned b = 0; b < 4; ++b)
      for (unsigned v = 0; v < 256; ++v)
        for (unsigned bit = 0; bit < 8; ++bit)
          if ((v >> bit) & 1u) t[d][b][v] ^= kSobolDirections[d][8 * b + bit];
  return t;
}
constexpr ByteTable kSobolBytes = make_sobol_bytes();

std::uint32_t sobol_raw(std::uint32_t index, std::uint32_t dim) {
  const auto& t = kSobolBytes[dim];
  return t[0][index & 0xffu] ^ t[1][(index >> 8) & 0xffu] ^ t[2][(index >> 16) & 0xffu] ^ t[3][index >> 24];
}

// ---- Burley 2020 hash-based Owen scrambling --------------------------------------------------

std::uint32_t reverse_bits(std::uint32_t x) {
  x = ((x >> 1) & 0x55555555u) | ((x & 0x55555555u) << 1);
  x = ((x >> 2) & 0x33333333u) | ((x & 0x33333333u) << 2);
  x = ((x >> 4) & 0x0F0F0F0Fu) | ((x & 0x0F0F0F0Fu) << 4);
  return __builtin_bswap32(x);  // the bytes' order: the last two swaps in one instruction (GCC, Clang)
}

// A seeded bijection in which each output bit depends only on the same and lower input bits
// (additions and multiplications by even constants carry upwards only): Burley's
// Laine-Karras-style hash.
std::uint32_t upward_hash(std::uint32_t x, std::uint32_t seed) {
  x += seed;
  x ^= x * 0x6c50b47cu;
  x ^= x * 0xb82f1e52u;
  x ^= x * 0xc7afe638u;
  x ^= x * 0x8d22f6e6u;
  return x;
}

// Nested uniform (Owen) scramble of a 32-bit fraction: bit reversal turns "depends on lower bits"
// into "depends on more significant digits", which is Owen's nested permutation in base 2.
std::uint32_t owen_scramble(std::uint32_t x, std::uint32_t seed) {
  return reverse_bits(upward_hash(reverse_bits(x), seed));
}

std::uint32_t derive_seed(std::uint32_t seed, std::uint32_t salt) {
  return static_cast<std::uint32_t>(mix64((static_cast<std::uint64_t>(seed) << 32) | salt) >> 32);
}

float to_unit_float(std::uint32_t x) { return static_cast<float>(x >> 8) * 0x1p-24f; }

// ---- Halton ----------------------------------------------------------------------------------

constexpr std::array<std::uint32_t, 32> kPrimes = {2,  3,  5,  7,  11, 13, 17, 19, 23, 29,  31,  37,  41,  43,  47,  53,
                                                   59, 61, 67, 71, 73, 79, 83, 89, 97, 101, 103, 107, 109, 113, 127, 131};

// The base-b digits of `index` mirrored about the radix point.
double radical_inverse(std::uint32_t index, std::uint32_t base) {
  const double inv_base = 1.0 / base;
  std::uint64_t reversed = 0;
  double scale = 1.0;
  while (index != 0) {
    const std::uint32_t next = index / base;
    reversed = reversed * base + (index - next * base);
    scale *= inv_base;
    index = next;
  }
  return static_cast<double>(reversed) * scale;
}

}  // namespace

float sobol(std::uint32_t index, std::uint32_t dim, std::uint32_t seed) {
  assert(dim < 4 && "sobol: only dimensions 0..3 are tabulated");
  dim &= 3u;
  // Shuffle the sequence order by Owen-scrambling the index (Burley 2020, section 4): a prefix of
  // 2^k points maps to an aligned block of 2^k points, which is still a (0,k,2)-net.
  const std::uint32_t shuffled = owen_scramble(index, derive_seed(seed, 0xffffffffu));
  return to_unit_float(owen_scramble(sobol_raw(shuffled, dim), derive_seed(seed, dim)));
}

glm::vec2 sobol_2d(std::uint32_t index, std::uint32_t seed) { return Sobol2D(seed)(index); }

Sobol2D::Sobol2D(std::uint32_t seed)
    : shuffle_(derive_seed(seed, 0xffffffffu)), scramble_{derive_seed(seed, 0), derive_seed(seed, 1)} {}

glm::vec2 Sobol2D::operator()(std::uint32_t index) const {
  // sobol() of dimensions 0 and 1 with the index shuffled once; dimension 0's direction numbers
  // are the van der Corput sequence's, so its raw point is the index's bit reversal.
  const std::uint32_t shuffled = owen_scramble(index, shuffle_);
  return {to_unit_float(owen_scramble(reverse_bits(shuffled), scramble_[0])),
          to_unit_float(owen_scramble(sobol_raw(shuffled, 1), scramble_[1]))};
}

float halton(std::uint32_t index, std::uint32_t dim, float rotation) {
  assert(dim < kPrimes.size() && "halton: dim must be below 32");
  double x = radical_inverse(index, kPrimes[dim % kPrimes.size()]);
  // Cranley-Patterson rotation: a toroidal shift that keeps the set's stratification.
  x += static_cast<double>(rotation);
  x -= std::floor(x);
  return std::min(static_cast<float>(x), kOneMinusEpsilon);
}

glm::vec3 uniform_sphere(glm::vec2 u) {
  const float z = 1.0f - 2.0f * u.x;
  const float r = std::sqrt(std::max(0.0f, 1.0f - z * z));
  const float phi = 2.0f * kPi * u.y;
  return {r * std::cos(phi), r * std::sin(phi), z};
}

glm::vec3 uniform_hemisphere(glm::vec2 u) {
  const float z = u.x;
  const float r = std::sqrt(std::max(0.0f, 1.0f - z * z));
  const float phi = 2.0f * kPi * u.y;
  return {r * std::cos(phi), r * std::sin(phi), z};
}

glm::vec2 concentric_disk(glm::vec2 u) {
  // Shirley & Chiu 1997: map squares around the centre of [-1, 1]^2 to circles.
  const glm::vec2 a = 2.0f * u - 1.0f;
  if (a.x == 0.0f && a.y == 0.0f) return {0.0f, 0.0f};
  float r, theta;
  if (std::abs(a.x) > std::abs(a.y)) {
    r = a.x;
    theta = (kPi / 4.0f) * (a.y / a.x);
  } else {
    r = a.y;
    theta = kPi / 2.0f - (kPi / 4.0f) * (a.x / a.y);
  }
  return {r * std::cos(theta), r * std::sin(theta)};
}

glm::vec3 cosine_hemisphere(glm::vec2 u) {
  // Malley's method: a uniform point on the disk lifted onto the hemisphere.
  const glm::vec2 d = concentric_disk(u);
  return {d.x, d.y, std::sqrt(std::max(0.0f, 1.0f - d.x * d.x - d.y * d.y))};
}

void orthonormal_basis(glm::vec3 n, glm::vec3& tangent, glm::vec3& bitangent) {
  // Duff et al. 2017, listing 3: branchless and continuous except across n.z = 0.
  const float sign = std::copysign(1.0f, n.z);
  const float a = -1.0f / (sign + n.z);
  const float b = n.x * n.y * a;
  tangent = {1.0f + sign * n.x * n.x * a, sign * b, -sign * n.x};
  bitangent = {b, sign + n.y * n.y * a, -n.y};
}

glm::vec3 to_world(glm::vec3 n, glm::vec3 d) {
  glm::vec3 t, b;
  orthonormal_basis(n, t, b);
  return d.x * t + d.y * b + d.z * n;
}

}  // namespace penumbra
