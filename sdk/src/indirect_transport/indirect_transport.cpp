// Indirect-transport settings, patches, the Haar transform and the CPU update (see
// indirect_transport.h).
#include "penumbra/indirect_transport/indirect_transport.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>

#include <glm/common.hpp>
#include <glm/geometric.hpp>
#include <glm/vec2.hpp>

namespace penumbra {

IndirectTransport IndirectTransport::preset(Preset preset) {
  IndirectTransport t;
  switch (preset) {
    case Preset::Draft: t.finest_level = 2; t.refinement_threshold = 0.02f; break;
    case Preset::Medium: t.finest_level = 3; t.refinement_threshold = 0.002f; break;
    case Preset::High: t.finest_level = 4; t.refinement_threshold = 0.001f; break;
  }
  return t;
}

float TransportPatch::area() const { return glm::length(glm::cross(edge_u, edge_v)); }
float TransportPatch::leaf_area() const { return area() / static_cast<float>(leaves()); }
glm::vec3 TransportPatch::leaf_centre(std::uint32_t i, std::uint32_t j) const {
  const float inv = 1.0f / static_cast<float>(side());
  return origin + (static_cast<float>(i) + 0.5f) * inv * edge_u + (static_cast<float>(j) + 0.5f) * inv * edge_v;
}

std::uint64_t SparseTransport::bytes() const {
  return sizeof(*this) + begin.capacity() * sizeof(std::uint64_t) + row.capacity() * sizeof(std::uint32_t) +
         value.capacity() * sizeof(glm::vec3);
}

double SparseTransport::frobenius() const {
  double sum = 0.0;
  for (const glm::vec3& v : value) sum += double(v.x) * v.x + double(v.y) * v.y + double(v.z) * v.z;
  return std::sqrt(sum);
}

std::uint32_t TransportData::leaf_count() const {
  return patches.empty() ? 0u : patches.back().first + patches.back().leaves();
}

std::uint64_t TransportData::bytes() const {
  std::uint64_t n = sizeof(*this) + global.bytes() +
                    (fixed_direct.capacity() + fixed_indirect.capacity() + fixed_probes.capacity()) * sizeof(glm::vec3);
  for (const TransportPatch& p : patches) n += sizeof(p) + p.key.capacity() + p.coverage.capacity() * sizeof(float);
  return n + probes.bytes();
}

float patch_plane_tolerance(const TransportPatch& p) {
  const glm::vec3 o = glm::abs(p.origin);
  return 0.05f * std::sqrt(p.area()) + 1e-5f * std::max(o.x, std::max(o.y, o.z));
}

int transport_patch_at(const TransportData& data, glm::vec3 x, glm::vec3 n) {
  int best = -1;
  float best_d = 0.0f;
  for (std::size_t i = 0; i < data.patches.size(); ++i) {
    const TransportPatch& p = data.patches[i];
    const glm::vec3 r = x - p.origin;
    const float d = std::abs(glm::dot(r, p.normal));
    if (d > patch_plane_tolerance(p) || glm::dot(n, p.normal) < 0.5f || (best >= 0 && d >= best_d)) continue;
    const float s = glm::dot(r, p.edge_u) / glm::dot(p.edge_u, p.edge_u);
    const float t = glm::dot(r, p.edge_v) / glm::dot(p.edge_v, p.edge_v);
    const float m = kTransportMargin;
    if (!(s >= -m && s <= 1.0f + m && t >= -m && t <= 1.0f + m)) continue;
    best = static_cast<int>(i);
    best_d = d;
    if (d <= kTransportPlaneSnap * patch_plane_tolerance(p)) break;  // on its plane: none is nearer
  }
  return best;
}

namespace {

// Bilinear interpolation of patch p's leaf texels at x (centres at (k + 0.5) / 2^level, clamped).
glm::vec3 lightmap_at(const TransportPatch& p, std::span<const glm::vec3> irradiance, glm::vec3 x) {
  const glm::vec3 r = x - p.origin;
  const float s = glm::dot(r, p.edge_u) / glm::dot(p.edge_u, p.edge_u);
  const float t = glm::dot(r, p.edge_v) / glm::dot(p.edge_v, p.edge_v);
  const float side = static_cast<float>(p.side());
  const glm::vec2 f = glm::clamp(glm::vec2(s, t) * side - 0.5f, glm::vec2(0.0f), glm::vec2(side - 1.0f));
  const glm::vec2 f0 = glm::floor(f), w = f - f0;
  const auto s0 = static_cast<std::uint32_t>(f0.x), t0 = static_cast<std::uint32_t>(f0.y), last = p.side() - 1;
  const std::uint32_t s1 = std::min(s0 + 1, last), t1 = std::min(t0 + 1, last), row = p.side();
  const glm::vec3 a = irradiance[p.first + s0 + t0 * row], b = irradiance[p.first + s1 + t0 * row];
  const glm::vec3 c = irradiance[p.first + s0 + t1 * row], d = irradiance[p.first + s1 + t1 * row];
  return glm::mix(glm::mix(a, b, w.x), glm::mix(c, d, w.x), w.y);
}

}  // namespace

glm::vec3 sample_indirect_irradiance(const TransportData& data, std::span<const glm::vec3> irradiance, glm::vec3 x,
                                     glm::vec3 n) {
  const int found = transport_patch_at(data, x, n);
  return found >= 0 ? lightmap_at(data.patches[static_cast<std::size_t>(found)], irradiance, x) : glm::vec3(0.0f);
}

std::uint64_t TransportProbes::bytes() const {
  return open.capacity() + reach.capacity() * sizeof(reach[0]) + begin.capacity() * sizeof(std::uint32_t) +
         entries.capacity() * sizeof(BounceProbeEntry);
}

bool bounce_probe_in_range(std::uint8_t open, const std::array<float, 6>& reach,
                           std::span<const BounceProbeEntry> entries, std::uint32_t cells) {
  bool ok = open <= 1;
  for (const float f : reach) ok = ok && f >= 0.0f && f <= 1.0f;
  for (const BounceProbeEntry& e : entries) {
    ok = ok && e.cell < cells;
    for (const float w : e.weight) ok = ok && w >= 0.0f && w <= 4.0f * std::numbers::pi_v<float>;
  }
  return ok;
}

std::vector<std::uint32_t> bounce_probe_cell_offsets(std::span<const TransportPatch> patches) {
  std::vector<std::uint32_t> first(patches.size() + 1, 0u);
  for (std::size_t i = 0; i < patches.size(); ++i)
    first[i + 1] = first[i] + (1u << (2 * std::min(patches[i].level, kBounceProbeCellLevel)));
  return first;
}

std::uint32_t TransportData::cell_count() const { return bounce_probe_cell_offsets(patches).back(); }

void bounce_probe_irradiance(const TransportData& data, std::span<const glm::vec3> direct,
                             std::span<const glm::vec3> indirect, std::span<glm::vec3> cubes,
                             TaskScheduler* scheduler) {
  // The cells' mean radiance, in bounce_probe_cell_offsets' order: albedo / pi x the
  // coverage-weighted mean irradiance of their leaves.
  constexpr std::size_t kMaxCells = std::size_t{1} << (2 * kBounceProbeCellLevel);
  std::vector<glm::vec3> radiance;
  radiance.reserve(data.cell_count());
  for (const TransportPatch& p : data.patches) {
    const std::uint32_t cell_level = std::min(p.level, kBounceProbeCellLevel), cells = 1u << cell_level;
    const std::uint32_t shift = p.level - cell_level;
    std::array<glm::vec3, kMaxCells> sum{};
    std::array<float, kMaxCells> weight{};
    for (std::uint32_t j = 0; j < p.side(); ++j)
      for (std::uint32_t i = 0; i < p.side(); ++i) {
        const std::uint32_t leaf = i + j * p.side(), cell = (i >> shift) + (j >> shift) * cells;
        sum[cell] += p.coverage[leaf] * (direct[p.first + leaf] + indirect[p.first + leaf]);
        weight[cell] += p.coverage[leaf];
      }
    for (std::size_t c = 0; c < std::size_t{cells} * cells; ++c)
      radiance.push_back(weight[c] > 0.0f ? p.albedo / std::numbers::pi_v<float> * sum[c] / weight[c]
                                          : glm::vec3(0.0f));
  }
  // Each probe: sum over its entries of w_a L_cell.
  const TransportProbes& probes = data.probes;
  JobContext jobs(scheduler);
  (void)jobs.parallel_for(probes.nodes(), 64, [&](std::size_t begin, std::size_t end) {
    for (std::size_t node = begin; node < end; ++node) {
      std::array<glm::vec3, 6> e{};
      for (std::uint32_t k = probes.begin[node]; k < probes.begin[node + 1]; ++k) {
        const BounceProbeEntry& t = probes.entries[k];
        const glm::vec3 l = radiance[t.cell];
        for (std::size_t a = 0; a < 6; ++a) e[a] += t.weight[a] * l;
      }
      std::copy(e.begin(), e.end(), cubes.begin() + static_cast<std::ptrdiff_t>(6 * node));
    }
  });
}

glm::vec3 sample_bounce_probes(const TransportProbes& probes, std::span<const glm::vec3> cubes, glm::vec3 x,
                               glm::vec3 n) {
  if (probes.nodes() == 0 || !(probes.spacing > 0.0f)) return glm::vec3(0.0f);
  const glm::vec3 last = glm::vec3(probes.count) - 1.0f;
  const glm::vec3 g = glm::clamp((x + kBounceProbeOffset * probes.spacing * n - probes.origin) / probes.spacing,
                                 glm::vec3(0.0f), last);
  if (!(g.x >= 0.0f && g.y >= 0.0f && g.z >= 0.0f)) return glm::vec3(0.0f);  // a non-finite point
  const glm::uvec3 c0 = glm::min(glm::uvec3(g), glm::uvec3(last));
  const glm::vec3 f = g - glm::vec3(c0);
  const glm::vec3 sq = n * n;
  const int side[3] = {n.x < 0.0f ? 1 : 0, n.y < 0.0f ? 1 : 0, n.z < 0.0f ? 1 : 0};
  for (const bool guard : {true, false}) {
    glm::vec3 sum(0.0f);
    float total = 0.0f;
    for (int corner = 0; corner < 8; ++corner) {
      const glm::uvec3 o((corner & 1) != 0, (corner & 2) != 0, (corner & 4) != 0);
      const glm::uvec3 c = glm::min(c0 + o, glm::uvec3(last));
      const std::size_t node = c.x + probes.count.x * (c.y + std::size_t{probes.count.y} * c.z);
      if (probes.open[node] == 0) continue;
      const glm::vec3 w3 = glm::mix(1.0f - f, f, glm::vec3(o));
      const float w = w3.x * w3.y * w3.z;
      if (!(w > 0.0f)) continue;
      if (guard) {
        const glm::vec3 d = g - glm::vec3(c);  // from the node to the point, in spacings
        bool reached = true;
        for (int a = 0; a < 3; ++a) {
          const auto way = static_cast<std::size_t>(2 * a + (d[a] < 0.0f ? 1 : 0));
          reached = reached && std::abs(d[a]) <= probes.reach[node][way];
        }
        if (!reached) continue;
      }
      const glm::vec3* cube = cubes.data() + 6 * node;
      sum += w * (sq.x * cube[side[0]] + sq.y * cube[2 + side[1]] + sq.z * cube[4 + side[2]]);
      total += w;
    }
    if (total > 0.0f) return sum / total;
  }
  return glm::vec3(0.0f);
}

glm::vec3 sample_transport_irradiance(const TransportData& data, const IndirectLightmap& map, glm::vec3 x,
                                      glm::vec3 n) {
  const int found = transport_patch_at(data, x, n);
  if (found >= 0) return lightmap_at(data.patches[static_cast<std::size_t>(found)], map.irradiance, x);
  return sample_bounce_probes(data.probes, map.probes, x, n);
}

namespace {

std::uint32_t node_offset(std::uint32_t level) { return ((1u << (2 * level)) - 1u) / 3u; }

// Two grids of up to 4^level values, reused by every transform on this thread.
std::vector<glm::vec3>& scratch(int which, std::size_t size) {
  thread_local std::vector<glm::vec3> buffers[2];
  std::vector<glm::vec3>& b = buffers[which];
  if (b.size() < size) b.resize(size);
  return b;
}

}  // namespace

void haar_analyse(std::span<glm::vec3> values, std::uint32_t level, float leaf_area) {
  const std::size_t n_leaves = std::size_t{1} << (2 * level);
  std::vector<glm::vec3>& fine = scratch(0, n_leaves);
  std::vector<glm::vec3>& coarse = scratch(1, n_leaves);
  std::copy(values.begin(), values.begin() + static_cast<std::ptrdiff_t>(n_leaves), fine.begin());
  // Pyramid from the leaves up: each node's scaling coefficient and three wavelets from its four
  // children (a = (2i, 2j), b = (2i+1, 2j), c = (2i, 2j+1), d = (2i+1, 2j+1)), orthonormal.
  for (std::uint32_t l = level; l-- > 0;) {
    const std::uint32_t n = 1u << l, w = 2 * n;
    for (std::uint32_t j = 0; j < n; ++j)
      for (std::uint32_t i = 0; i < n; ++i) {
        const glm::vec3 a = fine[2 * i + 2 * j * w], b = fine[2 * i + 1 + 2 * j * w];
        const glm::vec3 c = fine[2 * i + (2 * j + 1) * w], d = fine[2 * i + 1 + (2 * j + 1) * w];
        coarse[i + j * n] = 0.5f * (a + b + c + d);
        const std::size_t k = 1 + 3 * (node_offset(l) + i + j * n);
        values[k] = 0.5f * (a + b - c - d);
        values[k + 1] = 0.5f * (a - b + c - d);
        values[k + 2] = 0.5f * (a - b - c + d);
      }
    std::swap(fine, coarse);
  }
  values[0] = fine[0];
  const float scale = std::sqrt(leaf_area);
  for (std::size_t k = 0; k < n_leaves; ++k) values[k] *= scale;
}

void haar_synthesise(std::span<glm::vec3> values, std::uint32_t level, float leaf_area) {
  const std::size_t n_leaves = std::size_t{1} << (2 * level);
  std::vector<glm::vec3>& coarse = scratch(0, n_leaves);
  std::vector<glm::vec3>& fine = scratch(1, n_leaves);
  const float scale = leaf_area > 0.0f ? 1.0f / std::sqrt(leaf_area) : 0.0f;
  coarse[0] = values[0] * scale;
  // The pyramid's inverse, from the root down (the 4x4 transform is its own inverse).
  for (std::uint32_t l = 0; l < level; ++l) {
    const std::uint32_t n = 1u << l, w = 2 * n;
    for (std::uint32_t j = 0; j < n; ++j)
      for (std::uint32_t i = 0; i < n; ++i) {
        const std::size_t k = 1 + 3 * (node_offset(l) + i + j * n);
        const glm::vec3 s = coarse[i + j * n], w0 = values[k] * scale, w1 = values[k + 1] * scale,
                        w2 = values[k + 2] * scale;
        fine[2 * i + 2 * j * w] = 0.5f * (s + w0 + w1 + w2);
        fine[2 * i + 1 + 2 * j * w] = 0.5f * (s + w0 - w1 - w2);
        fine[2 * i + (2 * j + 1) * w] = 0.5f * (s - w0 + w1 - w2);
        fine[2 * i + 1 + (2 * j + 1) * w] = 0.5f * (s - w0 - w1 + w2);
      }
    std::swap(fine, coarse);
  }
  std::copy(coarse.begin(), coarse.begin() + static_cast<std::ptrdiff_t>(n_leaves), values.begin());
}

TransportUpdate apply_transport(const TransportData& data, std::span<const glm::vec3> direct,
                                std::span<glm::vec3> indirect, float keep_threshold, TaskScheduler* scheduler) {
  TransportUpdate stats;
  JobContext jobs(scheduler);
  const std::uint32_t n = data.leaf_count();
  std::vector<glm::vec3> coefficients(direct.begin(), direct.begin() + n);
  // Haar analysis of each patch's direct irradiance.
  (void)jobs.parallel_for(data.patches.size(), 8, [&](std::size_t begin, std::size_t end) {
    for (std::size_t i = begin; i < end; ++i) {
      const TransportPatch& p = data.patches[i];
      haar_analyse(std::span<glm::vec3>(coefficients).subspan(p.first, p.leaves()), p.level, p.leaf_area());
    }
  });
  float largest = 0.0f;
  for (const glm::vec3& c : coefficients)
    largest = std::max(largest, std::max(std::abs(c.x), std::max(std::abs(c.y), std::abs(c.z))));
  // The sparse product with G over the significant coefficients (columns of G), in kSlices fixed
  // column ranges summed separately and then in order: the same bits at any thread count.
  constexpr std::size_t kSlices = 4;
  const float keep = keep_threshold * largest;
  const SparseTransport& g = data.global;
  std::vector<std::vector<glm::vec3>> partial(kSlices);
  std::vector<TransportUpdate> slice_stats(kSlices);
  (void)jobs.parallel_for(kSlices, 1, [&](std::size_t begin, std::size_t end) {
    for (std::size_t slice = begin; slice < end; ++slice) {
      std::vector<glm::vec3>& out = partial[slice];
      out.assign(n, glm::vec3(0.0f));
      const std::uint32_t first = static_cast<std::uint32_t>(std::uint64_t{n} * slice / kSlices);
      const std::uint32_t last = static_cast<std::uint32_t>(std::uint64_t{n} * (slice + 1) / kSlices);
      for (std::uint32_t j = first; j < last && largest > 0.0f; ++j) {
        const glm::vec3 c = coefficients[j];
        if (std::max(std::abs(c.x), std::max(std::abs(c.y), std::abs(c.z))) < keep) continue;
        ++slice_stats[slice].kept;
        const std::uint64_t stop = g.begin[j + 1];
        for (std::uint64_t k = g.begin[j]; k < stop; ++k) out[g.row[k]] += g.value[k] * c;
        slice_stats[slice].multiplies += stop - g.begin[j];
      }
    }
  });
  std::copy(partial[0].begin(), partial[0].end(), indirect.begin());
  for (std::size_t slice = 1; slice < kSlices; ++slice)
    for (std::uint32_t i = 0; i < n; ++i) indirect[i] += partial[slice][i];
  for (const TransportUpdate& t : slice_stats) {
    stats.kept += t.kept;
    stats.multiplies += t.multiplies;
  }
  // The inverse transform into leaf irradiance; holes of a chart stay dark.
  (void)jobs.parallel_for(data.patches.size(), 8, [&](std::size_t begin, std::size_t end) {
    for (std::size_t i = begin; i < end; ++i) {
      const TransportPatch& p = data.patches[i];
      std::span<glm::vec3> leaves = indirect.subspan(p.first, p.leaves());
      haar_synthesise(leaves, p.level, p.leaf_area());
      for (std::uint32_t k = 0; k < p.leaves(); ++k)
        if (!(p.coverage[k] > 0.0f)) leaves[k] = glm::vec3(0.0f);
    }
  });
  return stats;
}

}  // namespace penumbra
