// Indirect transport's runtime: dynamic lights, shadowing, direct light at the leaves, the update
// system and the module descriptor (see indirect_transport_system.h).
#include "penumbra/indirect_transport/indirect_transport_system.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <numeric>
#include <string>

#include <glm/common.hpp>
#include <glm/geometric.hpp>

#include "penumbra/core/hash.h"
#include "penumbra/core/log.h"
#include "penumbra/ecs/transform.h"
#include "penumbra/scene/entity_key.h"

namespace penumbra {

namespace {

bool finite(glm::vec3 v) { return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z); }

std::string light_name(const World& world, Entity e) {
  const Name* name = world.try_get<Name>(e);
  return "light '" + (name != nullptr ? name->value : std::string("?")) + "' (entity " + std::to_string(e.index) +
         ")";
}

}  // namespace

Result<std::vector<RuntimeLight>> dynamic_lights(World& world, LightMotion motion) {
  std::vector<RuntimeLight> out;
  for (Entity e : world.view<DynamicLight, Light, WorldTransform>().sorted_entities()) {
    const DynamicLight& tag = world.get<DynamicLight>(e);
    if (!tag.enabled || tag.moves != (motion == LightMotion::Moving)) continue;
    const Light& light = world.get<Light>(e);
    if (light.type == Light::Type::Directional) continue;  // not a local light
    const LightFrame frame = light_frame(light, world.get<WorldTransform>(e).matrix);
    RuntimeLight rl;
    rl.light = light;
    rl.position = frame.position;
    rl.direction = frame.direction;
    rl.half_x = frame.half_x;
    rl.half_y = frame.half_y;
    if (!frame.valid || !std::isfinite(light.intensity) || !finite(light.color))
      return make_error(ErrorCode::InvalidInput, "indirect transport: " + light_name(world, e) +
                                                     " has a non-finite position, direction, size or intensity; "
                                                     "fix its Transform or Light");
    if (frame.zero_rect)
      return make_error(ErrorCode::InvalidInput, "indirect transport: " + light_name(world, e) +
                                                     " is a rect light of zero area; fix Light::size");
    out.push_back(rl);
  }
  return out;
}

// ---------------------------------------------------------------------------------------------
// Occluders.

TransportOccluders TransportOccluders::build(World& world) {
  TransportOccluders o;
  for (Entity e : world.view<Static, Mesh, WorldTransform>().sorted_entities()) {
    const Mesh& mesh = world.get<Mesh>(e);
    if (!mesh.data) continue;
    const glm::mat4& m = world.get<WorldTransform>(e).matrix;
    const MeshData& d = *mesh.data;
    for (std::size_t t = 0; t + 2 < d.indices.size(); t += 3) {
      const glm::vec3 a = glm::vec3(m * glm::vec4(d.positions[d.indices[t]], 1.0f));
      const glm::vec3 b = glm::vec3(m * glm::vec4(d.positions[d.indices[t + 1]], 1.0f));
      const glm::vec3 c = glm::vec3(m * glm::vec4(d.positions[d.indices[t + 2]], 1.0f));
      if (finite(a) && finite(b) && finite(c) && glm::length(glm::cross(b - a, c - a)) > 0.0f)
        o.triangles_.push_back({a, b - a, c - a});
    }
  }
  if (o.triangles_.empty()) return o;
  std::vector<glm::vec3> centres(o.triangles_.size());
  for (std::size_t i = 0; i < centres.size(); ++i) {
    const Triangle& t = o.triangles_[i];
    centres[i] = t.a + (t.e1 + t.e2) / 3.0f;
  }
  o.nodes_.reserve(2 * o.triangles_.size());
  o.nodes_.push_back({});
  o.build_node(0, centres, 0, static_cast<std::uint32_t>(o.triangles_.size()));
  return o;
}

