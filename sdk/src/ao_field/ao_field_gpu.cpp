// The GPU layout of ambient occlusion fields (see ao_field_gpu.h) and the reference evaluation
// that the renderer's per-pixel pass ports: Kontkanen & Laine 2005, section 3.3 (the runtime), and
// Malmer et al. 2007 for the grid, on a flat buffer of vec4s.
#include "penumbra/ao_field/ao_field_gpu.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <string>

#include <glm/geometric.hpp>
#include <glm/matrix.hpp>

#include "penumbra/ecs/transform.h"

namespace penumbra {

namespace {

constexpr std::size_t kRecord = 7;                  // vec4s per caster record
constexpr std::size_t kMaxVec4s = std::size_t{1} << 24;  // integers stored as exact floats

float as_float(std::size_t i) { return static_cast<float>(i); }
std::size_t as_index(float f) { return f >= 0.0f ? static_cast<std::size_t>(f) : 0; }

// The table lookup of cap_occlusion_table on the buffer (value q at component q % 4 of
// data[table + q / 4]).
float table_lookup(const std::vector<glm::vec4>& data, std::size_t table, float omega, float cos_beta) {
  constexpr int k = kCapTableIntervals;
  constexpr float n = static_cast<float>(k);
  const auto value = [&](int q) { return data[table + static_cast<std::size_t>(q) / 4][q % 4]; };
  const float u = std::min(std::max(0.0f, omega * (n / (4.0f * std::numbers::pi_v<float>))), n);
  const float v = std::min(std::max(0.0f, (cos_beta + 1.0f) * (0.5f * n)), n);
  const int i = std::min(static_cast<int>(u), k - 1), j = std::min(static_cast<int>(v), k - 1);
  const float fu = u - static_cast<float>(i), fv = v - static_cast<float>(j);
  const int q0 = i * (k + 1) + j, q1 = q0 + k + 1;
  const float a0 = value(q0) + (value(q0 + 1) - value(q0)) * fv;
  const float a1 = value(q1) + (value(q1 + 1) - value(q1)) * fv;
  return a0 + (a1 - a0) * fu;
}

// Steps 1-5 of evaluate_local for caster record `rec` at local point x, local unit normal n.
float caster_occlusion(const std::vector<glm::vec4>& data, std::size_t table, std::size_t rec, glm::vec3 x,
                       glm::vec3 n) {
  const glm::vec4 geometry = data[rec + 3], settings = data[rec + 4], layout = data[rec + 5];
  const glm::vec3 centre(geometry);
  const float r_far = geometry.w, fade_scale = settings.x, A0 = settings.y, exponent = settings.z;
  const bool grid = settings.w == 1.0f;
  const std::size_t size = as_index(layout.x), offset = as_index(layout.y);
  const std::size_t extent = grid ? size * size * size : 12 * size * size;
  if (size < (grid ? 2u : 1u) || offset + extent > data.size()) return 0.0f;  // a malformed record
  // Step 1.
  const glm::vec3 p = x - centre;
  const float r = glm::length(p);
  if (!(r < r_far)) return 0.0f;
  if (r == 0.0f) return A0;
  const glm::vec3 w = p / r;
  float omega = 0.0f, a = 0.0f;
  glm::vec3 axis(0.0f);
  float r0 = 0.0f;
  if (!grid) {
    // Step 2, radial fit: the cube face (major axis m of p) and the bilinear texel lookup.
    const glm::vec3 ap = glm::abs(p);
    const int m = ap.x >= ap.y && ap.x >= ap.z ? 0 : (ap.y >= ap.z ? 1 : 2);
    const float s = p[(m + 1) % 3] / ap[m], t = p[(m + 2) % 3] / ap[m];
    const std::size_t face = static_cast<std::size_t>(2 * m) + (p[m] < 0.0f ? 1u : 0u);
    const float last = static_cast<float>(size - 1), res = static_cast<float>(size);
    const float u = std::clamp(0.5f * (s + 1.0f) * res - 0.5f, 0.0f, last);
    const float v = std::clamp(0.5f * (t + 1.0f) * res - 0.5f, 0.0f, last);
    const std::size_t u0 = as_index(u), v0 = as_index(v);
    const std::size_t u1 = std::min(u0 + 1, size - 1), v1 = std::min(v0 + 1, size - 1);
    const float fu = u - static_cast<float>(u0), fv = v - static_cast<float>(v0);
    const std::size_t base = offset + 2 * face * size * size;
    const auto texel = [&](std::size_t tv, std::size_t tu, std::size_t half) {
      return data[base + 2 * (tv * size + tu) + half];
    };
    const auto bilinear = [&](std::size_t half) {
      return (1 - fu) * (1 - fv) * texel(v0, u0, half) + fu * (1 - fv) * texel(v0, u1, half) +
             (1 - fu) * fv * texel(v1, u0, half) + fu * fv * texel(v1, u1, half);
    };
    const glm::vec4 abc_r0 = bilinear(0), c0 = bilinear(1);
    r0 = abc_r0.w;
    const float rc = std::max(r, r0);
    const float denom = (abc_r0.x * rc + abc_r0.y) * rc + abc_r0.z;
    omega = denom > 0.0f ? std::min(1.0f / denom, 4.0f * std::numbers::pi_v<float>) : 0.0f;
    axis = glm::vec3(c0) - rc * w;
  } else {
    // Step 2, grid: per axis the warp's inverse, then the trilinear lookup.
    glm::vec3 g;
    std::size_t i0[3];
    for (int k = 0; k < 3; ++k) {
      const float uk = std::copysign(std::sqrt(std::abs(p[k]) / r_far), p[k]);
      const float last = static_cast<float>(size - 1);
      const float gk = std::clamp((uk + 1.0f) * 0.5f * last, 0.0f, last);
      i0[k] = std::min(as_index(gk), size - 2);
      g[k] = gk - static_cast<float>(i0[k]);
    }
    glm::vec4 sum(0.0f);
    for (int c = 0; c < 8; ++c) {
      const std::size_t cx = c & 1, cy = (c >> 1) & 1, cz = static_cast<std::size_t>(c >> 2);
      const float weight = (cx ? g.x : 1.0f - g.x) * (cy ? g.y : 1.0f - g.y) * (cz ? g.z : 1.0f - g.z);
      sum += weight * data[offset + ((i0[2] + cz) * size + i0[1] + cy) * size + i0[0] + cx];
    }
    omega = sum.x;
    axis = glm::vec3(sum.y, sum.z, sum.w);
  }
  const float len = glm::length(axis);
  const float cos_beta = len > 0.0f ? glm::dot(n, axis) / len : -glm::dot(n, w);
  // Step 3.
  a = table_lookup(data, table, omega, cos_beta);
  // Step 4 (radial fit inside the hull).
  if (!grid && r < r0) a = A0 + (a - A0) * std::pow(r / r0, exponent);
  // Step 5.
  return std::clamp(a * std::min((r_far - r) * fade_scale, 1.0f), 0.0f, 1.0f);
}

}  // namespace

Result<AOFieldGpuBuffer> pack_ao_fields_gpu(std::span<const AOFieldGpuCaster> casters) {
  std::vector<std::size_t> used;
  for (std::size_t i = 0; i < casters.size(); ++i)
    if (casters[i].field != nullptr && casters[i].field->valid()) used.push_back(i);
  // Sizes first: records, then each field, then the table.
  std::size_t total = 1 + kRecord * used.size();
  std::vector<std::size_t> offsets;
  for (std::size_t i : used) {
    const AOFieldData& f = *casters[i].field;
    offsets.push_back(total);
    total += f.representation == AOFieldRepresentation::Grid ? f.nodes.size() : 2 * f.texels.size();
  }
  const std::span<const float> table = cap_occlusion_table_values();
  const std::size_t table_offset = total;
  total += (table.size() + 3) / 4;
  if (total > kMaxVec4s)
    return make_error(ErrorCode::OutOfBudget, "ao field GPU buffer: " + std::to_string(total) +
                                                  " vec4s exceed the layout's 2^24; lower the casters' resolution "
                                                  "or grid_size");
  AOFieldGpuBuffer out;
  out.data.assign(total, glm::vec4(0.0f));
  out.casters = static_cast<std::uint32_t>(used.size());
  out.data[0] = glm::vec4(as_float(used.size()), as_float(table_offset), as_float(kCapTableIntervals + 1), 0.0f);
  for (std::size_t k = 0; k < used.size(); ++k) {
    const AOFieldGpuCaster& c = casters[used[k]];
    const AOFieldData& f = *c.field;
    const glm::mat4& m = c.world;
    bool finite = true;
    for (int col = 0; col < 4; ++col)
      for (int row = 0; row < 4; ++row) finite = finite && std::isfinite(m[col][row]);
    const float det = glm::determinant(glm::mat3(m));
    if (!finite || !(det != 0.0f) || !std::isfinite(det))
      return make_error(ErrorCode::InvalidArgument, "ao field GPU buffer: caster " + std::to_string(used[k]) +
                                                        " has a singular or non-finite world matrix; give it a "
                                                        "non-zero uniform scale");
    const glm::mat4 inv = glm::inverse(m);
    glm::vec4* rec = &out.data[1 + kRecord * k];
    for (int row = 0; row < 3; ++row) rec[row] = glm::vec4(inv[0][row], inv[1][row], inv[2][row], inv[3][row]);
    rec[3] = glm::vec4(f.centre, f.r_far);
    const bool grid = f.representation == AOFieldRepresentation::Grid;
    rec[4] = glm::vec4(1.0f / ((1.0f - f.fade_start) * f.r_far), f.inside_occlusion, f.inside_exponent,
                       grid ? 1.0f : 0.0f);
    rec[5] = glm::vec4(as_float(grid ? f.grid_size : f.resolution), as_float(offsets[k]), 0.0f, 0.0f);
    const float scale = std::cbrt(std::abs(det));
    rec[6] = glm::vec4(glm::vec3(m * glm::vec4(f.centre, 1.0f)), f.r_far * scale);
    glm::vec4* field = &out.data[offsets[k]];
    if (grid) {
      for (std::size_t j = 0; j < f.nodes.size(); ++j)
        field[j] = glm::vec4(f.nodes[j].omega, f.nodes[j].weighted_direction);
    } else {
      for (std::size_t j = 0; j < f.texels.size(); ++j) {
        const AOFieldTexel& t = f.texels[j];
        field[2 * j] = glm::vec4(t.a, t.b, t.c, t.r0);
        field[2 * j + 1] = glm::vec4(t.c0, 0.0f);
      }
    }
  }
  for (std::size_t q = 0; q < table.size(); ++q) out.data[table_offset + q / 4][static_cast<int>(q % 4)] = table[q];
  return out;
}

float evaluate_packed(const AOFieldGpuBuffer& buffer, glm::vec3 x, glm::vec3 n) {
  const std::vector<glm::vec4>& data = buffer.data;
  if (data.empty()) return 0.0f;
  const std::size_t count = as_index(data[0].x), table = as_index(data[0].y);
  constexpr std::size_t kTableVec4s = ((kCapTableIntervals + 1) * (kCapTableIntervals + 1) + 3) / 4;
  if (1 + kRecord * count > data.size() || table + kTableVec4s > data.size()) return 0.0f;
  float open = 1.0f;
  for (std::size_t i = 0; i < count; ++i) {
    const std::size_t rec = 1 + kRecord * i;
    const glm::vec4 reach = data[rec + 6];
    if (!(glm::distance(x, glm::vec3(reach)) < reach.w)) continue;
    const glm::vec4 h(x, 1.0f);
    const glm::vec3 xl(glm::dot(data[rec], h), glm::dot(data[rec + 1], h), glm::dot(data[rec + 2], h));
    const glm::vec3 nl(glm::dot(glm::vec3(data[rec]), n), glm::dot(glm::vec3(data[rec + 1]), n),
                       glm::dot(glm::vec3(data[rec + 2]), n));
    const float len = glm::length(nl);
    if (!(len > 0.0f) || !std::isfinite(len)) continue;
    open *= 1.0f - caster_occlusion(data, table, rec, xl, nl / len);
  }
  return std::clamp(1.0f - open, 0.0f, 1.0f);
}

}  // namespace penumbra
