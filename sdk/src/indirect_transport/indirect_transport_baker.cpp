// The indirect-transport bake (see indirect_transport_baker.h).
#include "penumbra/indirect_transport/indirect_transport_baker.h"

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstdio>
#include <map>
#include <numbers>
#include <numeric>
#include <tuple>
#include <unordered_map>
#include <utility>

#include <glm/common.hpp>
#include <glm/geometric.hpp>

#include "penumbra/core/log.h"
#include "penumbra/core/random.h"
#include "penumbra/core/sampling.h"
#include "penumbra/ecs/transform.h"
#include "penumbra/indirect_transport/indirect_transport_system.h"
#include "penumbra/scene/components.h"
#include "penumbra/scene/entity_key.h"

namespace penumbra {

namespace {

constexpr float kPi = std::numbers::pi_v<float>;
constexpr std::uint32_t kMaxLevel = 6;
constexpr std::uint64_t kMaxLeaves = 1ull << 30;

std::uint32_t node_offset(std::uint32_t level) { return ((1u << (2 * level)) - 1u) / 3u; }

struct Node {
  std::uint32_t level, i, j;
};
std::uint32_t node_id(Node n) { return node_offset(n.level) + n.i + (n.j << n.level); }
Node node_of(std::uint32_t id) {
  std::uint32_t l = 0;
  while (node_offset(l + 1) <= id) ++l;
  const std::uint32_t k = id - node_offset(l);
  return {l, k & ((1u << l) - 1u), k >> l};
}

// ---------------------------------------------------------------------------------------------
// Patches.

struct WorldTriangle {
  std::array<glm::vec3, 3> p;
  glm::vec3 normal;
  float area;
};

// Charts of one mesh: union-find over triangles sharing a welded edge and lying in one plane.
std::vector<std::vector<std::uint32_t>> charts_of(const std::vector<WorldTriangle>& tris,
                                                  const std::vector<std::array<std::uint32_t, 3>>& ids, float tol) {
  std::vector<std::uint32_t> parent(tris.size());
  std::iota(parent.begin(), parent.end(), 0u);
  const auto find = [&](std::uint32_t x) {
    while (parent[x] != x) x = parent[x] = parent[parent[x]];
    return x;
  };
  std::map<std::pair<std::uint32_t, std::uint32_t>, std::vector<std::uint32_t>> edges;
  for (std::uint32_t t = 0; t < tris.size(); ++t)
    for (int e = 0; e < 3; ++e) {
      std::uint32_t a = ids[t][static_cast<std::size_t>(e)], b = ids[t][static_cast<std::size_t>((e + 1) % 3)];
      if (a > b) std::swap(a, b);
      edges[{a, b}].push_back(t);
    }
  constexpr float kCosOneDegree = 0.99985f;
  for (const auto& [edge, list] : edges)
    for (std::size_t x = 0; x + 1 < list.size(); ++x)
      for (std::size_t y = x + 1; y < list.size(); ++y) {
        const WorldTriangle &a = tris[list[x]], &b = tris[list[y]];
        if (glm::dot(a.normal, b.normal) < kCosOneDegree) continue;
        bool on_plane = true;
        for (const glm::vec3& q : b.p) on_plane = on_plane && std::abs(glm::dot(a.normal, q - a.p[0])) <= tol;
        if (on_plane) parent[find(list[x])] = find(list[y]);
      }
  std::map<std::uint32_t, std::vector<std::uint32_t>> groups;
  for (std::uint32_t t = 0; t < tris.size(); ++t) groups[find(t)].push_back(t);
  std::vector<std::vector<std::uint32_t>> out;
  for (auto& [root, list] : groups) out.push_back(std::move(list));
  std::sort(out.begin(), out.end(), [](const auto& a, const auto& b) { return a.front() < b.front(); });
  return out;
}

bool inside(glm::vec2 p, glm::vec2 a, glm::vec2 b, glm::vec2 c) {
  const auto cross = [](glm::vec2 u, glm::vec2 v) { return u.x * v.y - u.y * v.x; };
  const float d1 = cross(b - a, p - a), d2 = cross(c - b, p - b), d3 = cross(a - c, p - c);
  const bool neg = d1 < 0.0f || d2 < 0.0f || d3 < 0.0f, pos = d1 > 0.0f || d2 > 0.0f || d3 > 0.0f;
  return !(neg && pos);
}

}  // namespace

Result<std::vector<TransportPatch>> build_transport_patches(World& world, const IndirectTransport& settings,
                                                            std::vector<std::string>& warnings) {
  std::vector<TransportPatch> patches;
  const std::vector<Entity> receivers = world.view<IndirectReceiver, Static, Mesh, WorldTransform>().sorted_entities();
  Aabb bounds;
  for (Entity e : receivers) {
    const Mesh& mesh = world.get<Mesh>(e);
    if (!mesh.data) continue;
    const glm::mat4& m = world.get<WorldTransform>(e).matrix;
    for (const glm::vec3& p : mesh.data->positions) bounds.extend(glm::vec3(m * glm::vec4(p, 1.0f)));
  }
  const float diagonal = bounds.empty() ? 1.0f : glm::length(bounds.extent());
  const std::uint32_t finest = std::min(settings.finest_level, kMaxLevel);
  std::uint64_t leaves = 0;
  for (Entity e : receivers) {
    const Mesh& mesh = world.get<Mesh>(e);
    if (!mesh.data || mesh.data->indices.empty()) continue;
    const std::string key = entity_key(world, e);
    const std::string what = "indirect receiver '" + (key.empty() ? std::to_string(e.index) : key) + "'";
    const float patch_size = world.get<IndirectReceiver>(e).patch_size > 0.0f
                                 ? world.get<IndirectReceiver>(e).patch_size
                                 : (diagonal > 0.0f && std::isfinite(diagonal) ? kPatchSizeFraction * diagonal : 1.0f);
    const float texel = patch_size / static_cast<float>(1u << finest);
    const float tol = 1e-4f * patch_size;
    // World-space triangles with vertices welded on a grid of tol / 4.
    const MeshData& d = *mesh.data;
    const glm::mat4& m = world.get<WorldTransform>(e).matrix;
    std::vector<WorldTriangle> tris;
    std::vector<std::array<std::uint32_t, 3>> ids;
    std::map<std::tuple<long long, long long, long long>, std::uint32_t> weld;
    const float q = tol / 4.0f;
    for (std::size_t t = 0; t + 2 < d.indices.size(); t += 3) {
      WorldTriangle w;
      std::array<std::uint32_t, 3> id;
      for (int k = 0; k < 3; ++k) {
        const glm::vec3 p = glm::vec3(m * glm::vec4(d.positions[d.indices[t + static_cast<std::size_t>(k)]], 1.0f));
        w.p[static_cast<std::size_t>(k)] = p;
        const auto cell = std::make_tuple(std::llround(p.x / q), std::llround(p.y / q), std::llround(p.z / q));
        id[static_cast<std::size_t>(k)] = weld.emplace(cell, static_cast<std::uint32_t>(weld.size())).first->second;
      }
      const glm::vec3 c = glm::cross(w.p[1] - w.p[0], w.p[2] - w.p[0]);
      w.area = 0.5f * glm::length(c);
      if (!(w.area > 0.0f) || !std::isfinite(w.area)) continue;
      w.normal = c / (2.0f * w.area);
      tris.push_back(w);
      ids.push_back(id);
    }
    const Material* material = world.try_get<Material>(e);
    glm::vec3 albedo(1.0f);
    if (material != nullptr) {
      albedo = glm::vec3(material->base_color);
      if (material->base_color_texture) albedo *= material->base_color_texture->average_linear;
    }
    albedo = glm::clamp(albedo, glm::vec3(0.0f), glm::vec3(1.0f));
    std::size_t unusable = 0, used_charts = 0;
    // A neighbour whose vertices lie within a quarter texel of a triangle's plane shares its chart,
    // so a quad modelled slightly bent (the Cornell box's red wall: 3.2 mm over 0.56 m) stays one
    // rectangle instead of two triangles whose slanted rectangles seam the wall along the diagonal.
    for (const std::vector<std::uint32_t>& chart : charts_of(tris, ids, std::max(tol, 0.25f * texel))) {
      // The chart's plane, and its axes: along the edge whose direction gives the smallest
      // bounding rectangle (exact for rectangles and axis-aligned polygons).
      glm::vec3 n(0.0f);
      float area = 0.0f;
      for (std::uint32_t t : chart) {
        n += tris[t].normal * tris[t].area;
        area += tris[t].area;
      }
      if (area < texel * texel || !(glm::length(n) > 0.0f)) {
        unusable += chart.size();
        continue;
      }
      n = glm::normalize(n);
      // The chart's plane through its front-most vertex: a chart bent within the flatness above
      // then lies behind its texels, never in front of them (a texel behind its surface is shadowed).
      glm::vec3 p0 = tris[chart.front()].p[0];
      float ahead = 0.0f;
      for (std::uint32_t t : chart)
        for (const glm::vec3& corner : tris[t].p) ahead = std::max(ahead, glm::dot(corner - p0, n));
      if (ahead > tol) p0 += ahead * n;
      glm::vec3 u_axis(0.0f);
      float best = std::numeric_limits<float>::max();
      constexpr std::size_t kCandidates = 64;  // edges tried, of the first triangles
      for (std::size_t c = 0; c < std::min(chart.size(), kCandidates / 3 + 1); ++c)
        for (int k = 0; k < 3; ++k) {
          const WorldTriangle& t = tris[chart[c]];
          glm::vec3 axis = t.p[static_cast<std::size_t>((k + 1) % 3)] - t.p[static_cast<std::size_t>(k)];
          axis -= glm::dot(axis, n) * n;
          if (!(glm::length(axis) > 0.0f)) continue;
          axis = glm::normalize(axis);
          const glm::vec3 other = glm::cross(n, axis);
          glm::vec2 a_lo(std::numeric_limits<float>::max()), a_hi(-std::numeric_limits<float>::max());
          for (std::uint32_t tt : chart)
            for (const glm::vec3& corner : tris[tt].p) {
              const glm::vec2 f(glm::dot(corner - p0, axis), glm::dot(corner - p0, other));
              a_lo = glm::min(a_lo, f);
              a_hi = glm::max(a_hi, f);
            }
          const float rect = (a_hi.x - a_lo.x) * (a_hi.y - a_lo.y);
          if (rect < best * (1.0f - 1e-4f)) {
            best = rect;
            u_axis = axis;
          }
        }
      const glm::vec3 v_axis = glm::cross(n, u_axis);
      glm::vec2 lo(std::numeric_limits<float>::max()), hi(-std::numeric_limits<float>::max());
      std::vector<std::array<glm::vec2, 3>> flat;
      for (std::uint32_t t : chart) {
        std::array<glm::vec2, 3> f;
        for (int k = 0; k < 3; ++k) {
          const glm::vec3 r = tris[t].p[static_cast<std::size_t>(k)] - p0;
          f[static_cast<std::size_t>(k)] = glm::vec2(glm::dot(r, u_axis), glm::dot(r, v_axis));
          lo = glm::min(lo, f[static_cast<std::size_t>(k)]);
          hi = glm::max(hi, f[static_cast<std::size_t>(k)]);
        }
        flat.push_back(f);
      }
      const glm::vec2 size = hi - lo;
      const auto tiles_u = static_cast<std::uint32_t>(std::max(1.0f, std::ceil(size.x / patch_size - 1e-4f)));
      const auto tiles_v = static_cast<std::uint32_t>(std::max(1.0f, std::ceil(size.y / patch_size - 1e-4f)));
      const glm::vec2 tile(size.x / float(tiles_u), size.y / float(tiles_v));
      std::uint32_t level = finest;
      while (level > 0 && std::max(tile.x, tile.y) / float(1u << (level - 1)) <= texel * 1.001f) --level;
      ++used_charts;
      for (std::uint32_t tv = 0; tv < tiles_v; ++tv)
        for (std::uint32_t tu = 0; tu < tiles_u; ++tu) {
          TransportPatch p;
          p.key = key;
          p.level = level;
          const glm::vec2 corner = lo + glm::vec2(float(tu) * tile.x, float(tv) * tile.y);
          p.origin = p0 + corner.x * u_axis + corner.y * v_axis;
          p.edge_u = tile.x * u_axis;
          p.edge_v = tile.y * v_axis;
          p.normal = n;
          p.albedo = albedo;
          // Coverage: 4 x 4 points per leaf inside any of the chart's triangles.
          const std::uint32_t side = p.side(), samples = 4 * side;
          std::vector<std::uint8_t> covered(std::size_t{samples} * samples, 0);
          const glm::vec2 step = tile / float(samples);
          for (const auto& f : flat) {
            const glm::vec2 flo = glm::min(f[0], glm::min(f[1], f[2])) - corner,
                            fhi = glm::max(f[0], glm::max(f[1], f[2])) - corner;
            const int i0 = std::max(0, int(std::floor(flo.x / step.x - 0.5f))),
                      i1 = std::min(int(samples) - 1, int(std::ceil(fhi.x / step.x)));
            const int j0 = std::max(0, int(std::floor(flo.y / step.y - 0.5f))),
                      j1 = std::min(int(samples) - 1, int(std::ceil(fhi.y / step.y)));
            for (int j = j0; j <= j1; ++j)
              for (int i = i0; i <= i1; ++i) {
                const glm::vec2 s = corner + glm::vec2((float(i) + 0.5f) * step.x, (float(j) + 0.5f) * step.y);
                if (inside(s, f[0], f[1], f[2])) covered[std::size_t(i) + std::size_t(j) * samples] = 1;
              }
          }
          p.coverage.assign(p.leaves(), 0.0f);
          float total = 0.0f;
          for (std::uint32_t j = 0; j < samples; ++j)
            for (std::uint32_t i = 0; i < samples; ++i)
              if (covered[i + std::size_t(j) * samples]) p.coverage[(i / 4) + (j / 4) * side] += 1.0f / 16.0f;
          for (float c : p.coverage) total += c;
          if (!(total > 0.0f)) continue;  // a tile of the rectangle outside the chart
          p.first = static_cast<std::uint32_t>(leaves);
          leaves += p.leaves();
          if (leaves > kMaxLeaves)
            return make_error(ErrorCode::InvalidInput, what + ": the receivers need more than 2^30 leaf texels; raise "
                                                              "patch_size or lower finest_level");
          patches.push_back(std::move(p));
        }
    }
    if (used_charts == 0) {
      warnings.push_back(what + ": none of its " + std::to_string(tris.size()) +
                         " triangles form a planar chart of at least one texel (" + std::to_string(texel) +
                         " m), so it neither receives nor passes on bounce light (the transport needs large planar "
                         "surfaces: remove its IndirectReceiver or raise patch_size)");
      continue;
    }
    if (unusable > 0)
      warnings.push_back(what + ": " + std::to_string(unusable) + " of its " + std::to_string(tris.size()) +
                         " triangles lie in charts smaller than one texel (curved or fragmented geometry) and neither "
                         "receive nor pass on bounce light");
  }
  return patches;
}

// ---------------------------------------------------------------------------------------------
// Refinement.

namespace {

// Per patch and node: whether any leaf below has coverage (nodes with none are never linked).
std::vector<std::uint8_t> node_coverage(const TransportPatch& p) {
  std::vector<std::uint8_t> out(node_offset(p.level + 1), 0);
  for (std::uint32_t j = 0; j < p.side(); ++j)
    for (std::uint32_t i = 0; i < p.side(); ++i)
      if (p.coverage[i + j * p.side()] > 0.0f)
        for (std::uint32_t l = 0; l <= p.level; ++l) {
          const std::uint32_t shift = p.level - l;
          out[node_id({l, i >> shift, j >> shift})] = 1;
        }
  return out;
}

// Node area and a point at parameter (a, b) in [0, 1]^2 of the node.
float node_area(const TransportPatch& p, Node n) { return p.area() / float(1u << (2 * n.level)); }
glm::vec3 node_point(const TransportPatch& p, Node n, float a, float b) {
  const float inv = 1.0f / float(1u << n.level);
  return p.origin + (float(n.i) + a) * inv * p.edge_u + (float(n.j) + b) * inv * p.edge_v;
}
bool point_covered(const TransportPatch& p, Node n, float a, float b) {
  const float inv = 1.0f / float(1u << n.level);
  const auto i = std::min(p.side() - 1, static_cast<std::uint32_t>((float(n.i) + a) * inv * float(p.side())));
  const auto j = std::min(p.side() - 1, static_cast<std::uint32_t>((float(n.j) + b) * inv * float(p.side())));
  return p.coverage[i + j * p.side()] > 0.0f;
}

// Does any corner of `s` lie strictly in front of the plane of `r` (and vice versa)?
bool faces(const TransportPatch& r, const TransportPatch& s) {
  const auto in_front = [](const TransportPatch& plane, const TransportPatch& q) {
    const float tol = 1e-5f * std::sqrt(plane.area());
    for (const glm::vec3 c : {q.origin, q.origin + q.edge_u, q.origin + q.edge_v, q.origin + q.edge_u + q.edge_v})
      if (glm::dot(plane.normal, c - plane.origin) > tol) return true;
    return false;
  };
  return in_front(r, s) && in_front(s, r);
}

std::array<glm::vec3, 4> node_corners(const TransportPatch& p, Node n) {
  return {node_point(p, n, 0, 0), node_point(p, n, 1, 0), node_point(p, n, 1, 1), node_point(p, n, 0, 1)};
}

// Where the corners lie against the plane of `plane` (in front: the side its normal points to).
enum class Side : std::uint8_t { Front, Behind, Both };
Side side_of(const TransportPatch& plane, const std::array<glm::vec3, 4>& corners) {
  const float tol = 1e-5f * std::sqrt(plane.area());
  bool front = false, behind = false;
  for (const glm::vec3& c : corners) {
    const float d = glm::dot(plane.normal, c - plane.origin);
    front = front || d > tol;
    behind = behind || d < -tol;
  }
  return front && behind ? Side::Both : front ? Side::Front : Side::Behind;
}

// The receiver's variation counts 2x the sender's: its four points (one per quadrant) see about half
// its range over the node, and what a link leaves out, the change within each quadrant, adds up
// coherently over a receiver's many links (the sender's partly cancels against the variation of
// its light). Measured on the maze (quadrant links, form factors at jittered points): 2x at
// threshold t and 4x at 2t give the same error for the same links, time and bytes: the weight only
// sets what a threshold means, and the presets' thresholds are chosen for 2x.
constexpr float kReceiverWeight = 2.0f;

struct Evaluation {
  float form_factor = 0.0f;  // mean over the receiver points of their visible form factor
  // Per quadrant c of the receiver node (child (2i + c % 2, 2j + c / 2)): the visible form factor
  // at its centre, or the mean where the quadrant's jittered point is off the mesh.
  std::array<float, 4> quadrant{};
  // max - min over the pairs of (point form factor x pair visibility), or the spread of the
  // point-to-point kernel over the sender seen from one receiver point, whichever is larger.
  float spread = 0.0f;
  bool any = false;          // any covered point on both sides
};

// The form factor from a point x with normal n to the polygon `q` (Lambert's formula for the
// unoccluded point-to-polygon form factor: (1 / 2 pi) sum_i theta_i n . unit(R_i x R_i+1)), the
// polygon first clipped to the half space in front of x. Exact as the polygon touches x's plane.
float point_to_polygon(glm::vec3 x, glm::vec3 n, const std::array<glm::vec3, 4>& q) {
  std::array<glm::vec3, 8> c;
  int count = 0;
  for (int k = 0; k < 4; ++k) {  // Sutherland-Hodgman against dot(n, p - x) >= 0
    const glm::vec3 a = q[static_cast<std::size_t>(k)] - x, b = q[static_cast<std::size_t>((k + 1) % 4)] - x;
    const float da = glm::dot(n, a), db = glm::dot(n, b);
    if (da >= 0.0f) c[static_cast<std::size_t>(count++)] = a;
    if ((da >= 0.0f) != (db >= 0.0f)) c[static_cast<std::size_t>(count++)] = a + (da / (da - db)) * (b - a);
  }
  if (count < 3) return 0.0f;
  float sum = 0.0f;
  for (int k = 0; k < count; ++k) {
    const glm::vec3 a = c[static_cast<std::size_t>(k)], b = c[static_cast<std::size_t>((k + 1) % count)];
    const float la = glm::length(a), lb = glm::length(b);
    if (!(la > 0.0f) || !(lb > 0.0f)) continue;
    const glm::vec3 cr = glm::cross(a, b);
    const float lc = glm::length(cr);
    if (!(lc > 0.0f)) continue;
    const float theta = std::atan2(lc, glm::dot(a, b));
    sum += theta * glm::dot(n, cr) / lc;
  }
  return std::min(1.0f, std::abs(sum) / (2.0f * kPi));
}

// 2 x 2 points per side, one per quadrant: each receiver quadrant's exact form factor to the
// sender node at the quadrant's centre (the midpoint rule: a random point's would add the kernel's
// change over the quadrant as noise), times the fraction of the shadow rays from a jittered point
// of the quadrant to jittered points of the sender's quadrants that arrive (16 rays, one packet).
Evaluation evaluate_link(const RayScene& scene, const TransportPatch& rp, Node r, const TransportPatch& sp, Node s,
                         std::uint64_t seed, std::uint64_t& rays) {
  Rng rng = Rng::stream(seed, mix64((std::uint64_t{node_id(r)} << 32) ^ node_id(s)) ^ mix64(rp.first) ^
                                  (std::uint64_t{sp.first} << 20));
  std::array<glm::vec3, 4> xs, ys;
  std::array<bool, 4> xok, yok;
  for (int k = 0; k < 4; ++k) {
    const float a = (float(k % 2) + rng.next_float()) * 0.5f, b = (float(k / 2) + rng.next_float()) * 0.5f;
    xok[static_cast<std::size_t>(k)] = point_covered(rp, r, a, b);
    xs[static_cast<std::size_t>(k)] = node_point(rp, r, a, b);
    const float c = (float(k % 2) + rng.next_float()) * 0.5f, d = (float(k / 2) + rng.next_float()) * 0.5f;
    yok[static_cast<std::size_t>(k)] = point_covered(sp, s, c, d);
    ys[static_cast<std::size_t>(k)] = node_point(sp, s, c, d);
  }
  const std::array<glm::vec3, 4> polygon = {node_point(sp, s, 0, 0), node_point(sp, s, 1, 0), node_point(sp, s, 1, 1),
                                            node_point(sp, s, 0, 1)};
  std::array<float, 4> point_ff{};
  std::array<Ray, 16> batch;
  std::array<int, 16> owner{};
  std::array<float, 16> point_kernel{};
  std::array<std::uint8_t, 16> blocked{};
  const float sender_area = node_area(sp, s);
  int count = 0, receivers = 0;
  bool any_sender = false;
  for (int b = 0; b < 4; ++b) any_sender = any_sender || yok[static_cast<std::size_t>(b)];
  for (int a = 0; a < 4; ++a) {
    if (!xok[static_cast<std::size_t>(a)]) continue;
    ++receivers;
    const glm::vec3 x = xs[static_cast<std::size_t>(a)];
    const glm::vec3 centre = node_point(rp, r, 0.25f + 0.5f * float(a % 2), 0.25f + 0.5f * float(a / 2));
    // Behind the sender: it sees the sender's back.
    if (!(glm::dot(sp.normal, x - sp.origin) > 0.0f) || !(glm::dot(sp.normal, centre - sp.origin) > 0.0f)) continue;
    point_ff[static_cast<std::size_t>(a)] = point_to_polygon(centre, rp.normal, polygon);
    if (!(point_ff[static_cast<std::size_t>(a)] > 0.0f)) continue;
    for (int b = 0; b < 4; ++b) {
      const glm::vec3 y = ys[static_cast<std::size_t>(b)];
      if (!yok[static_cast<std::size_t>(b)] || !(glm::dot(rp.normal, y - x) > 0.0f)) continue;  // facing pairs
      const glm::vec3 ox = x + scene.ray_epsilon(x) * rp.normal, oy = y + scene.ray_epsilon(y) * sp.normal;
      batch[static_cast<std::size_t>(count)] = Ray{ox, 0.0f, oy - ox, 1.0f};
      owner[static_cast<std::size_t>(count)] = a;
      // The point-to-point kernel x the sender node's area (a form factor, capped at 1): how much
      // the transfer changes over the sender, which the link's single mean leaves out.
      const glm::vec3 d = y - x;
      const float r2 = glm::dot(d, d);
      const float cos_x = glm::dot(rp.normal, d), cos_y = -glm::dot(sp.normal, d);
      point_kernel[static_cast<std::size_t>(count)] =
          r2 > 0.0f && cos_y > 0.0f ? std::min(1.0f, cos_x * cos_y * sender_area / (kPi * r2 * r2)) : 0.0f;
      ++count;
    }
  }
  Evaluation ev;
  ev.any = receivers > 0 && any_sender;
  if (count == 0 || !ev.any) return ev;
  scene.occluded(std::span<const Ray>(batch.data(), static_cast<std::size_t>(count)),
                 std::span<std::uint8_t>(blocked.data(), static_cast<std::size_t>(count)));
  rays += static_cast<std::uint64_t>(count);
  std::array<int, 4> seen{}, tried{};
  std::array<float, 4> k_lo, k_hi{};
  k_lo.fill(std::numeric_limits<float>::max());
  float lo = std::numeric_limits<float>::max(), hi = 0.0f;
  for (int k = 0; k < count; ++k) {
    const auto a = static_cast<std::size_t>(owner[static_cast<std::size_t>(k)]);
    ++tried[a];
    const bool open = !blocked[static_cast<std::size_t>(k)];
    if (open) ++seen[a];
    const float w = open ? point_ff[a] : 0.0f;
    lo = std::min(lo, w);
    hi = std::max(hi, w);
    k_lo[a] = std::min(k_lo[a], point_kernel[static_cast<std::size_t>(k)]);
    k_hi[a] = std::max(k_hi[a], point_kernel[static_cast<std::size_t>(k)]);
  }
  float sender_spread = 0.0f;
  for (std::size_t a = 0; a < 4; ++a)
    if (tried[a] > 1) sender_spread = std::max(sender_spread, k_hi[a] - k_lo[a]);
  float sum = 0.0f, largest = 0.0f;
  int seen_total = 0;
  for (std::size_t a = 0; a < 4; ++a) {
    if (!xok[a]) continue;
    largest = std::max(largest, point_ff[a]);
    seen_total += seen[a];
    if (tried[a] == 0) lo = 0.0f;  // a covered point that sees none of the sender
    else sum += point_ff[a] * float(seen[a]) / float(tried[a]);
  }
  ev.form_factor = sum / float(receivers);
  for (std::size_t a = 0; a < 4; ++a)
    ev.quadrant[a] = !xok[a] ? ev.form_factor : tried[a] == 0 ? 0.0f : point_ff[a] * float(seen[a]) / float(tried[a]);
  // A link whose rays all stop says little about the rest of it: its error bound is the
  // unoccluded form factor, as for a partly blocked one.
  ev.spread = std::max(kReceiverWeight * (seen_total == 0 ? largest : hi - lo), sender_spread);
  return ev;
}

}  // namespace

std::vector<TransportLink> refine_receiver(const RayScene& scene, const std::vector<TransportPatch>& patches,
                                           std::uint32_t receiver, float threshold, std::uint64_t seed,
                                           std::uint64_t& rays) {
  std::vector<TransportLink> links;
  const TransportPatch& rp = patches[receiver];
  const std::vector<std::uint8_t> r_cov = node_coverage(rp);
  struct Pending {
    Node r, s;
  };
  for (std::uint32_t sender = 0; sender < patches.size(); ++sender) {
    if (sender == receiver) continue;
    const TransportPatch& sp = patches[sender];
    if (!faces(rp, sp)) continue;
    const float rho = std::max(sp.albedo.x, std::max(sp.albedo.y, sp.albedo.z));
    if (!(rho > 0.0f)) continue;  // a black sender passes nothing on
    const std::vector<std::uint8_t> s_cov = node_coverage(sp);
    std::vector<Pending> stack{{{0, 0, 0}, {0, 0, 0}}};
    while (!stack.empty()) {
      const Pending link = stack.back();
      stack.pop_back();
      // Where one node's plane cuts the other, its sample points may all fall on one side: such a
      // link is refined unevaluated (the children of nodes with coverage); one wholly behind the
      // other's plane passes nothing.
      const Side r_side = side_of(sp, node_corners(rp, link.r)), s_side = side_of(rp, node_corners(sp, link.s));
      if (r_side == Side::Behind || s_side == Side::Behind) continue;
      const bool r_leaf = link.r.level == rp.level, s_leaf = link.s.level == sp.level;
      const bool cut = r_side == Side::Both || s_side == Side::Both;
      const auto refine = [&] {
        // Refine the larger side (by area), the other when it is already a leaf; children pushed in
        // reverse so that they are evaluated in index order.
        const bool split_receiver = s_leaf || (!r_leaf && node_area(rp, link.r) >= node_area(sp, link.s));
        for (int c = 3; c >= 0; --c) {
          Pending child = link;
          Node& n = split_receiver ? child.r : child.s;
          n = {n.level + 1, 2 * n.i + std::uint32_t(c % 2), 2 * n.j + std::uint32_t(c / 2)};
          if ((split_receiver ? r_cov : s_cov)[node_id(n)]) stack.push_back(child);
        }
      };
      if (cut && !(r_leaf && s_leaf)) {
        refine();
        continue;
      }
      const Evaluation ev = evaluate_link(scene, rp, link.r, sp, link.s, seed, rays);
      if (!ev.any) continue;
      if (rho * ev.spread > threshold && !(r_leaf && s_leaf)) {
        refine();
        continue;
      }
      if (!(ev.form_factor > 0.0f)) continue;
      // A receiver node above the leaves keeps its quadrants' form factors (the kernel's change
      // across it at no extra rays); a leaf holds one value.
      links.push_back({node_id(link.r), sender, node_id(link.s),
                       r_leaf ? std::array<float, 4>{ev.form_factor, ev.form_factor, ev.form_factor, ev.form_factor}
                              : ev.quadrant});
    }
  }
  return links;
}

// ---------------------------------------------------------------------------------------------
// Bounce probes.

TransportProbes bounce_probe_grid(const std::vector<TransportPatch>& patches, float spacing) {
  TransportProbes probes;
  Aabb bounds;
  for (const TransportPatch& p : patches)
    for (const glm::vec3 c : {p.origin, p.origin + p.edge_u, p.origin + p.edge_v, p.origin + p.edge_u + p.edge_v})
      bounds.extend(c);
  if (bounds.empty()) return probes;
  const glm::vec3 extent = bounds.extent();
  float s = spacing > 0.0f ? spacing : kBounceProbeSpacingFraction * glm::length(extent);
  if (!(s > 0.0f) || !std::isfinite(s) || !std::isfinite(glm::length(extent))) return probes;
  // Nodes from half a spacing below the bounds to at least half a spacing above them.
  const auto counts = [&](float step) { return glm::dvec3(glm::ceil(glm::dvec3(extent) / double(step))) + 2.0; };
  while (counts(s).x * counts(s).y * counts(s).z > double(kMaxBounceProbes)) s *= 1.25f;
  probes.spacing = s;
  probes.count = glm::uvec3(counts(s));
  probes.origin = bounds.min - 0.5f * s;
  return probes;
}

BounceProbeTargets bounce_probe_targets(World& world, std::span<const TransportPatch> patches) {
  BounceProbeTargets targets;
  targets.patches = patches;
  std::unordered_map<std::string, std::vector<std::uint32_t>> by_key;
  for (std::uint32_t i = 0; i < patches.size(); ++i) by_key[patches[i].key].push_back(i);
  for (Entity e : world.view<IndirectReceiver, Static, Mesh>().sorted_entities())
    if (const auto it = by_key.find(entity_key(world, e)); it != by_key.end()) targets.patches_of[e.index] = it->second;
  targets.first_cell = bounce_probe_cell_offsets(patches);
  return targets;
}

BounceProbeSight trace_bounce_probe(const RayScene& scene, const BounceProbeTargets& targets, glm::vec3 at,
                                    float spacing, std::uint32_t rays, std::uint64_t seed, std::uint64_t node) {
  BounceProbeSight sight;
  for (int a = 0; a < 6; ++a) {
    glm::vec3 dir(0.0f);
    dir[a / 2] = a % 2 == 0 ? 1.0f : -1.0f;
    Hit hit;
    sight.reach[static_cast<std::size_t>(a)] =
        scene.intersect(Ray{at, 0.0f, dir, spacing}, hit) ? std::clamp(hit.t / spacing, 0.0f, 1.0f) : 1.0f;
  }
  std::map<std::uint32_t, std::array<float, 6>> seen;  // cell -> weights, in cell order
  const auto scramble = static_cast<std::uint32_t>(mix64(seed ^ mix64(node + 0x9e3779b97f4a7c15ull)));
  const float solid_angle = 4.0f * kPi / static_cast<float>(rays);
  std::uint32_t inside = 0;
  for (std::uint32_t k = 0; k < rays; ++k) {
    const glm::vec3 dir = uniform_sphere(sobol_2d(k, scramble));
    Hit hit;
    if (!scene.intersect(Ray{at, 0.0f, dir}, hit)) continue;  // the sky: no bounce light
    if (hit.back_face) {
      if (!hit.material.double_sided) ++inside;
      continue;  // a patch sends light from its front only
    }
    const auto list = targets.patches_of.find(hit.entity.index);
    if (list == targets.patches_of.end()) continue;  // an occluder that is not a receiver
    const glm::vec3 x = at + hit.t * dir;
    int best = -1;
    float best_d = 0.0f;
    for (const std::uint32_t i : list->second) {
      const TransportPatch& p = targets.patches[i];
      const glm::vec3 r = x - p.origin;
      const float d = std::abs(glm::dot(r, p.normal));
      if (d > patch_plane_tolerance(p) || !(glm::dot(dir, p.normal) < 0.0f) || (best >= 0 && d >= best_d)) continue;
      const float s = glm::dot(r, p.edge_u) / glm::dot(p.edge_u, p.edge_u);
      const float t = glm::dot(r, p.edge_v) / glm::dot(p.edge_v, p.edge_v);
      if (!(s >= 0.0f && s <= 1.0f && t >= 0.0f && t <= 1.0f)) continue;
      best = static_cast<int>(i);
      best_d = d;
    }
    if (best < 0) continue;  // triangles left out of the charts
    const TransportPatch& p = targets.patches[static_cast<std::size_t>(best)];
    const glm::vec3 r = x - p.origin;
    const std::uint32_t cells = 1u << std::min(p.level, kBounceProbeCellLevel);
    const auto cell_of = [&](float f) {
      return std::min(static_cast<std::uint32_t>(std::max(f, 0.0f) * static_cast<float>(cells)), cells - 1);
    };
    const std::uint32_t ci = cell_of(glm::dot(r, p.edge_u) / glm::dot(p.edge_u, p.edge_u));
    const std::uint32_t cj = cell_of(glm::dot(r, p.edge_v) / glm::dot(p.edge_v, p.edge_v));
    const std::uint32_t cell = targets.first_cell[static_cast<std::size_t>(best)] + ci + cj * cells;
    std::array<float, 6>& w = seen.try_emplace(cell).first->second;
    for (int a = 0; a < 3; ++a) {
      w[static_cast<std::size_t>(2 * a)] += solid_angle * std::max(0.0f, dir[a]);
      w[static_cast<std::size_t>(2 * a + 1)] += solid_angle * std::max(0.0f, -dir[a]);
    }
  }
  sight.open = static_cast<float>(inside) <= kBounceProbeClosedFraction * static_cast<float>(rays);
  if (sight.open)
    for (const auto& [cell, w] : seen) sight.entries.push_back({cell, w});
  return sight;
}

// ---------------------------------------------------------------------------------------------
// The operator in the Haar bases.

namespace {

// The Haar coefficients of a node's box (1 on its leaves) divided by `divide`: the scaling
// coefficient n / sqrt(N) and, for each ancestor a, its three wavelets +-n / sqrt(n_a).
void box_coefficients(const TransportPatch& p, Node n, float divide,
                      std::vector<std::pair<std::uint32_t, float>>& out) {
  out.clear();
  const float leaves_below = float(1u << (2 * (p.level - n.level)));
  out.push_back({0u, leaves_below / float(p.side()) / divide});
  for (std::uint32_t l = 0; l < n.level; ++l) {
    const std::uint32_t shift = n.level - l;
    const std::uint32_t ai = n.i >> shift, aj = n.j >> shift;
    const std::uint32_t qx = (n.i >> (shift - 1)) & 1u, qy = (n.j >> (shift - 1)) & 1u;
    const float magnitude = leaves_below / float(1u << (p.level - l)) / divide;
    const std::uint32_t k = 1 + 3 * (node_offset(l) + ai + (aj << l));
    out.push_back({k, qy == 0 ? magnitude : -magnitude});
    out.push_back({k + 1, qx == 0 ? magnitude : -magnitude});
    out.push_back({k + 2, qx == qy ? magnitude : -magnitude});
  }
}

struct Triple {
  std::uint32_t col, row;
  glm::vec3 value;
};

// Sums equal (col, row) entries of a sorted list.
void merge_sorted(std::vector<Triple>& t) {
  std::sort(t.begin(), t.end(), [](const Triple& a, const Triple& b) {
    return a.col < b.col || (a.col == b.col && a.row < b.row);
  });
  std::size_t w = 0;
  for (std::size_t i = 0; i < t.size(); ++i) {
    if (w > 0 && t[w - 1].col == t[i].col && t[w - 1].row == t[i].row) t[w - 1].value += t[i].value;
    else t[w++] = t[i];
  }
  t.resize(w);
}

// A CSC matrix of size n from triples sorted by (col, row), per-receiver lists in row order.
SparseTransport from_triples(std::uint32_t n, const std::vector<std::vector<Triple>>& lists) {
  SparseTransport m;
  m.size = n;
  m.begin.assign(std::size_t{n} + 1, 0);
  std::uint64_t total = 0;
  for (const auto& list : lists)
    for (const Triple& t : list) ++m.begin[t.col + 1];
  for (std::uint32_t j = 0; j < n; ++j) m.begin[j + 1] += m.begin[j];
  total = m.begin[n];
  m.row.resize(total);
  m.value.resize(total);
  std::vector<std::uint64_t> next(m.begin.begin(), m.begin.end() - 1);
  for (const auto& list : lists)
    for (const Triple& t : list) {
      m.row[next[t.col]] = t.row;
      m.value[next[t.col]++] = t.value;
    }
  return m;
}

float max_abs(glm::vec3 v) { return std::max(std::abs(v.x), std::max(std::abs(v.y), std::abs(v.z))); }

}  // namespace

SparseTransport direct_operator(const std::vector<TransportPatch>& patches,
                                const std::vector<std::vector<TransportLink>>& links, JobContext& jobs) {
  const std::uint32_t n = patches.empty() ? 0u : patches.back().first + patches.back().leaves();
  std::vector<std::vector<Triple>> lists(patches.size());
  constexpr std::size_t kDenseBlock = std::size_t{1} << 20;  // receiver x sender coefficients summed densely
  // Each receiver's links, one sender patch at a time: summed into a dense block of the two
  // patches' coefficients (or sorted triples for blocks above kDenseBlock), emitted by column;
  // a bitmap of the block's touched cells gives them in that order.
  (void)jobs.parallel_for(patches.size(), 1, [&](std::size_t begin, std::size_t end) {
    std::vector<std::pair<std::uint32_t, float>> u, uc, v;
    std::vector<glm::vec3> block;
    std::vector<std::uint64_t> touched;
    std::vector<Triple> sorted;
    for (std::size_t r = begin; r < end; ++r) {
      const TransportPatch& rp = patches[r];
      std::vector<std::uint32_t> order(links[r].size());
      std::iota(order.begin(), order.end(), 0u);
      std::stable_sort(order.begin(), order.end(), [&](std::uint32_t a, std::uint32_t b) {
        return links[r][a].sender_patch < links[r][b].sender_patch;
      });
      std::vector<Triple>& out = lists[r];
      for (std::size_t k = 0; k < order.size();) {
        const std::uint32_t sender = links[r][order[k]].sender_patch;
        const TransportPatch& sp = patches[sender];
        const std::size_t cells = std::size_t{rp.leaves()} * sp.leaves();
        const bool dense = cells <= kDenseBlock;
        if (dense && block.size() < cells) {
          block.resize(cells, glm::vec3(0.0f));
          touched.resize((cells + 63) / 64, 0);
        }
        sorted.clear();
        for (; k < order.size() && links[r][order[k]].sender_patch == sender; ++k) {
          const TransportLink& link = links[r][order[k]];
          const Node rn = node_of(link.receiver_node), sn = node_of(link.sender_node);
          // W = sqrt(A_r / A_s) sum_c F_c (H_r 1_c) (H_s 1_s)^T rho_s / n_s over the receiver
          // node's quadrants c (the node itself at a leaf), A the leaf areas. The quadrants' boxes
          // have coefficients at the same indices (the scaling one, their ancestors' wavelets), so
          // sum_c F_c H_r 1_c is one list.
          const bool leaf = rn.level == rp.level;
          box_coefficients(sp, sn, float(1u << (2 * (sp.level - sn.level))), v);
          for (std::uint32_t c = 0; c < (leaf ? 1u : 4u); ++c) {
            const Node quadrant = leaf ? rn : Node{rn.level + 1, 2 * rn.i + c % 2, 2 * rn.j + c / 2};
            box_coefficients(rp, quadrant, 1.0f, uc);
            if (c == 0) u.assign(uc.size(), {0u, 0.0f});
            for (std::size_t q = 0; q < uc.size(); ++q)
              u[q] = {uc[q].first, u[q].second + link.form_factor[c] * uc[q].second};
          }
          const glm::vec3 scale = std::sqrt(rp.leaf_area() / sp.leaf_area()) * sp.albedo;
          for (const auto& [sv, vv] : v)
            for (const auto& [ru, uu] : u) {
              if (uu == 0.0f) continue;
              if (dense) {
                const std::size_t cell = std::size_t{sv} * rp.leaves() + ru;
                block[cell] += scale * (uu * vv);
                touched[cell >> 6] |= std::uint64_t{1} << (cell & 63u);
              } else {
                sorted.push_back({sp.first + sv, rp.first + ru, scale * (uu * vv)});
              }
            }
        }
        if (dense) {
          for (std::size_t w = 0; w < (cells + 63) / 64; ++w)
            for (std::uint64_t bits = std::exchange(touched[w], 0); bits != 0; bits &= bits - 1) {
              const std::size_t cell = w * 64 + static_cast<std::size_t>(std::countr_zero(bits));
              const glm::vec3 value = std::exchange(block[cell], glm::vec3(0.0f));
              const auto sv = static_cast<std::uint32_t>(cell / rp.leaves());
              const auto ru = static_cast<std::uint32_t>(cell % rp.leaves());
              if (value != glm::vec3(0.0f)) out.push_back({sp.first + sv, rp.first + ru, value});
            }
        } else {
          merge_sorted(sorted);
          out.insert(out.end(), sorted.begin(), sorted.end());
        }
      }
    }
  });
  return from_triples(n, lists);
}

Result<DenseTransport> dense_direct_operator(const RayScene& scene, const std::vector<TransportPatch>& patches,
                                             std::uint64_t seed, std::uint64_t memory_limit, JobContext& jobs,
                                             std::uint64_t& rays) {
  const std::uint32_t n = patches.empty() ? 0u : patches.back().first + patches.back().leaves();
  const std::uint64_t bytes = std::uint64_t{n} * n * sizeof(glm::vec3);
  if (memory_limit > 0 && bytes > memory_limit)
    return make_error(ErrorCode::InvalidInput, "dense transport: " + std::to_string(n) + " leaves need a " +
                                                   std::to_string(bytes / 1000000) + " MB matrix, over the limit");
  // Leaf-to-leaf kernels with the refinement's estimator, one receiver patch per task.
  DenseTransport out;
  out.size = n;
  std::vector<glm::vec3>& dense = out.value;
  dense.assign(std::size_t{n} * n, glm::vec3(0.0f));  // dense[col * n + row]
  std::vector<std::uint64_t> patch_rays(patches.size(), 0);
  jobs.begin_stage("dense links", patches.size());
  PENUMBRA_TRY(jobs.parallel_for(patches.size(), 1, [&](std::size_t begin, std::size_t end) {
    for (std::size_t r = begin; r < end; ++r) {
      const TransportPatch& rp = patches[r];
      for (std::size_t s = 0; s < patches.size(); ++s) {
        const TransportPatch& sp = patches[s];
        if (s == r || !faces(rp, sp)) continue;
        for (std::uint32_t ri = 0; ri < rp.leaves(); ++ri) {
          if (!(rp.coverage[ri] > 0.0f)) continue;
          const Node rn{rp.level, ri % rp.side(), ri / rp.side()};
          for (std::uint32_t si = 0; si < sp.leaves(); ++si) {
            if (!(sp.coverage[si] > 0.0f)) continue;
            const Node sn{sp.level, si % sp.side(), si / sp.side()};
            const Evaluation ev = evaluate_link(scene, rp, rn, sp, sn, seed, patch_rays[r]);
            dense[std::size_t{sp.first + si} * n + rp.first + ri] = ev.form_factor * sp.albedo;
          }
        }
      }
      jobs.advance(1);
    }
  }));
  rays = std::accumulate(patch_rays.begin(), patch_rays.end(), std::uint64_t{0});
  // Standard decomposition: the receivers' transform down each column, then the senders' along
  // each row (the scale sqrt(A_r / A_s) of the Haar bases' normalisation).
  std::vector<glm::vec3> line;
  for (std::uint32_t c = 0; c < n; ++c)
    for (const TransportPatch& p : patches)
      haar_analyse(std::span<glm::vec3>(dense).subspan(std::size_t{c} * n + p.first, p.leaves()), p.level,
                   p.leaf_area());
  for (std::uint32_t row = 0; row < n; ++row)
    for (const TransportPatch& p : patches) {
      line.resize(p.leaves());
      for (std::uint32_t k = 0; k < p.leaves(); ++k) line[k] = dense[std::size_t{p.first + k} * n + row];
      haar_analyse(line, p.level, 1.0f / p.leaf_area());  // H_s^T / sqrt(A_s) on the sender side
      for (std::uint32_t k = 0; k < p.leaves(); ++k) dense[std::size_t{p.first + k} * n + row] = line[k];
    }
  return out;
}

SparseTransport truncate_transport(const DenseTransport& dense, std::uint64_t keep) {
  const std::uint32_t n = dense.size;
  // Truncation to the `keep` largest coefficients.
  float cut = 0.0f;
  if (keep > 0 && keep < dense.value.size()) {
    std::vector<float> mags(dense.value.size());
    for (std::size_t k = 0; k < dense.value.size(); ++k) mags[k] = max_abs(dense.value[k]);
    std::nth_element(mags.begin(), mags.begin() + static_cast<std::ptrdiff_t>(mags.size() - keep), mags.end());
    cut = mags[mags.size() - keep];
  }
  std::vector<std::vector<Triple>> lists(1);
  for (std::uint32_t c = 0; c < n; ++c)
    for (std::uint32_t row = 0; row < n; ++row) {
      const glm::vec3 v = dense.value[std::size_t{c} * n + row];
      const float mag = max_abs(v);
      if (mag > 0.0f && mag >= cut) lists[0].push_back({c, row, v});
    }
  return from_triples(n, lists);
}

// ---------------------------------------------------------------------------------------------
// The Neumann series.

namespace {

// The left factor of the series' products: T with each column's entries by decreasing magnitude
// (max channel; ties in row order), and those magnitudes.
struct ByMagnitude {
  SparseTransport m;
  std::vector<float> mag;
};
ByMagnitude by_magnitude(SparseTransport t) {
  ByMagnitude out;
  out.mag.resize(t.value.size());
  std::vector<std::uint64_t> order;
  std::vector<std::uint32_t> rows;
  std::vector<glm::vec3> values;
  for (std::uint32_t j = 0; j < t.size; ++j) {
    const std::uint64_t first = t.begin[j];
    order.resize(t.begin[j + 1] - first);
    std::iota(order.begin(), order.end(), first);
    std::stable_sort(order.begin(), order.end(),
                     [&](std::uint64_t x, std::uint64_t y) { return max_abs(t.value[x]) > max_abs(t.value[y]); });
    rows.clear();
    values.clear();
    for (const std::uint64_t k : order) {
      rows.push_back(t.row[k]);
      values.push_back(t.value[k]);
    }
    for (std::size_t q = 0; q < order.size(); ++q) {
      t.row[first + q] = rows[q];
      t.value[first + q] = values[q];
      out.mag[first + q] = max_abs(values[q]);
    }
  }
  out.m = std::move(t);
  return out;
}

// C = A B (A by_magnitude, B CSC with rows sorted), coefficients with max channel below `drop`
// left out, and no product a_ik b_kj below `prune` summed: a column of B stops reading A's column
// k at its first such product. Columns of B go in blocks of kProductBlock neighbours (a patch's
// basis functions, which reach much the same rows): each column of A they need is read once for
// the block, its products summed into the block's accumulators (interleaved per row), whose
// touched rows a bitmap records so that they come out in row order without a sort. Each column's
// sum runs over the same products in the same order at any block and thread count: deterministic.
Result<SparseTransport> multiply(const ByMagnitude& left, const SparseTransport& b, float drop, float prune,
                                 JobContext& jobs) {
  constexpr std::size_t kProductBlock = 8;
  static_assert(kProductBlock <= 8, "a row of B holds the block's columns as the bits of a byte");
  const SparseTransport& a = left.m;
  const std::uint32_t n = b.size;
  std::vector<std::vector<std::uint32_t>> rows(n);
  std::vector<std::vector<glm::vec3>> values(n);
  const std::size_t blocks = (std::size_t{n} + kProductBlock - 1) / kProductBlock;
  PENUMBRA_TRY(jobs.parallel_for(blocks, 8, [&](std::size_t begin, std::size_t end) {
    std::vector<glm::vec3> acc(std::size_t{a.size} * kProductBlock, glm::vec3(0.0f));  // acc[i * block + c]
    std::vector<std::uint64_t> touched((std::size_t{a.size} + 63) / 64, 0);
    std::vector<std::uint64_t> needed((std::size_t{b.size} + 63) / 64, 0);  // rows of B the block has
    std::vector<std::uint8_t> columns(b.size, 0);                          // per such row, the block's columns
    for (std::size_t blk = begin; blk < end; ++blk) {
      const std::size_t j0 = blk * kProductBlock, width = std::min<std::size_t>(kProductBlock, n - j0);
      std::array<std::uint64_t, kProductBlock> cursor{};
      for (std::size_t c = 0; c < width; ++c) {
        cursor[c] = b.begin[j0 + c];
        for (std::uint64_t kb = b.begin[j0 + c]; kb < b.begin[j0 + c + 1]; ++kb) {
          const std::uint32_t k = b.row[kb];
          needed[k >> 6] |= std::uint64_t{1} << (k & 63u);
          columns[k] = static_cast<std::uint8_t>(columns[k] | (1u << c));
        }
      }
      for (std::size_t w = 0; w < needed.size(); ++w)
        for (std::uint64_t bits = std::exchange(needed[w], 0); bits != 0; bits &= bits - 1) {
          const auto k = static_cast<std::uint32_t>(w * 64 + static_cast<std::size_t>(std::countr_zero(bits)));
          // The block's entries in row k of B, by decreasing magnitude.
          std::array<std::uint32_t, kProductBlock> slot;
          std::array<glm::vec3, kProductBlock> bv;
          std::array<float, kProductBlock> bmag;
          std::size_t count = 0;
          for (unsigned mask = std::exchange(columns[k], std::uint8_t{0}); mask != 0; mask &= mask - 1) {
            const auto c = static_cast<std::size_t>(std::countr_zero(mask));
            const glm::vec3 v = b.value[cursor[c]++];
            std::size_t q = count++;
            for (; q > 0 && bmag[q - 1] < max_abs(v); --q) {
              slot[q] = slot[q - 1];
              bv[q] = bv[q - 1];
              bmag[q] = bmag[q - 1];
            }
            slot[q] = static_cast<std::uint32_t>(c);
            bv[q] = v;
            bmag[q] = max_abs(v);
          }
          for (std::uint64_t ka = a.begin[k]; ka < a.begin[k + 1]; ++ka) {
            while (count > 0 && left.mag[ka] * bmag[count - 1] < prune) --count;
            if (count == 0) break;
            const std::uint32_t i = a.row[ka];
            const glm::vec3 av = a.value[ka];
            touched[i >> 6] |= std::uint64_t{1} << (i & 63u);
            glm::vec3* row = &acc[std::size_t{i} * kProductBlock];
            for (std::size_t q = 0; q < count; ++q) row[slot[q]] += av * bv[q];
          }
        }
      for (std::size_t w = 0; w < touched.size(); ++w)
        for (std::uint64_t bits = std::exchange(touched[w], 0); bits != 0; bits &= bits - 1) {
          const auto i = static_cast<std::uint32_t>(w * 64 + static_cast<std::size_t>(std::countr_zero(bits)));
          for (std::size_t c = 0; c < width; ++c) {
            glm::vec3& v = acc[std::size_t{i} * kProductBlock + c];
            if (max_abs(v) >= drop && max_abs(v) > 0.0f) {
              rows[j0 + c].push_back(i);
              values[j0 + c].push_back(v);
            }
            v = glm::vec3(0.0f);
          }
        }
    }
  }));
  SparseTransport c;
  c.size = n;
  c.begin.assign(std::size_t{n} + 1, 0);
  for (std::uint32_t j = 0; j < n; ++j) c.begin[j + 1] = c.begin[j] + rows[j].size();
  c.row.reserve(c.begin[n]);
  c.value.reserve(c.begin[n]);
  for (std::uint32_t j = 0; j < n; ++j) {
    c.row.insert(c.row.end(), rows[j].begin(), rows[j].end());
    c.value.insert(c.value.end(), values[j].begin(), values[j].end());
  }
  return c;
}

// The coefficients of `m` whose largest channel is at least `drop`.
SparseTransport drop_below(const SparseTransport& m, float drop) {
  SparseTransport out;
  out.size = m.size;
  out.begin.assign(std::size_t{m.size} + 1, 0);
  for (std::uint32_t j = 0; j < m.size; ++j) {
    for (std::uint64_t k = m.begin[j]; k < m.begin[j + 1]; ++k)
      if (max_abs(m.value[k]) >= drop) {
        out.row.push_back(m.row[k]);
        out.value.push_back(m.value[k]);
      }
    out.begin[j + 1] = out.row.size();
  }
  return out;
}

// A + B, both CSC with rows sorted in each column.
SparseTransport add(const SparseTransport& a, const SparseTransport& b) {
  SparseTransport c;
  c.size = a.size;
  c.begin.assign(std::size_t{a.size} + 1, 0);
  c.row.reserve(a.row.size() + b.row.size());
  c.value.reserve(a.row.size() + b.row.size());
  for (std::uint32_t j = 0; j < a.size; ++j) {
    std::uint64_t x = a.begin[j], y = b.begin[j];
    while (x < a.begin[j + 1] || y < b.begin[j + 1]) {
      if (y == b.begin[j + 1] || (x < a.begin[j + 1] && a.row[x] < b.row[y])) {
        c.row.push_back(a.row[x]);
        c.value.push_back(a.value[x++]);
      } else if (x == a.begin[j + 1] || b.row[y] < a.row[x]) {
        c.row.push_back(b.row[y]);
        c.value.push_back(b.value[y++]);
      } else {
        c.row.push_back(a.row[x]);
        c.value.push_back(a.value[x++] + b.value[y++]);
      }
    }
    c.begin[j + 1] = c.row.size();
  }
  return c;
}

}  // namespace

Result<NeumannResult> neumann_series(const SparseTransport& direct, float tolerance, std::uint32_t max_terms,
                                     float drop_threshold, std::uint64_t memory_limit, JobContext& jobs) {
  NeumannResult out;
  float largest = 0.0f;
  for (const glm::vec3& v : direct.value) largest = std::max(largest, max_abs(v));
  const float drop = drop_threshold * largest;
  // T itself keeps only its significant coefficients, as every product after it.
  SparseTransport t = drop_below(direct, drop);
  out.global = t;
  out.terms = 1;
  SparseTransport term = t;
  const ByMagnitude left = by_magnitude(std::move(t));
  jobs.begin_stage("Neumann series", max_terms);
  jobs.advance(1);
  out.last_term_ratio = direct.nonzeros() > 0 ? 1.0f : 0.0f;
  out.converged = direct.nonzeros() == 0;
  while (!out.converged && out.terms < max_terms) {
    if (jobs.cancelled()) return make_error(ErrorCode::Cancelled, "indirect transport: cancelled");
    auto next = multiply(left, term, drop, kProductPrune * drop, jobs);
    if (!next) return next.error();
    term = std::move(*next);
    out.global = add(out.global, term);
    ++out.terms;
    jobs.advance(1);
    const double g = out.global.frobenius();
    out.last_term_ratio = g > 0.0 ? static_cast<float>(term.frobenius() / g) : 0.0f;
    out.converged = !(out.last_term_ratio > tolerance);
    if (memory_limit > 0 && out.global.bytes() + term.bytes() > memory_limit)
      return make_error(ErrorCode::InvalidInput,
                        "indirect transport: the global operator needs " + std::to_string(out.global.bytes() / 1000000) +
                            " MB after " + std::to_string(out.terms) +
                            " terms, over the memory limit; raise drop_threshold or refinement_threshold");
  }
  return out;
}

// ---------------------------------------------------------------------------------------------
// The baker.

namespace {

// With no light moving, only the fixed lights' light needs transporting: E_ind = sum_{k=1..K}
// T^k E_d by products of T with one vector (K products of nonzeros(T) each) instead of the series
// of matrices, with nothing dropped; it stops as neumann_series does, on the vector's norm (the
// sum of squares over the leaves and channels). `direct` is T as a TransportData's operator.
struct NeumannLight {
  std::vector<glm::vec3> indirect;
  std::uint32_t terms = 0;
  float last_term_ratio = 0.0f;
  bool converged = false;
};
Result<NeumannLight> neumann_light(const TransportData& direct, std::span<const glm::vec3> light, float tolerance,
                                   std::uint32_t max_terms, JobContext& jobs) {
  const std::size_t n = direct.leaf_count();
  const auto norm = [](const std::vector<glm::vec3>& v) {
    double s = 0.0;
    for (const glm::vec3& x : v) s += double(x.x) * x.x + double(x.y) * x.y + double(x.z) * x.z;
    return std::sqrt(s);
  };
  NeumannLight out;
  out.indirect.assign(n, glm::vec3(0.0f));
  std::vector<glm::vec3> term(light.begin(), light.end()), next(n);
  jobs.begin_stage("Neumann series", max_terms);
  while (!out.converged && out.terms < max_terms) {
    if (jobs.cancelled()) return make_error(ErrorCode::Cancelled, "indirect transport: cancelled");
    apply_transport(direct, term, next, 0.0f);
    for (std::size_t i = 0; i < n; ++i) out.indirect[i] += next[i];
    ++out.terms;
    jobs.advance(1);
    const double sum = norm(out.indirect);
    out.last_term_ratio = sum > 0.0 ? static_cast<float>(norm(next) / sum) : 0.0f;
    out.converged = !(out.last_term_ratio > tolerance);
    std::swap(term, next);
  }
  return out;
}

constexpr std::uint64_t kPatchBlock = 4;  // receiver patches per work item
// The layout of the links a part carries (TransportLink): in the inputs' hash, so that a part of
// another layout is never merged.
constexpr std::uint32_t kLinkLayout = 2;
// The rule that cuts receivers into charts (build_transport_patches: flatness, plane), in the
// inputs' hash so that a bake of an earlier rule reads as out of date.
constexpr std::uint32_t kChartRule = 2;
// Parts carry links and probe entries as their bytes: no padding.
static_assert(sizeof(TransportLink) == 3 * sizeof(std::uint32_t) + 4 * sizeof(float));
static_assert(sizeof(BounceProbeEntry) == sizeof(std::uint32_t) + 6 * sizeof(float));

// Written as its bytes into the plan, which every shard must reproduce: no padding (`unused` fills
// what would be padding, always 0).
struct Header {
  float refinement_threshold, bounce_tolerance, drop_threshold;
  std::uint32_t finest_level, max_bounces, unused;
  std::uint64_t seed, memory_limit;
};
static_assert(sizeof(Header) == 3 * sizeof(float) + 3 * sizeof(std::uint32_t) + 2 * sizeof(std::uint64_t));

// The header: the settings, then the patches, the probe grid (no entries: every probe open and
// empty), whether a light moves and the fixed lights' direct irradiance, as a chunk's payload,
// read back with the chunk's checks.
std::vector<std::byte> write_header(const Header& h, const std::vector<TransportPatch>& patches,
                                    const TransportProbes& grid, bool moving_lights,
                                    std::vector<glm::vec3> fixed_direct) {
  TransportData data;
  data.patches = patches;
  data.moving_lights = moving_lights;
  data.fixed_direct = std::move(fixed_direct);
  data.fixed_indirect.assign(data.fixed_direct.size(), glm::vec3(0.0f));
  if (!data.fixed_direct.empty()) data.fixed_probes.assign(6 * grid.nodes(), glm::vec3(0.0f));
  data.global.size = data.leaf_count();
  data.global.begin.assign(std::size_t{data.global.size} + 1, 0);
  data.probes = grid;
  data.probes.rays = kBounceProbeRays;
  data.probes.open.assign(grid.nodes(), 1);
  data.probes.reach.assign(grid.nodes(), std::array<float, 6>{});
  data.probes.begin.assign(grid.nodes() + 1, 0);
  ByteWriter w;
  w.write(h);
  const BakeChunk geometry = write_transport_chunk("", data);
  w.write_vector(std::span<const std::byte>(geometry.payload));
  return w.take();
}

Result<std::pair<Header, TransportData>> read_header(std::span<const std::byte> bytes, const std::string& context) {
  ByteReader r(bytes, context);
  Header h;
  std::vector<std::byte> payload;
  PENUMBRA_TRY(r.read(h));
  PENUMBRA_TRY(r.read_vector(payload));
  PENUMBRA_TRY(r.finish());
  auto geometry = read_transport_chunk(BakeChunk{kTransportChunkType, kTransportChunkVersion, "", payload});
  if (!geometry) return geometry.error();
  return std::make_pair(h, std::move(geometry->data));
}

Entity transport_entity(World& world) {
  const std::vector<Entity> all = world.view<IndirectTransport>().sorted_entities();
  return all.empty() ? Entity::null() : all.front();
}

// The enabled local DynamicLights, in entity order (what the transport carries).
std::vector<Entity> transport_lights(World& world) {
  std::vector<Entity> out;
  for (Entity e : world.view<DynamicLight, Light>().sorted_entities())
    if (world.get<DynamicLight>(e).enabled && world.get<Light>(e).type != Light::Type::Directional)
      out.push_back(e);
  return out;
}

Result<BakeWork> plan_transport(BakeInputs& in) {
  BakeWork work;
  const Entity owner = transport_entity(in.world);
  if (!owner) return work;
  const IndirectTransport& settings = in.world.get<IndirectTransport>(owner);
  const std::string what = "indirect transport '" + entity_key(in.world, owner) + "'";
  PENUMBRA_TRY(check_fields(indirect_transport_info(), &settings, what));
  if (settings.glossy)
    return make_error(ErrorCode::Unsupported, what + ": glossy transport is not implemented; set glossy to false");
  auto key = bake_key(in, owner, what);
  if (!key) return key.error();
  std::vector<std::string> warnings;
  auto patches = build_transport_patches(in.world, settings, warnings);
  if (!patches) return patches.error();
  constexpr std::size_t kShown = 3;  // warnings logged one by one; the rest counted
  for (std::size_t i = 0; i < std::min(warnings.size(), kShown); ++i) log(LogLevel::Warning, warnings[i]);
  if (warnings.size() > kShown)
    log(LogLevel::Warning, what + ": " + std::to_string(warnings.size() - kShown) +
                               " more receivers with triangles outside every chart (see the first " +
                               std::to_string(kShown) + ")");
  if (patches->empty()) return work;
  const Header h{settings.refinement_threshold, settings.bounce_tolerance, settings.drop_threshold,
                 settings.finest_level, settings.max_bounces, 0, in.settings.seed, in.settings.memory_limit_bytes};
  // The fixed lights' direct light at the leaves, baked (the finish applies the operator to it);
  // the operator itself is dropped when there are lights and all of them are fixed.
  auto fixed = dynamic_lights(in.world, LightMotion::Fixed);
  if (!fixed) return fixed.error();
  bool moving_lights = fixed->empty();
  for (Entity e : transport_lights(in.world)) moving_lights = moving_lights || in.world.get<DynamicLight>(e).moves;
  std::vector<glm::vec3> fixed_direct;
  if (!fixed->empty()) {
    TransportData leaves;
    leaves.patches = *patches;
    fixed_direct.resize(leaves.leaf_count());
    const TransportOccluders occluders = TransportOccluders::build(in.world);
    direct_irradiance(leaves, *fixed, &occluders, fixed_direct);
  }
  auto shared = std::make_shared<std::vector<TransportPatch>>(std::move(*patches));
  auto grid = std::make_shared<const TransportProbes>(bounce_probe_grid(*shared, settings.probe_spacing));
  auto targets = std::make_shared<const BounceProbeTargets>(bounce_probe_targets(in.world, *shared));
  // Elements: the receiver patches (their links), then the bounce probes (what each saw).
  work.groups.push_back(BakeGroup{std::move(*key), shared->size() + grid->nodes(), kPatchBlock, 1000.0,
                                  write_header(h, *shared, *grid, moving_lights, std::move(fixed_direct))});
  work.run = [&in, shared, grid, targets, h](std::size_t, std::uint64_t begin, std::uint64_t end,
                                             JobContext& jobs) -> Result<std::vector<std::byte>> {
    const std::uint64_t patch_end = std::min<std::uint64_t>(end, shared->size());
    const std::size_t count = begin < patch_end ? static_cast<std::size_t>(patch_end - begin) : 0;
    const std::uint64_t probe_begin = std::max<std::uint64_t>(begin, shared->size());
    const std::size_t probe_count = end > probe_begin ? static_cast<std::size_t>(end - probe_begin) : 0;
    std::vector<std::vector<TransportLink>> links(count);
    std::vector<BounceProbeSight> sights(probe_count);
    jobs.begin_stage("transport links and probes", count + probe_count);
    PENUMBRA_TRY(jobs.parallel_for(count, 1, [&](std::size_t b, std::size_t e) {
      for (std::size_t i = b; i < e; ++i) {
        std::uint64_t rays = 0;
        links[i] = refine_receiver(in.rays, *shared, static_cast<std::uint32_t>(begin + i), h.refinement_threshold,
                                   h.seed, rays);
        jobs.advance(1);
      }
    }));
    const glm::uvec3 n = grid->count;
    PENUMBRA_TRY(jobs.parallel_for(probe_count, 4, [&](std::size_t b, std::size_t e) {
      for (std::size_t i = b; i < e; ++i) {
        const std::uint64_t node = probe_begin + i - shared->size();
        const glm::vec3 ijk(float(node % n.x), float(node / n.x % n.y), float(node / n.x / n.y));
        sights[i] = trace_bounce_probe(in.rays, *targets, grid->origin + grid->spacing * ijk, grid->spacing,
                                       kBounceProbeRays, h.seed, node);
        jobs.advance(1);
      }
    }));
    std::uint64_t total = 0;
    for (const auto& l : links) total += l.size() * sizeof(TransportLink);
    for (const BounceProbeSight& sight : sights) total += sight.entries.size() * sizeof(BounceProbeEntry);
    PENUMBRA_TRY(in.budget.reserve("transport links and probes", total));
    ByteWriter out;
    for (const auto& l : links) out.write_vector(l);
    for (const BounceProbeSight& sight : sights) {
      out.write(static_cast<std::uint8_t>(sight.open ? 1 : 0));
      out.write_vector(sight.entries);
      out.write(sight.reach);
    }
    in.budget.release(total);
    return out.take();
  };
  return work;
}

Result<std::vector<BakeChunk>> finish_transport(std::span<const BakedGroup> groups, JobContext& jobs) {
  std::vector<BakeChunk> chunks;
  for (const BakedGroup& g : groups) {
    const std::string context = "indirect transport '" + g.group->name + "'";
    auto header = read_header(g.group->header, context + " header");
    if (!header) return header.error();
    const Header& h = header->first;
    const std::vector<TransportPatch>& patches = header->second.patches;
    TransportProbes probes = std::move(header->second.probes);
    std::vector<std::vector<TransportLink>> links(patches.size());
    ByteReader r(g.results, context + " results");
    std::uint64_t link_count = 0;
    for (std::size_t p = 0; p < patches.size(); ++p) {
      PENUMBRA_TRY(r.read_vector(links[p]));
      for (const TransportLink& l : links[p])
        if (l.sender_patch >= patches.size() || l.receiver_node >= node_offset(patches[p].level + 1) ||
            l.sender_node >= node_offset(patches[l.sender_patch].level + 1) ||
            !std::all_of(l.form_factor.begin(), l.form_factor.end(), [](float f) { return std::isfinite(f); }))
          return make_error(ErrorCode::InvalidInput, context + " results: a link of patch " + std::to_string(p) +
                                                         " is out of range; re-bake the part");
      link_count += links[p].size();
    }
    const std::uint32_t cells = header->second.cell_count();
    probes.entries.clear();
    for (std::size_t node = 0; node < probes.nodes(); ++node) {
      std::uint8_t open = 0;
      std::vector<BounceProbeEntry> entries;
      PENUMBRA_TRY(r.read(open));
      PENUMBRA_TRY(r.read_vector(entries));
      PENUMBRA_TRY(r.read(probes.reach[node]));
      if (!bounce_probe_in_range(open, probes.reach[node], entries, cells))
        return make_error(ErrorCode::InvalidInput, context + " results: bounce probe " + std::to_string(node) +
                                                       " has a value out of range; re-bake the part");
      probes.open[node] = open;
      probes.begin[node] = static_cast<std::uint32_t>(probes.entries.size());
      probes.entries.insert(probes.entries.end(), entries.begin(), entries.end());
    }
    probes.begin[probes.nodes()] = static_cast<std::uint32_t>(probes.entries.size());
    PENUMBRA_TRY(r.finish());
    jobs.begin_stage("direct operator", 1);
    TransportData data;
    data.patches = patches;
    data.global = direct_operator(patches, links, jobs);
    jobs.advance(1);
    data.probes = std::move(probes);
    data.refinement_threshold = h.refinement_threshold;
    data.finest_level = h.finest_level;
    data.links = link_count;
    data.direct_nonzeros = data.global.nonzeros();
    data.fixed_direct = std::move(header->second.fixed_direct);
    data.fixed_indirect.assign(data.fixed_direct.size(), glm::vec3(0.0f));
    data.moving_lights = header->second.moving_lights;
    if (data.moving_lights) {
      // G for the moving lights; the fixed ones' light through it whole (every coefficient kept).
      auto series =
          neumann_series(data.global, h.bounce_tolerance, h.max_bounces, h.drop_threshold, h.memory_limit, jobs);
      if (!series) return series.error();
      data.global = std::move(series->global);
      data.terms = series->terms;
      data.last_term_ratio = series->last_term_ratio;
      data.converged = series->converged;
      if (!data.fixed_direct.empty()) apply_transport(data, data.fixed_direct, data.fixed_indirect, 0.0f);
    } else {
      // No light moves: the fixed lights' light alone, and neither G nor the probes' entries kept.
      auto light = neumann_light(data, data.fixed_direct, h.bounce_tolerance, h.max_bounces, jobs);
      if (!light) return light.error();
      data.fixed_indirect = std::move(light->indirect);
      data.terms = light->terms;
      data.last_term_ratio = light->last_term_ratio;
      data.converged = light->converged;
    }
    // What the bounce probes see of the fixed lights' light.
    if (!data.fixed_direct.empty()) {
      data.fixed_probes.assign(6 * data.probes.nodes(), glm::vec3(0.0f));
      bounce_probe_irradiance(data, data.fixed_direct, data.fixed_indirect, data.fixed_probes);
    }
    if (!data.moving_lights) {
      data.global = SparseTransport{};
      data.global.size = data.leaf_count();
      data.global.begin.assign(std::size_t{data.global.size} + 1, 0);
      data.probes.entries.clear();
      data.probes.begin.assign(data.probes.nodes() + 1, 0);
    }
    if (!data.converged)
      log(LogLevel::Warning, context + ": the Neumann series did not converge in " + std::to_string(data.terms) +
                                 " terms (last term " + std::to_string(data.last_term_ratio) +
                                 " of the sum); the indirect light is short by the missing bounces: raise max_bounces");
    chunks.push_back(write_transport_chunk(g.group->name, data));
  }
  return chunks;
}

void hash_inputs(World& world, const BakeSettings&, Hasher& h) {
  h.add(kTransportChunkVersion);
  h.add(kLinkLayout);
  h.add(kChartRule);
  const Entity owner = transport_entity(world);
  if (!owner) return;
  h.add(std::string_view(entity_key(world, owner)));
  hash_fields(indirect_transport_info(), &world.get<IndirectTransport>(owner), h);
  for (Entity e : world.view<IndirectReceiver>().sorted_entities()) {
    h.add(std::string_view(entity_key(world, e)));
    hash_fields(indirect_receiver_info(), &world.get<IndirectReceiver>(e), h);
  }
  // The lights: whether each moves, and a fixed one's light and place (its bounce is baked).
  for (Entity e : transport_lights(world)) {
    const DynamicLight& d = world.get<DynamicLight>(e);
    h.add(std::string_view(entity_key(world, e)));
    h.add(d.moves);
    if (d.moves) continue;
    hash_light(world.get<Light>(e), h);
    if (const auto* wt = world.try_get<WorldTransform>(e)) h.add(wt->matrix);
  }
}

}  // namespace

void register_indirect_transport_baker(World& world) {
  Baker b = baker_for(indirect_transport_module());
  b.reads_lights = false;
  b.stages = 4;
  b.hash_inputs = hash_inputs;
  b.plan = plan_transport;
  b.finish = finish_transport;
  world.resource<BakerRegistry>().add(std::move(b));
}

}  // namespace penumbra