void TransportOccluders::build_node(std::uint32_t node, std::vector<glm::vec3>& centres, std::uint32_t first,
                                    std::uint32_t count) {
  glm::vec3 lo(std::numeric_limits<float>::max()), hi(-std::numeric_limits<float>::max());
  glm::vec3 clo = lo, chi = hi;
  for (std::uint32_t i = first; i < first + count; ++i) {
    const Triangle& t = triangles_[i];
    for (const glm::vec3 p : {t.a, t.a + t.e1, t.a + t.e2}) {
      lo = glm::min(lo, p);
      hi = glm::max(hi, p);
    }
    clo = glm::min(clo, centres[i]);
    chi = glm::max(chi, centres[i]);
  }
  nodes_[node].lo = lo;
  nodes_[node].hi = hi;
  if (count <= 4) {
    nodes_[node].first = first;
    nodes_[node].count = count;
    return;
  }
  // Median split of the centres along the widest axis of their bounds.
  const glm::vec3 ext = chi - clo;
  const int axis = ext.x >= ext.y && ext.x >= ext.z ? 0 : ext.y >= ext.z ? 1 : 2;
  std::vector<std::uint32_t> order(count);
  std::iota(order.begin(), order.end(), first);
  const std::uint32_t half = count / 2;
  std::nth_element(order.begin(), order.begin() + half, order.end(), [&](std::uint32_t a, std::uint32_t b) {
    return centres[a][axis] < centres[b][axis] || (centres[a][axis] == centres[b][axis] && a < b);
  });
  std::vector<Triangle> tris(count);
  std::vector<glm::vec3> cs(count);
  for (std::uint32_t i = 0; i < count; ++i) {
    tris[i] = triangles_[order[i]];
    cs[i] = centres[order[i]];
  }
  std::copy(tris.begin(), tris.end(), triangles_.begin() + first);
  std::copy(cs.begin(), cs.end(), centres.begin() + first);
  const auto left = static_cast<std::uint32_t>(nodes_.size());
  nodes_.push_back({});
  nodes_.push_back({});
  nodes_[node].first = left;
  nodes_[node].count = 0;
  build_node(left, centres, first, half);
  build_node(left + 1, centres, first + half, count - half);
}

bool TransportOccluders::occluded(glm::vec3 from, glm::vec3 to) const {
  if (nodes_.empty()) return false;
  const glm::vec3 d = to - from;
  const glm::vec3 inv = 1.0f / d;
  constexpr float kEnd = 1.0f - 1e-4f;  // the segment's end (the light) is not an occluder
  std::array<std::uint32_t, 64> stack;
  int top = 0;
  stack[top++] = 0;
  while (top > 0) {
    const Node& n = nodes_[stack[--top]];
    // Slab test against the node's box over t in [0, kEnd].
    const glm::vec3 t0 = (n.lo - from) * inv, t1 = (n.hi - from) * inv;
    const glm::vec3 tmin = glm::min(t0, t1), tmax = glm::max(t0, t1);
    const float enter = std::max(std::max(tmin.x, tmin.y), std::max(tmin.z, 0.0f));
    const float leave = std::min(std::min(tmax.x, tmax.y), std::min(tmax.z, kEnd));
    if (!(enter <= leave)) continue;
    if (n.count == 0) {
      if (top + 2 > static_cast<int>(stack.size())) return false;  // depth is O(log n): never in practice
      stack[top++] = n.first;
      stack[top++] = n.first + 1;
      continue;
    }
    for (std::uint32_t i = n.first; i < n.first + n.count; ++i) {
      // Moller-Trumbore, both sides.
      const Triangle& t = triangles_[i];
      const glm::vec3 p = glm::cross(d, t.e2);
      const float det = glm::dot(t.e1, p);
      if (std::abs(det) < 1e-30f) continue;
      const float inv_det = 1.0f / det;
      const glm::vec3 s = from - t.a;
      const float u = glm::dot(s, p) * inv_det;
      if (u < 0.0f || u > 1.0f) continue;
      const glm::vec3 q = glm::cross(s, t.e1);
      const float v = glm::dot(d, q) * inv_det;
      if (v < 0.0f || u + v > 1.0f) continue;
      const float tt = glm::dot(t.e2, q) * inv_det;
      if (tt > 1e-4f && tt < kEnd) return true;
    }
  }
  return false;
}

// ---------------------------------------------------------------------------------------------
// Direct light at the leaves.

