// Real spherical harmonics, bands l = 0..2 (9 coefficients), in float and RGB.
//
// Convention (the only place it is written down; shaders and bakers follow it):
// - Ordering: coefficient i = l (l + 1) + m, so 0: (0,0); 1..3: (1,-1), (1,0), (1,1);
//   4..8: (2,-2), (2,-1), (2,0), (2,1), (2,2). "L1" means the first 4 coefficients, "L2" all 9.
// - Basis: Sloan 2008, "Stupid Spherical Harmonics (SH) Tricks", appendix A2, Condon-Shortley
//   phase included, for a unit direction d = (x, y, z) in whatever frame the caller uses (the
//   SDK's world frame is +Y up; the basis does not care):
//     Y0 = 0.282095                         (1/2 sqrt(1/pi))
//     Y1 = -0.488603 y, Y2 = 0.488603 z, Y3 = -0.488603 x            (sqrt(3/(4 pi)))
//     Y4 = 1.092548 xy, Y5 = -1.092548 yz, Y7 = -1.092548 xz          (1/2 sqrt(15/pi))
//     Y6 = 0.315392 (3z^2 - 1)                                        (1/4 sqrt(5/pi))
//     Y8 = 0.546274 (x^2 - y^2)                                       (1/4 sqrt(15/pi))
// - Normalisation: orthonormal over the sphere, int Y_i Y_j dw = delta_ij. Projection is
//   c_i = int f(w) Y_i(w) dw and evaluation is f(d) = sum_i c_i Y_i(d).
// - Irradiance: E(n) = int L(w) max(0, n.w) dw has coefficients A_l c_i with A_0 = pi,
//   A_1 = 2 pi / 3, A_2 = pi / 4 (Ramamoorthi & Hanrahan 2001); sh_convolve_cosine applies them.
//
// All functions are pure, thread-safe and cost a few tens of flops (rotation about 150).
#pragma once

#include <array>

#include <glm/mat3x3.hpp>
#include <glm/vec3.hpp>

namespace penumbra {

inline constexpr int kSHCoefficientsL1 = 4;
inline constexpr int kSHCoefficientsL2 = 9;

// Nine coefficients of a real SH expansion; T is float or glm::vec3 (RGB).
template <class T>
struct SH9 {
  std::array<T, kSHCoefficientsL2> c{};

  T& operator[](int i) { return c[static_cast<std::size_t>(i)]; }
  const T& operator[](int i) const { return c[static_cast<std::size_t>(i)]; }
  SH9& operator+=(const SH9& o) {
    for (std::size_t i = 0; i < c.size(); ++i) c[i] += o.c[i];
    return *this;
  }
  SH9& operator*=(float s) {
    for (T& v : c) v *= s;
    return *this;
  }
  friend SH9 operator+(SH9 a, const SH9& b) { return a += b; }
  friend SH9 operator*(SH9 a, float s) { return a *= s; }
  friend bool operator==(const SH9&, const SH9&) = default;
};

using SH9f = SH9<float>;
using SH9rgb = SH9<glm::vec3>;

// The nine basis functions at unit direction d.
SH9f sh_basis(glm::vec3 d);

// Projection, one sample at a time: sh += value * Y(d). For a Monte Carlo or quadrature estimate
// of c_i = int f Y_i dw, pass value = f(d) * weight with weight = 1 / (pdf(d) * sample count)
// (or the quadrature weight).
void sh_add_sample(SH9f& sh, glm::vec3 d, float value);
void sh_add_sample(SH9rgb& sh, glm::vec3 d, glm::vec3 value);

// sum_i c_i Y_i(d) over the first `bands` bands (1: L0 only, 2: L1, 3: L2).
float sh_evaluate(const SH9f& sh, glm::vec3 d, int bands = 3);
glm::vec3 sh_evaluate(const SH9rgb& sh, glm::vec3 d, int bands = 3);

// "Never negative": sh_evaluate clamped to >= 0 per channel, for irradiance whose truncated
// expansion rings below zero opposite a bright light. Window first to reduce the ringing.
float sh_evaluate_non_negative(const SH9f& sh, glm::vec3 d, int bands = 3);
glm::vec3 sh_evaluate_non_negative(const SH9rgb& sh, glm::vec3 d, int bands = 3);

// Irradiance coefficients from radiance coefficients (clamped-cosine convolution). Evaluate the
// result at a normal n to get E(n) = int L(w) max(0, n.w) dw, exact for band-limited L.
SH9f sh_convolve_cosine(const SH9f& radiance);
SH9rgb sh_convolve_cosine(const SH9rgb& radiance);

// The expansion of the rotated function g(d) = f(R^T d), so that sh_evaluate(result, R d) ==
// sh_evaluate(sh, d). R must be a rotation (orthonormal, det +1). Exact: band 1 rotates as a
// vector and band 2 as the traceless symmetric matrix Q of f_2(d) = d^T Q d, Q' = R Q R^T.
SH9f sh_rotate(const SH9f& sh, const glm::mat3& r);
SH9rgb sh_rotate(const SH9rgb& sh, const glm::mat3& r);

// Deringing windows: per-band factors sigma_l (l = 0, 1, 2) that damp higher bands (Sloan 2008,
// section "Windowing"; Sloan 2017, "Deringing Spherical Harmonics"). `width` > 0 is the band at
// which the window reaches zero (Hanning) or its first zero (Lanczos); larger is sharper.
//   Hanning: sigma_l = (1 + cos(pi l / width)) / 2 for l < width, else 0.
//   Lanczos: sigma_l = sin(pi l / width) / (pi l / width), sigma_0 = 1.
std::array<float, 3> sh_hanning_window(float width);
std::array<float, 3> sh_lanczos_window(float width);
// Multiplies every coefficient of band l by window[l].
SH9f sh_apply_window(const SH9f& sh, const std::array<float, 3>& window);
SH9rgb sh_apply_window(const SH9rgb& sh, const std::array<float, 3>& window);

}  // namespace penumbra
