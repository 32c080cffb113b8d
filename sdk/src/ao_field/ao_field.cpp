// Ambient occlusion fields (see ao_field.h): validation, the spherical-cap closed form and the
// CPU evaluation of Kontkanen & Laine 2005, section 3 (the runtime of the thesis, section 4.1).
#include "penumbra/ao_field/ao_field.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <string>

#include <glm/geometric.hpp>
#include <glm/matrix.hpp>

namespace penumbra {

namespace {

constexpr double kPiD = std::numbers::pi;

Error bad_setting(std::string_view context, const std::string& what) {
  return make_error(ErrorCode::InvalidArgument, std::string(context) + ": " + what);
}

// The face, and the in-face coordinates (s, t) in [-1, 1], of direction d (inverse of
// cube_direction). Plain scalars and selects (no run-time indexing of glm vectors, which
// compiles to branches).
void cube_coordinates(glm::vec3 d, std::uint32_t& face, float& s, float& t) {
  const float ax = std::abs(d.x), ay = std::abs(d.y), az = std::abs(d.z);
  const bool mx = ax >= ay && ax >= az, my = !mx && ay >= az;
  const float major = mx ? d.x : (my ? d.y : d.z);
  const float inv = 1.0f / std::abs(major);
  // Axis m's in-face coordinates are axes (m + 1) % 3 and (m + 2) % 3.
  s = (mx ? d.y : (my ? d.z : d.x)) * inv;
  t = (mx ? d.z : (my ? d.x : d.y)) * inv;
  face = (mx ? 0u : (my ? 2u : 4u)) + (major < 0.0f ? 1u : 0u);
}

// Bilinear interpolation of the texels of one face in direction w (any non-zero length; clamped
// at the face's edge texel centres, so each lookup reads a single face).
AOFieldTexel lookup(const AOFieldData& field, glm::vec3 w) {
  std::uint32_t face = 0;
  float s = 0.0f, t = 0.0f;
  cube_coordinates(w, face, s, t);
  const std::uint32_t res = field.resolution;
  const float last = static_cast<float>(res - 1);
  const float u = std::clamp(0.5f * (s + 1.0f) * static_cast<float>(res) - 0.5f, 0.0f, last);
  const float v = std::clamp(0.5f * (t + 1.0f) * static_cast<float>(res) - 0.5f, 0.0f, last);
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
  static constexpr int kSize = 128;  // intervals per axis
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

// Step 5 of evaluate_local: the linear fade to 0 between fade_start x r_far and r_far.
float fade(const AOFieldData& field, float r) {
  return std::clamp((field.r_far - r) / ((1.0f - field.fade_start) * field.r_far), 0.0f, 1.0f);
}

// Steps 2-4 for a RadialFit field at p = x - centre, r = |p| in (0, r_far).
float radial_occlusion(const AOFieldData& field, glm::vec3 p, float r, glm::vec3 n) {
  const AOFieldTexel t = lookup(field, p);
  // Outside the hull: r itself; inside: the hull point, then the blend towards A0.
  const float rc = std::max(r, t.r0);
  const float denom = (t.a * rc + t.b) * rc + t.c;
  const float omega = denom > 0.0f ? std::min(1.0f / denom, 4.0f * std::numbers::pi_v<float>) : 0.0f;
  const float inv_r = 1.0f / r;
  const glm::vec3 axis = t.c0 - (rc * inv_r) * p;
  const float len2 = glm::dot(axis, axis);
  const float cos_beta = len2 > 0.0f ? glm::dot(n, axis) / std::sqrt(len2) : -glm::dot(n, p) * inv_r;
  float a = cap_occlusion_table(omega, cos_beta);
  if (r < t.r0) {
    const float A0 = field.inside_occlusion, q = r / t.r0;
    a = A0 + (a - A0) * (field.inside_exponent == 2.0f ? q * q : std::pow(q, field.inside_exponent));
  }
  return a;
}

// Steps 2-3 for a Grid field (Malmer et al. 2007): trilinear Omega and Omega x Upsilon on the
// warped grid.
float grid_occlusion(const AOFieldData& field, glm::vec3 p, float r, glm::vec3 n) {
  const std::uint32_t size = field.grid_size;
  const float last = static_cast<float>(size - 1), inv_far = 1.0f / field.r_far;
  std::uint32_t i0[3];
  float f[3];
  for (int k = 0; k < 3; ++k) {
    const float u = std::copysign(std::sqrt(std::abs(p[k]) * inv_far), p[k]);  // the warp's inverse
    const float g = std::clamp((u + 1.0f) * 0.5f * last, 0.0f, last);
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
  const float cos_beta = len2 > 0.0f ? glm::dot(n, dir) / std::sqrt(len2) : -glm::dot(n, p) / r;
  return cap_occlusion_table(omega, cos_beta);
}

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

Status validate_ao_field_caster(const AOFieldCaster& c, const glm::mat4& m, std::string_view context) {
  if (c.representation != AOFieldRepresentation::RadialFit && c.representation != AOFieldRepresentation::Grid)
    return bad_setting(context, "representation " + std::to_string(static_cast<std::uint32_t>(c.representation)) +
                                    " is unknown; use RadialFit or Grid");
  if (c.supersample < 1 || c.supersample > 4)
    return bad_setting(context, "supersample " + std::to_string(c.supersample) + " is outside 1..4; use 2");
  if (c.grid_size < 4 || c.grid_size > 128)
    return bad_setting(context, "grid_size " + std::to_string(c.grid_size) +
                                    " is outside 4..128 vertices per axis; use 16, 32 or 48");
  if (c.resolution < 1 || c.resolution > 256)
    return bad_setting(context, "resolution " + std::to_string(c.resolution) +
                                    " is outside 1..256 texels per face; use 8, 16 or 32");
  if (c.radial_samples < 3 || c.radial_samples > 1024)
    return bad_setting(context, "radial_samples " + std::to_string(c.radial_samples) +
                                    " is outside 3..1024; the fit of three coefficients needs at least 3 radii");
  if (c.rays_per_sample < 16)
    return bad_setting(context, "rays_per_sample " + std::to_string(c.rays_per_sample) + " is below 16; use 64 or more");
  if (!std::isfinite(c.falloff_distance) || c.falloff_distance < 0.0f)
    return bad_setting(context, "falloff_distance must be finite and >= 0 (0 derives 6 x the bounding radius)");
  if (!(c.fade_start > 0.0f && c.fade_start < 1.0f))
    return bad_setting(context, "fade_start must be in (0, 1), e.g. 0.8");
  if (!(c.inside_occlusion >= 0.0f && c.inside_occlusion <= 1.0f))
    return bad_setting(context, "inside_occlusion must be in [0, 1]");
  if (!(c.inside_exponent > 0.0f && std::isfinite(c.inside_exponent)))
    return bad_setting(context, "inside_exponent must be finite and > 0, e.g. 2");
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

float cap_occlusion_table(float omega, float cos_beta) {
  constexpr float n = static_cast<float>(CapTable::kSize);
  const CapTable& t = cap_table();
  // NaN inputs land on the clamps' lower ends through the comparisons below.
  float u = omega * (n / (4.0f * std::numbers::pi_v<float>));
  float v = (cos_beta + 1.0f) * (0.5f * n);
  u = u > 0.0f ? std::min(u, n) : 0.0f;
  v = v > 0.0f ? std::min(v, n) : 0.0f;
  const int i = std::min(static_cast<int>(u), CapTable::kSize - 1), j = std::min(static_cast<int>(v), CapTable::kSize - 1);
  const float fu = u - static_cast<float>(i), fv = v - static_cast<float>(j);
  const float* row0 = &t.values[static_cast<std::size_t>(i * (CapTable::kSize + 1) + j)];
  const float* row1 = row0 + (CapTable::kSize + 1);
  const float a0 = row0[0] + (row0[1] - row0[0]) * fv, a1 = row1[0] + (row1[1] - row1[0]) * fv;
  return a0 + (a1 - a0) * fu;
}

float evaluate_local(const AOFieldData& field, glm::vec3 x, glm::vec3 n) {
  if (!field.valid()) return 0.0f;
  const glm::vec3 p = x - field.centre;
  const float r = glm::length(p);
  if (!(r < field.r_far)) return 0.0f;  // beyond the falloff (or not finite)
  if (r == 0.0f) return field.inside_occlusion;
  const float a = field.representation == AOFieldRepresentation::Grid ? grid_occlusion(field, p, r, n)
                                                                       : radial_occlusion(field, p, r, n);
  return std::clamp(a * fade(field, r), 0.0f, 1.0f);
}

void accumulate_open(const AOFieldData& field, const glm::mat4& world_to_local, std::span<const glm::vec3> x,
                     std::span<const glm::vec3> n, std::span<float> open) {
  const glm::mat3 linear(world_to_local);
  const glm::vec3 offset(world_to_local[3]);
  const std::size_t count = std::min({x.size(), n.size(), open.size()});
  for (std::size_t i = 0; i < count; ++i) {
    const glm::vec3 nl = linear * n[i];
    const float len2 = glm::dot(nl, nl);
    if (!(len2 > 0.0f) || !std::isfinite(len2)) continue;
    open[i] *= 1.0f - evaluate_local(field, linear * x[i] + offset, nl / std::sqrt(len2));
  }
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