namespace {

// Solid angle of triangle (a, b, c) seen from the origin (Van Oosterom & Strackee 1983).
float triangle_solid_angle(glm::vec3 a, glm::vec3 b, glm::vec3 c) {
  const float la = glm::length(a), lb = glm::length(b), lc = glm::length(c);
  const float num = std::abs(glm::dot(a, glm::cross(b, c)));
  const float den = la * lb * lc + glm::dot(a, b) * lc + glm::dot(a, c) * lb + glm::dot(b, c) * la;
  return 2.0f * std::atan2(num, den);
}

// The leaves of one patch (see direct_irradiance).
void direct_irradiance_of(const TransportPatch& p, std::span<const RuntimeLight> lights,
                          const TransportOccluders* occluders, std::span<glm::vec3> out) {
  std::fill(out.begin() + p.first, out.begin() + p.first + p.leaves(), glm::vec3(0.0f));
  const float inv = 1.0f / static_cast<float>(p.side());
  const glm::vec3 du = p.edge_u * inv, dv = p.edge_v * inv;
  const float leaf_area = p.leaf_area();
  const float offset = 1e-4f * std::sqrt(p.area());
  for (const RuntimeLight& rl : lights) {
    // Point sources: one for a point or spot light, 4 x 4 over a rect light's area (intensity
    // L A_k cos_l towards the patch).
    std::array<glm::vec3, 16> where;
    int sources = 1;
    where[0] = rl.position;
    if (rl.light.type == Light::Type::Rect) {
      sources = 16;
      for (int k = 0; k < 16; ++k)
        where[static_cast<std::size_t>(k)] = rl.position + ((2.0f * float(k % 4) + 1.0f) / 4.0f - 1.0f) * rl.half_x +
                                             ((2.0f * float(k / 4) + 1.0f) / 4.0f - 1.0f) * rl.half_y;
    }
    const glm::vec3 power = rl.light.color * rl.light.intensity;
    const float sub_area = 4.0f * glm::length(glm::cross(rl.half_x, rl.half_y)) / 16.0f;
    for (std::uint32_t j = 0; j < p.side(); ++j)
      for (std::uint32_t i = 0; i < p.side(); ++i) {
        const std::uint32_t k = i + j * p.side();
        if (!(p.coverage[k] > 0.0f)) continue;
        const glm::vec3 c0 = p.origin + float(i) * du + float(j) * dv;
        const glm::vec3 centre = c0 + 0.5f * (du + dv);
        float e = 0.0f;
        for (int s = 0; s < sources; ++s) {
          const glm::vec3 src = where[static_cast<std::size_t>(s)];
          const glm::vec3 to = src - centre;
          const float dist = glm::length(to);
          if (!(glm::dot(src - p.origin, p.normal) > 0.0f) || !(dist > 0.0f)) continue;  // behind the patch
          const glm::vec3 l = to / dist;
          float weight = punctual_window(rl.light, rl.direction, l, dist);
          if (rl.light.type == Light::Type::Rect) weight = std::max(0.0f, -glm::dot(rl.direction, l)) * sub_area;
          if (!(weight > 0.0f)) continue;
          // Mean of I cos_x / r^2 over the leaf = I Omega(leaf) / A (exact for a bare point source).
          const glm::vec3 a = c0 - src, b = a + du, c = a + du + dv, d = a + dv;
          const float omega = triangle_solid_angle(a, b, c) + triangle_solid_angle(a, c, d);
          e += weight * omega / leaf_area;
        }
        if (!(e > 0.0f)) continue;
        if (occluders != nullptr && occluders->occluded(centre + offset * p.normal, rl.position)) continue;
        out[p.first + k] += power * e;
      }
  }
}

}  // namespace

void direct_irradiance(const TransportData& data, std::span<const RuntimeLight> lights,
                       const TransportOccluders* occluders, std::span<glm::vec3> out, TaskScheduler* scheduler) {
  JobContext jobs(scheduler);
  (void)jobs.parallel_for(data.patches.size(), 4, [&](std::size_t begin, std::size_t end) {
    for (std::size_t pi = begin; pi < end; ++pi) direct_irradiance_of(data.patches[pi], lights, occluders, out);
  });
}

// ---------------------------------------------------------------------------------------------
// The update.

