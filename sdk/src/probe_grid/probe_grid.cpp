// Probe grid component, layout validation and CPU evaluation (see probe_grid.h).
// Evaluation is the irradiance-volume lookup of Greger et al. 1998 with the trilinear basis that
// Kontkanen & Laine 2006 assume for their supersampling: E(x, n) = sum_i B_i(x) E_i(n).
#include "penumbra/probe_grid/probe_grid.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>

#include <glm/common.hpp>
#include <glm/geometric.hpp>
#include <glm/gtc/matrix_transform.hpp>
#include <glm/matrix.hpp>

namespace penumbra {

const char* to_string(ProbeShOrder order) { return order == ProbeShOrder::L1 ? "L1" : "L2"; }
const char* to_string(ProbeSampling sampling) {
  switch (sampling) {
    case ProbeSampling::Point: return "point";
    case ProbeSampling::Supersampled: return "supersampled";
    case ProbeSampling::Fitted: return "fitted";
  }
  return "unknown";
}

IrradianceProbeGrid IrradianceProbeGrid::preset(Preset preset) {
  IrradianceProbeGrid g;
  switch (preset) {
    case Preset::Draft:
      g.samples_per_node = 8;
      g.rays_per_sample = 16;
      g.truncation = 0.2f;
      g.cells = 3;
      break;
    case Preset::Medium:
      g.samples_per_node = 32;
      g.rays_per_sample = 16;
      g.truncation = 0.05f;
      g.cells = 6;
      g.noise = 0.02f;  // the Cornell box: 5.4x the rays, its indirect view's RMSE 0.13 -> 0.10; the courtyard 1.08x
      g.sampling = ProbeSampling::Fitted;  // the probe-grid bench: lower RMSE and leak at ~1.1x the time
      break;
    case Preset::High:
      g.samples_per_node = 64;
      g.rays_per_sample = 32;
      g.truncation = 0.01f;
      g.cells = 12;
      g.noise = 0.01f;
      g.sampling = ProbeSampling::Fitted;
      break;
  }
  return g;
}

std::uint32_t probe_bounces(const IrradianceProbeGrid& grid, float max_albedo) {
  if (!(grid.truncation > 0.0f)) return grid.bounces;
  if (!(max_albedo > 0.0f)) return 1;  // black scene: nothing reflects, one bounce shows it
  if (!(max_albedo < 1.0f)) return kMaxDerivedBounces;
  const double k = std::ceil(std::log(double(std::min(grid.truncation, 1.0f))) / std::log(double(max_albedo)) - 1e-9);
  return static_cast<std::uint32_t>(std::clamp(k, 1.0, double(kMaxDerivedBounces)));
}

glm::vec3 probe_lit_irradiance(const ProbeLit& lit, glm::vec3 n) {
  return sh_evaluate_non_negative(lit.irradiance, n, lit.order == ProbeShOrder::L1 ? 2 : 3);
}

glm::vec3 ProbeGridLayout::node_position(glm::uvec3 ijk) const {
  const glm::vec3 u = glm::vec3(ijk) / glm::vec3(resolution - 1u);
  return glm::vec3(grid_to_world * glm::vec4(u, 1.0f));
}

namespace {

bool finite(const glm::mat4& m) {
  for (int c = 0; c < 4; ++c)
    for (int r = 0; r < 4; ++r)
      if (!std::isfinite(m[c][r])) return false;
  return true;
}

Error invalid(std::string_view context, const std::string& what) {
  return make_error(ErrorCode::InvalidArgument, std::string(context) + ": " + what);
}

std::string vec_text(glm::vec3 v) {
  char text[96];
  std::snprintf(text, sizeof text, "(%g, %g, %g)", static_cast<double>(v.x), static_cast<double>(v.y),
                static_cast<double>(v.z));
  return text;
}

}  // namespace

Result<ProbeGridLayout> probe_grid_layout(const IrradianceProbeGrid& grid, const glm::mat4& world_matrix,
                                          std::string_view context) {
  // Each setting's range and finiteness: the field list (probe_grid_fields.cpp).
  PENUMBRA_TRY(check_fields(irradiance_probe_grid_info(), &grid, context));

  // The box: explicit world-space AABB, or the unit cube through the world matrix.
  glm::mat4 grid_to_world;
  if (!grid.box.empty() || grid.box.min != Aabb{}.min) {
    const glm::vec3 size = grid.box.extent();
    if (!std::isfinite(size.x) || !std::isfinite(size.y) || !std::isfinite(size.z) ||
        !std::isfinite(grid.box.min.x) || !std::isfinite(grid.box.min.y) || !std::isfinite(grid.box.min.z))
      return invalid(context, "the box " + vec_text(grid.box.min) + " - " + vec_text(grid.box.max) +
                                  " is not finite; give finite corners");
    if (!(size.x > 0.0f && size.y > 0.0f && size.z > 0.0f))
      return invalid(context, "the box " + vec_text(grid.box.min) + " - " + vec_text(grid.box.max) +
                                  " is degenerate (size " + vec_text(size) +
                                  "); give it a positive size on every axis");
    grid_to_world = glm::scale(glm::translate(glm::mat4(1.0f), grid.box.min), size);
  } else {
    if (!finite(world_matrix))
      return invalid(context, "the entity's world transform has NaN or infinite entries; fix its Transform");
    grid_to_world = world_matrix * glm::translate(glm::mat4(1.0f), glm::vec3(-0.5f));
  }
  const glm::mat3 axes(grid_to_world);
  const glm::vec3 size(glm::length(axes[0]), glm::length(axes[1]), glm::length(axes[2]));
  const float volume = std::abs(glm::determinant(axes));
  if (!(volume > 0.0f) || !std::isfinite(volume) || !(std::min({size.x, size.y, size.z}) > 0.0f) ||
      !(volume > 1e-6f * size.x * size.y * size.z))
    return invalid(context, "the grid's box is degenerate (its transform has a zero scale or collapses an "
                            "axis; size " + vec_text(size) + "); give it a positive scale on every axis");

  // Resolution: explicit, or from the spacing.
  glm::uvec3 res = grid.resolution;
  if (res == glm::uvec3(0u)) {
    float spacing = grid.spacing;
    if (spacing == 0.0f) {  // follows the box: `cells` across its smallest side (range-checked by the
                            // field list above), bounded along its longest
      spacing = std::max(std::min({size.x, size.y, size.z}) / float(grid.cells),
                         std::max({size.x, size.y, size.z}) / float(kMaxDerivedCells));
    }
    if (!(spacing > 0.0f) || !std::isfinite(spacing))
      return invalid(context, "spacing " + std::to_string(grid.spacing) + " must be a positive number of metres "
                              "(or 0 to follow the box's size)");
    const glm::vec3 cells = glm::ceil(size / spacing - 1e-4f);
    if (!(std::max({cells.x, cells.y, cells.z}) < 1e6f))
      return invalid(context, "spacing " + std::to_string(spacing) + " m gives over a million nodes per axis "
                              "over a box of size " + vec_text(size) + "; use a larger spacing");
    res = glm::uvec3(glm::max(cells, glm::vec3(1.0f))) + 1u;
  } else if (res.x < 2 || res.y < 2 || res.z < 2) {
    return invalid(context, "resolution " + std::to_string(res.x) + "x" + std::to_string(res.y) + "x" +
                                std::to_string(res.z) + " has fewer than 2 nodes on an axis (a grid needs two "
                                "nodes per axis to interpolate); use at least 2x2x2, or resolution 0 with a spacing");
  }
  const std::uint64_t nodes = std::uint64_t{res.x} * res.y * res.z;
  if (nodes > kMaxProbeNodes)
    return invalid(context, std::to_string(res.x) + "x" + std::to_string(res.y) + "x" + std::to_string(res.z) +
                                " = " + std::to_string(nodes) + " nodes exceeds the limit of " +
                                std::to_string(kMaxProbeNodes) + "; use a larger spacing or a smaller box");

  ProbeGridLayout layout;
  layout.resolution = res;
  layout.grid_to_world = grid_to_world;
  layout.world_to_grid = glm::inverse(grid_to_world);
  layout.spacing = size / glm::vec3(res - 1u);
  return layout;
}

SH9rgb ProbeGridData::node(std::size_t n) const {
  SH9rgb sh;
  const int count = sh_coefficients(sh_order);
  for (int c = 0; c < count; ++c) sh[c] = coefficients[n * static_cast<std::size_t>(count) + static_cast<std::size_t>(c)];
  return sh;
}

float ProbeGridData::valid_fraction() const {
  if (validity.empty()) return 0.0f;
  const auto valid = std::count_if(validity.begin(), validity.end(), [](float v) { return v > 0.0f; });
  return static_cast<float>(valid) / static_cast<float>(validity.size());
}

std::uint64_t ProbeGridData::bytes() const {
  return sizeof(*this) + coefficients.capacity() * sizeof(glm::vec3) + validity.capacity() * sizeof(float) +
         filled.capacity() + reach.capacity();
}

std::uint64_t ProbeGridData::bytes_per_node() const {
  return static_cast<std::uint64_t>(sh_coefficients(sh_order)) * sizeof(glm::vec3) + (reach.empty() ? 0 : 6);
}

bool probe_node_sees(const std::uint8_t* reach, glm::vec3 offset) {
  for (int a = 0; a < 3; ++a) {
    const float r = float(reach[2 * a + (offset[a] < 0.0f ? 1 : 0)]) * (1.0f / 255.0f);
    if (!(std::abs(offset[a]) <= r + kProbeReachSlack)) return false;
  }
  return true;
}

bool probe_node_inside_surface(float validity, float height) {
  return validity < 1.0f && height < -kProbePlaneSlack;
}

glm::vec3 probe_lookup_fraction(const ProbeGridData& data, glm::uvec3 base, glm::vec3 f, glm::vec3 normal_cells,
                                ProbeReceiver receiver) {
  if (data.reach.empty()) return f;
  const float len = glm::length(normal_cells);
  const bool surface = len > 0.0f;  // false also for a NaN normal
  const bool solid_rule = surface && receiver == ProbeReceiver::Static;
  const float bias = solid_rule ? kProbeStaticNormalBias : kProbeNormalBias;
  const glm::vec3 test = surface ? f + normal_cells * (bias / len) : f;
  // The visible corners' weighted mean: by the reach alone (seen), and without the nodes inside
  // solids and, on static geometry, in the surface's own solid (front).
  float seen_sum = 0.0f, front_sum = 0.0f;
  glm::vec3 seen_mean(0.0f), front_mean(0.0f);
  for (std::uint32_t corner = 0; corner < 8; ++corner) {
    const glm::uvec3 o(corner & 1u, (corner >> 1) & 1u, (corner >> 2) & 1u);
    const std::size_t node = data.layout.node_index(base + o);
    if (!probe_node_sees(&data.reach[6 * node], test - glm::vec3(o))) continue;
    const float w = (o.x ? f.x : 1.0f - f.x) * (o.y ? f.y : 1.0f - f.y) * (o.z ? f.z : 1.0f - f.z);
    seen_sum += w;
    seen_mean += w * glm::vec3(o);
    const float validity = node < data.validity.size() ? data.validity[node] : 0.0f;  // as the GPU texels
    if (validity < kProbeSolidValidity) continue;
    if (solid_rule && probe_node_inside_surface(validity, glm::dot(normal_cells, glm::vec3(o) - f) / len)) continue;
    front_sum += w;
    front_mean += w * glm::vec3(o);
  }
  if (front_sum > 1e-6f) return front_mean / front_sum;
  return seen_sum > 1e-6f ? seen_mean / seen_sum : f;
}

SH9rgb interpolate(const ProbeGridData& data, glm::vec3 x, glm::vec3 n, ProbeReceiver receiver) {
  const ProbeGridLayout& g = data.layout;
  // Grid coordinates of x in node units, clamped into the box.
  const glm::vec3 cells(g.resolution - 1u);
  const glm::vec3 u = glm::clamp(glm::vec3(g.world_to_grid * glm::vec4(x, 1.0f)), 0.0f, 1.0f) * cells;
  SH9rgb out;
  if (!std::isfinite(u.x) || !std::isfinite(u.y) || !std::isfinite(u.z)) return out;
  const glm::uvec3 base = glm::min(glm::uvec3(u), g.resolution - 2u);
  const glm::vec3 n_cells = glm::mat3(g.world_to_grid) * n * cells;
  const glm::vec3 f = probe_lookup_fraction(data, base, u - glm::vec3(base), n_cells, receiver);
  const int count = sh_coefficients(data.sh_order);
  // Trilinear weights B_i(x) of the eight surrounding nodes.
  for (std::uint32_t corner = 0; corner < 8; ++corner) {
    const glm::uvec3 o(corner & 1u, (corner >> 1) & 1u, (corner >> 2) & 1u);
    const float w = (o.x ? f.x : 1.0f - f.x) * (o.y ? f.y : 1.0f - f.y) * (o.z ? f.z : 1.0f - f.z);
    const glm::vec3* node = &data.coefficients[g.node_index(base + o) * static_cast<std::size_t>(count)];
    for (int c = 0; c < count; ++c) out[c] += w * node[c];
  }
  return out;
}

glm::vec3 evaluate(const ProbeGridData& data, glm::vec3 x, glm::vec3 n, ProbeReceiver receiver) {
  return sh_evaluate_non_negative(interpolate(data, x, n, receiver), n, data.sh_order == ProbeShOrder::L1 ? 2 : 3);
}

}  // namespace penumbra
