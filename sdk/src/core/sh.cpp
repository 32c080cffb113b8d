// Real spherical harmonics up to band 2 (see penumbra/core/sh.h for the convention).
#include "penumbra/core/sh.h"

#include <algorithm>
#include <cmath>

#include <glm/common.hpp>

namespace penumbra {
namespace {

constexpr float kPi = 3.14159265358979323846f;
constexpr float kY0 = 0.28209479177387814f;   // 1/2 sqrt(1/pi)
constexpr float kY1 = 0.48860251190291992f;   // sqrt(3/(4 pi))
constexpr float kY2a = 1.09254843059207907f;  // 1/2 sqrt(15/pi): xy, yz, xz
constexpr float kY2b = 0.31539156525252005f;  // 1/4 sqrt(5/pi): 3z^2 - 1
constexpr float kY2c = 0.54627421529603959f;  // 1/4 sqrt(15/pi): x^2 - y^2

constexpr int band_of(std::size_t i) { return i == 0 ? 0 : i < 4 ? 1 : 2; }

float clamp_non_negative(float v) { return std::max(v, 0.0f); }
glm::vec3 clamp_non_negative(glm::vec3 v) { return glm::max(v, glm::vec3(0.0f)); }

template <class T>
void add_sample(SH9<T>& sh, glm::vec3 d, T value) {
  const SH9f y = sh_basis(d);
  for (std::size_t i = 0; i < sh.c.size(); ++i) sh.c[i] += value * y.c[i];
}

template <class T>
T evaluate(const SH9<T>& sh, glm::vec3 d, int bands) {
  const SH9f y = sh_basis(d);
  const std::size_t n = bands <= 1 ? 1 : bands == 2 ? 4 : 9;
  T sum = sh.c[0] * y.c[0];
  for (std::size_t i = 1; i < n; ++i) sum += sh.c[i] * y.c[i];
  return sum;
}

template <class T>
SH9<T> apply_window(const SH9<T>& sh, const std::array<float, 3>& window) {
  SH9<T> out = sh;
  for (std::size_t i = 0; i < out.c.size(); ++i) out.c[i] *= window[static_cast<std::size_t>(band_of(i))];
  return out;
}

template <class T>
SH9<T> rotate(const SH9<T>& sh, const glm::mat3& r) {
  // R(i, j): row i, column j (glm stores columns).
  auto R = [&](int i, int j) { return r[j][i]; };
  SH9<T> out;
  out.c[0] = sh.c[0];

  // Band 1: f_1(d) = kY1 v.d with v = (-c3, -c1, c2); the rotated function has v' = R v.
  const T v[3] = {-sh.c[3], -sh.c[1], sh.c[2]};
  T w[3];
  for (int i = 0; i < 3; ++i) w[i] = v[0] * R(i, 0) + v[1] * R(i, 1) + v[2] * R(i, 2);
  out.c[1] = -w[1];
  out.c[2] = w[2];
  out.c[3] = -w[0];

  // Band 2: f_2(d) = d^T Q d on the unit sphere (3z^2 - 1 = 2z^2 - x^2 - y^2 there), with the
  // traceless symmetric Q below; the rotated function has Q' = R Q R^T.
  const T qxy = sh.c[4] * (0.5f * kY2a), qyz = sh.c[5] * (-0.5f * kY2a), qxz = sh.c[7] * (-0.5f * kY2a);
  const T qxx = sh.c[6] * -kY2b + sh.c[8] * kY2c;
  const T qyy = sh.c[6] * -kY2b - sh.c[8] * kY2c;
  const T qzz = sh.c[6] * (2.0f * kY2b);
  const T q[3][3] = {{qxx, qxy, qxz}, {qxy, qyy, qyz}, {qxz, qyz, qzz}};
  T rq[3][3];  // R Q
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) rq[i][j] = q[0][j] * R(i, 0) + q[1][j] * R(i, 1) + q[2][j] * R(i, 2);
  }
  auto rqrt = [&](int i, int j) { return rq[i][0] * R(j, 0) + rq[i][1] * R(j, 1) + rq[i][2] * R(j, 2); };
  out.c[4] = rqrt(0, 1) * (2.0f / kY2a);
  out.c[5] = rqrt(1, 2) * (-2.0f / kY2a);
  out.c[6] = rqrt(2, 2) * (0.5f / kY2b);
  out.c[7] = rqrt(0, 2) * (-2.0f / kY2a);
  out.c[8] = (rqrt(0, 0) - rqrt(1, 1)) * (0.5f / kY2c);
  return out;
}

constexpr std::array<float, 3> kCosineLobe = {kPi, 2.0f * kPi / 3.0f, kPi / 4.0f};

}  // namespace

SH9f sh_basis(glm::vec3 d) {
  const float x = d.x, y = d.y, z = d.z;
  SH9f b;
  b.c = {kY0,
         -kY1 * y,
         kY1 * z,
         -kY1 * x,
         kY2a * x * y,
         -kY2a * y * z,
         kY2b * (3.0f * z * z - 1.0f),
         -kY2a * x * z,
         kY2c * (x * x - y * y)};
  return b;
}

void sh_add_sample(SH9f& sh, glm::vec3 d, float value) { add_sample(sh, d, value); }
void sh_add_sample(SH9rgb& sh, glm::vec3 d, glm::vec3 value) { add_sample(sh, d, value); }

float sh_evaluate(const SH9f& sh, glm::vec3 d, int bands) { return evaluate(sh, d, bands); }
glm::vec3 sh_evaluate(const SH9rgb& sh, glm::vec3 d, int bands) { return evaluate(sh, d, bands); }

float sh_evaluate_non_negative(const SH9f& sh, glm::vec3 d, int bands) {
  return clamp_non_negative(evaluate(sh, d, bands));
}
glm::vec3 sh_evaluate_non_negative(const SH9rgb& sh, glm::vec3 d, int bands) {
  return clamp_non_negative(evaluate(sh, d, bands));
}

SH9f sh_convolve_cosine(const SH9f& radiance) { return apply_window(radiance, kCosineLobe); }
SH9rgb sh_convolve_cosine(const SH9rgb& radiance) { return apply_window(radiance, kCosineLobe); }

SH9f sh_rotate(const SH9f& sh, const glm::mat3& r) { return rotate(sh, r); }
SH9rgb sh_rotate(const SH9rgb& sh, const glm::mat3& r) { return rotate(sh, r); }

std::array<float, 3> sh_hanning_window(float width) {
  std::array<float, 3> w{};
  for (int l = 0; l < 3; ++l) {
    const auto fl = static_cast<float>(l);
    w[static_cast<std::size_t>(l)] = fl < width ? 0.5f * (1.0f + std::cos(kPi * fl / width)) : 0.0f;
  }
  return w;
}

std::array<float, 3> sh_lanczos_window(float width) {
  std::array<float, 3> w{1.0f, 0.0f, 0.0f};
  for (int l = 1; l < 3; ++l) {
    const float x = kPi * static_cast<float>(l) / width;
    w[static_cast<std::size_t>(l)] = std::sin(x) / x;
  }
  return w;
}

SH9f sh_apply_window(const SH9f& sh, const std::array<float, 3>& window) { return apply_window(sh, window); }
SH9rgb sh_apply_window(const SH9rgb& sh, const std::array<float, 3>& window) { return apply_window(sh, window); }

}  // namespace penumbra