namespace {

struct TransportState {
  const TransportData* data = nullptr;  // what the occluders were built for
  std::uint64_t lights_hash = 0;
  std::shared_ptr<TransportOccluders> occluders;
  std::shared_ptr<ThreadPool> pool = std::make_shared<ThreadPool>(2);  // the updates' two threads
  std::string last_error;
  const TransportData* warned = nullptr;  // the bake whose missing operator was reported
};

std::uint64_t hash_lights(std::span<const RuntimeLight> lights) {
  Hasher h;
  h.add(static_cast<std::uint64_t>(lights.size()));
  for (const RuntimeLight& l : lights) {
    h.add(l.light.type);
    h.add(l.light.color);
    h.add(l.light.intensity);
    h.add(l.light.range);
    h.add(l.light.inner_cone_angle);
    h.add(l.light.outer_cone_angle);
    h.add(l.position);
    h.add(l.direction);
    h.add(l.half_x);
    h.add(l.half_y);
  }
  return h.digest();
}

}  // namespace

Result<bool> update_indirect_transport(World& world) {
  Entity owner = Entity::null();
  for (Entity e : world.view<IndirectTransport>().sorted_entities())
    if (world.get<IndirectTransport>(e).data) {
      owner = e;
      break;
    }
  if (!owner) return false;
  TransportState& state = world.resource<TransportState>();
  const std::shared_ptr<const TransportData> data = world.get<IndirectTransport>(owner).data;
  auto lights = dynamic_lights(world);
  if (!lights) return lights.error();
  const std::uint64_t lights_hash = hash_lights(*lights);
  const bool rebuilt = state.data != data.get();
  if (!rebuilt && lights_hash == state.lights_hash && world.has<IndirectLightmap>(owner)) return false;
  if (rebuilt || !state.occluders) {
    state.occluders = std::make_shared<TransportOccluders>(TransportOccluders::build(world));
    state.data = data.get();
  }
  state.lights_hash = lights_hash;
  if (!data->moving_lights && !lights->empty()) {
    if (state.warned != data.get())
      log(LogLevel::Warning, "indirect transport: " + std::to_string(lights->size()) +
                                 " DynamicLights move, but the bake kept no operator (every DynamicLight was fixed "
                                 "when it baked): their bounce light is missing; re-bake");
    state.warned = data.get();
    lights->clear();
  }
  IndirectLightmap& map = world.has<IndirectLightmap>(owner) ? world.patch<IndirectLightmap>(owner)
                                                             : world.add<IndirectLightmap>(owner);
  const std::size_t leaves = data->leaf_count();
  map.direct.assign(leaves, glm::vec3(0.0f));
  map.irradiance.assign(leaves, glm::vec3(0.0f));
  map.probes.assign(6 * data->probes.nodes(), glm::vec3(0.0f));
  map.kept_coefficients = 0;
  if (!lights->empty()) {
    direct_irradiance(*data, *lights, state.occluders.get(), map.direct, state.pool.get());
    map.kept_coefficients = apply_transport(*data, map.direct, map.irradiance, 1e-4f, state.pool.get()).kept;
    bounce_probe_irradiance(*data, map.direct, map.irradiance, map.probes, state.pool.get());
  }
  // The bake's fixed part (the transport and the probes are linear in the direct light).
  if (!data->fixed_direct.empty()) {
    for (std::size_t i = 0; i < leaves; ++i) {
      map.direct[i] += data->fixed_direct[i];
      map.irradiance[i] += data->fixed_indirect[i];
    }
    for (std::size_t i = 0; i < map.probes.size(); ++i) map.probes[i] += data->fixed_probes[i];
  }
  map.updated_tick = world.tick();
  return true;
}

void register_indirect_transport_system(World& world) {
  SystemDesc desc;
  desc.name = "indirect-transport";
  desc.phase = Phase::Lighting;
  desc.reads = {component_id<Light>(), component_id<WorldTransform>(), component_id<DynamicLight>(),
                component_id<IndirectTransport>()};
  desc.writes = {component_id<IndirectLightmap>()};
  desc.run = [](World& w, const SystemContext&) {
    auto updated = update_indirect_transport(w);
    TransportState& state = w.resource<TransportState>();
    if (!updated) {
      if (updated.error().message != state.last_error) log(LogLevel::Warning, updated.error().message);
      state.last_error = updated.error().message;
    } else {
      state.last_error.clear();
    }
  };
  world.add_system(std::move(desc));
}

namespace {

// At most six distinct face directions: floors, walls, boxes (what the transport's planar charts
// parameterise well); curved meshes have more.
bool planar_faced(const MeshData& mesh) {
  std::vector<glm::vec3> directions;
  for (std::size_t t = 0; t + 2 < mesh.indices.size(); t += 3) {
    const glm::vec3 a = mesh.positions[mesh.indices[t]], b = mesh.positions[mesh.indices[t + 1]],
                    c = mesh.positions[mesh.indices[t + 2]];
    const glm::vec3 n = glm::cross(b - a, c - a);
    if (!(glm::length(n) > 0.0f)) continue;
    const glm::vec3 u = glm::normalize(n);
    if (std::none_of(directions.begin(), directions.end(), [&](glm::vec3 d) { return glm::dot(d, u) > 0.9998f; })) {
      directions.push_back(u);
      if (directions.size() > 6) return false;
    }
  }
  return !directions.empty();
}

}  // namespace

std::size_t add_default_indirect_transport(World& world, Preset preset) {
  // The receivers: static meshes the planar charts parameterise.
  std::vector<Entity> receivers;
  for (Entity e : world.view<Static, Mesh>().sorted_entities()) {
    const Mesh& mesh = world.get<Mesh>(e);
    if (mesh.data && planar_faced(*mesh.data)) receivers.push_back(e);
  }
  if (receivers.empty()) return 0;
  // The lights whose bounce the lightmap carries: every local light (point, spot, rect), moving
  // or not, since a texel holds light at the surface's own resolution, which the probe grid's
  // cells cannot (on the Cornell box the grid left the short block's front, which faces the
  // open side, 1.05x bright with a 17 % median error; the lightmap 0.996x and 3.1 %: penumbra
  // bench image-accuracy).
  // A rect light (a window, a panel) that no clip animates is fixed: its bounce is baked into the
  // lightmap, and a scene of fixed lights needs no operator (the Cornell box at medium: 941 KiB in
  // 4.8 s; with the light set to move, 57.6 MB in 12.6 s).
  // Point and spot lights (lanterns, torches) move.
  std::vector<Entity> lights;
  world.view<Light>().each([&](Entity e, Light& light) {
    if (light.type != Light::Type::Directional) lights.push_back(e);
  });
  if (lights.empty()) return 0;
  std::vector<Entity> animated;  // every clip's targets
  world.view<Animator>().each([&](Entity, Animator& a) {
    if (a.clips)
      for (const AnimationClip& clip : *a.clips) animated.insert(animated.end(), clip.targets.begin(), clip.targets.end());
  });
  const auto is_animated = [&](Entity e) {
    for (std::size_t depth = 0; e && world.alive(e) && depth < 1024; ++depth) {
      if (std::find(animated.begin(), animated.end(), e) != animated.end()) return true;
      const Parent* p = world.try_get<Parent>(e);
      e = p ? p->entity : Entity::null();
    }
    return false;
  };
  for (Entity e : lights)
    if (!world.has<DynamicLight>(e))
      world.add<DynamicLight>(e, DynamicLight{.enabled = true,
                                              .moves = world.get<Light>(e).type != Light::Type::Rect || is_animated(e)});
  for (Entity e : receivers)
    if (!world.has<IndirectReceiver>(e)) world.add<IndirectReceiver>(e);
  Entity root = receivers.front();
  while (const Parent* p = world.try_get<Parent>(root)) {
    if (!world.alive(p->entity)) break;
    root = p->entity;
  }
  if (!world.has<IndirectTransport>(root)) world.add<IndirectTransport>(root, IndirectTransport::preset(preset));
  return receivers.size();
}

// ---------------------------------------------------------------------------------------------
// The descriptor.

namespace {

Status attach_transport(World& world, const BakeChunk& chunk, const EntityKeys& keys) {
  auto read = read_transport_chunk(chunk);
  if (!read) return read.error();
  auto e = keyed_owner<IndirectTransport>(world, keys, read->key, "chunk 'WRTO'", "IndirectTransport");
  if (!e) return e.error();
  world.patch<IndirectTransport>(*e).data = std::make_shared<const TransportData>(std::move(read->data));
  return {};
}

std::vector<std::string> describe_transport(const BakeChunk& chunk) {
  auto read = read_transport_chunk(chunk);
  if (!read) return {read.error().message};
  const TransportData& d = read->data;
  char line[240];
  std::vector<std::string> out;
  std::snprintf(line, sizeof line, "'%s': %zu patches, %u leaf texels, finest level %u, refinement threshold %.3g",
                read->key.c_str(), d.patches.size(), d.leaf_count(), d.finest_level,
                static_cast<double>(d.refinement_threshold));
  out.emplace_back(line);
  std::snprintf(line, sizeof line,
                "direct operator: %llu links, %llu coefficients; global: %llu coefficients (%.3g MB), %u Neumann terms, "
                "last term %.3g of the sum%s",
                static_cast<unsigned long long>(d.links), static_cast<unsigned long long>(d.direct_nonzeros),
                static_cast<unsigned long long>(d.global.nonzeros()), double(d.global.bytes()) / 1e6, d.terms,
                static_cast<double>(d.last_term_ratio),
                d.converged ? "" : " (NOT converged: raise max_bounces or lower the albedo)");
  out.emplace_back(line);
  if (!d.fixed_direct.empty())
    out.emplace_back(std::string("fixed lights' bounce baked into the lightmap (") +
                     (d.moving_lights ? "the global operator kept for the moving lights)"
                                      : "no light moves: the global operator is not kept)"));
  const TransportProbes& probes = d.probes;
  const auto open = static_cast<std::size_t>(std::count(probes.open.begin(), probes.open.end(), std::uint8_t{1}));
  const std::string seen = d.moving_lights ? std::to_string(probes.entries.size()) + " cells seen"
                                           : std::string("the fixed lights' light baked");
  std::snprintf(line, sizeof line,
                "bounce probes (moving objects): %ux%ux%u every %.3g m, %zu open, %s, %.3g MB, %u rays each",
                probes.count.x, probes.count.y, probes.count.z, static_cast<double>(probes.spacing), open,
                seen.c_str(), double(probes.bytes()) / 1e6, probes.rays);
  out.emplace_back(line);
  return out;
}

std::string explain_empty(World& world) {
  const std::size_t transports = world.view<const IndirectTransport>().count();
  const std::size_t receivers = world.view<const IndirectReceiver>().count();
  if (transports == 0)
    return "indirect-transport bakes a scene with an IndirectTransport entity and this one has none (a built-in "
           "scene with a point, spot or rect light and a static planar mesh gets one; add it, IndirectReceiver on "
           "the static meshes and DynamicLight on the lights whose bounce it should carry)";
  return "indirect-transport found " + std::to_string(transports) + " IndirectTransport entities but " +
         std::to_string(receivers) + " IndirectReceiver meshes with planar charts to bake";
}

Status add_defaults(World& world, Preset preset, bool authored) {
  if (!authored) add_default_indirect_transport(world, preset);
  return {};
}

constexpr std::uint32_t kChunkTypes[] = {kTransportChunkType};

}  // namespace

const LightingModule& indirect_transport_module() {
  static const ComponentInfo* const components[] = {&indirect_transport_info(), &indirect_receiver_info(),
                                                    &dynamic_light_info()};
  static const LightingModule module{
      .name = "indirect-transport",
      .description = "bounce light of local lights on static surfaces, live as they move, baked for fixed ones "
                     "(wavelet radiance transport, Kontkanen et al. 2006)",
      .chunk_types = kChunkTypes,
      .components = components,
      .register_runtime = register_indirect_transport_system,
      .chunk_key = leading_chunk_key,
      .attach = attach_transport,
      .check = check_with<read_transport_chunk>,
      .describe = describe_transport,
      .add_defaults = add_defaults,
      .explain_empty = explain_empty,
  };
  return module;
}

}  // namespace penumbra
