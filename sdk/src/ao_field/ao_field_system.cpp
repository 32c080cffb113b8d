// Ambient-occlusion field runtime (see ao_field_system.h): per receiver, the multiplicative
// combination of the casters in range (Kontkanen & Laine 2005, section 3.3).
#include "penumbra/ao_field/ao_field_system.h"

#include <algorithm>
#include <cmath>
#include <vector>

#include <glm/geometric.hpp>
#include <glm/matrix.hpp>

#include "penumbra/ao_field/ao_field.h"
#include "penumbra/ecs/transform.h"
#include "penumbra/scene/components.h"

namespace penumbra {

namespace {

// A baked caster as this update sees it: the world-to-local matrix computed once.
struct ActiveCaster {
  const AOFieldData* data;
  Entity entity;
  glm::mat4 world_to_local;
  glm::vec3 centre;  // field centre, world space
  float reach;       // r_far in world units
};

// The system's memory between runs: how many casters were active (a removal changes it).
struct AOFieldSystemState {
  std::size_t casters = 0;
};

}  // namespace

std::size_t update_ao_field_receivers(World& world, std::uint64_t since) {
  // The pools looked up per entity, found once.
  const ComponentPool<WorldTransform> transforms = world.pool<WorldTransform>();
  const ComponentPool<AOFieldCaster> caster_pool = world.pool<AOFieldCaster>();
  const ComponentPool<AOFieldReceiver> receiver_pool = world.pool<AOFieldReceiver>();
  std::vector<ActiveCaster> casters;
  bool casters_changed = false;
  world.view<AOFieldCaster, WorldTransform>().each([&](Entity e, AOFieldCaster& c, WorldTransform& wt) {
    if (caster_pool.changed_tick(e) > since || transforms.changed_tick(e) > since) casters_changed = true;
    if (!c.data) return;
    const glm::mat4& m = wt.matrix;
    const float scale = glm::length(glm::vec3(m[0]));
    const glm::mat4 inv = glm::inverse(m);
    if (!(scale > 0.0f) || !std::isfinite(inv[0][0])) return;  // a degenerate transform casts nothing
    casters.push_back({c.data.get(), e, inv, glm::vec3(m * glm::vec4(c.data->centre, 1.0f)), c.data->r_far * scale});
  });
  std::sort(casters.begin(), casters.end(),
            [](const ActiveCaster& a, const ActiveCaster& b) { return a.entity.index < b.entity.index; });
  auto& state = world.resource<AOFieldSystemState>();
  if (state.casters != casters.size()) casters_changed = true;
  state.casters = casters.size();

  std::vector<Entity> receivers;
  world.view<AOFieldReceiver, WorldTransform>().each([&](Entity e, AOFieldReceiver& r, WorldTransform&) {
    if (r.mode != AOFieldReceiver::Mode::Entity) return;  // surfaces: the renderer's per-pixel pass
    if (casters_changed || transforms.changed_tick(e) > since || receiver_pool.changed_tick(e) > since)
      receivers.push_back(e);
  });

  // Receiver points and unit normals (a zero normal for a degenerate one: it stays open).
  std::vector<glm::vec3> xs(receivers.size()), ns(receivers.size());
  for (std::size_t i = 0; i < receivers.size(); ++i) {
    const glm::mat4& m = transforms.get(receivers[i]).matrix;
    xs[i] = glm::vec3(m[3]);
    const glm::vec3 nw = glm::mat3(m) * receiver_pool.get(receivers[i]).normal;
    const float len = glm::length(nw);
    ns[i] = len > 0.0f && std::isfinite(len) ? nw / len : glm::vec3(0.0f);
  }
  // Per caster, the receivers in its reach in one batch: open = prod (1 - A_i).
  std::vector<float> open(receivers.size(), 1.0f);
  std::vector<std::size_t> in_range;
  std::vector<glm::vec3> bx, bn;
  std::vector<float> bopen;
  for (const ActiveCaster& c : casters) {
    in_range.clear();
    for (std::size_t i = 0; i < receivers.size(); ++i)
      if (receivers[i] != c.entity && glm::distance(xs[i], c.centre) < c.reach) in_range.push_back(i);
    bx.resize(in_range.size());
    bn.resize(in_range.size());
    bopen.assign(in_range.size(), 1.0f);
    for (std::size_t k = 0; k < in_range.size(); ++k) {
      bx[k] = xs[in_range[k]];
      bn[k] = ns[in_range[k]];
    }
    accumulate_open(*c.data, c.world_to_local, bx, bn, bopen);
    for (std::size_t k = 0; k < in_range.size(); ++k) open[in_range[k]] *= bopen[k];
  }
  for (std::size_t i = 0; i < receivers.size(); ++i) {
    AOFieldReceiver& r = world.patch<AOFieldReceiver>(receivers[i]);
    r.occlusion = std::clamp(1.0f - open[i], 0.0f, 1.0f);
    r.updated_tick = world.tick();
  }
  return receivers.size();
}

void register_ao_field_system(World& world) {
  SystemDesc desc;
  desc.name = "ao-field";
  desc.phase = Phase::Lighting;
  desc.reads = {component_id<WorldTransform>(), component_id<AOFieldCaster>()};
  desc.writes = {component_id<AOFieldReceiver>()};
  desc.run = [](World& w, const SystemContext& ctx) { update_ao_field_receivers(w, ctx.last_run); };
  world.add_system(std::move(desc));
}

std::size_t add_default_ao_field_casters(World& world, Preset preset) {
  std::size_t added = 0;
  for (Entity e : world.view<Mesh, WorldTransform>().sorted_entities()) {
    if (!world.get<Mesh>(e).data) continue;
    const bool is_static = world.has<Static>(e), skinned = world.has<Skin>(e);
    if (!is_static && !skinned && !world.has<AOFieldCaster>(e)) {
      const AOFieldCaster caster = AOFieldCaster::preset(preset);
      if (validate_ao_field_caster(caster, world.get<WorldTransform>(e).matrix, "ao field").ok()) {
        world.add<AOFieldCaster>(e, caster);
        ++added;
      }
    }
    if ((is_static || skinned) && !world.has<AOFieldReceiver>(e)) {
      AOFieldReceiver r;
      r.mode = is_static ? AOFieldReceiver::Mode::Surface : AOFieldReceiver::Mode::Entity;
      world.add<AOFieldReceiver>(e, r);
    }
  }
  return added;
}

namespace {

Status attach_ao_field(World& world, const BakeChunk& chunk, const EntityKeys& keys) {
  auto data = read_ao_field_chunk(chunk);
  if (!data) return data.error();
  auto e = keyed_owner<AOFieldCaster>(world, keys, data->key, "chunk 'AOFC' (" + chunk.label + ")", "AOFieldCaster");
  if (!e) return e.error();
  world.patch<AOFieldCaster>(*e).data = std::make_shared<const AOFieldData>(std::move(*data));
  return {};
}

// Built-in scenes: their movable crates cast AO fields.
Status add_defaults(World& world, Preset preset, bool authored) {
  if (!authored) add_default_ao_field_casters(world, preset);
  return {};
}

constexpr std::uint32_t kChunkTypes[] = {kAOFieldChunkType};

std::string explain_empty(World& world) {
  return "ao-field bakes entities with an AOFieldCaster and this scene has " +
         std::to_string(world.view<const AOFieldCaster>().count()) +
         " (the built-in scenes give one to each movable mesh; in a glTF file, declare one on a movable mesh's "
         "node: \"extensions\": {\"PENUMBRA_lighting\": {\"version\": 1, \"components\": {\"AOFieldCaster\": "
         "{\"preset\": \"medium\"}}}}, or add it in the editor or from code)";
}

}  // namespace

const LightingModule& ao_field_module() {
  static const ComponentInfo* const components[] = {&ao_field_caster_info(), &ao_field_receiver_info()};
  static const LightingModule module{
      .name = "ao-field",
      .description = "ambient occlusion fields of moving rigid casters (Kontkanen & Laine 2005)",
      .chunk_types = kChunkTypes,
      .components = components,
      .register_runtime = register_ao_field_system,
      .chunk_key = leading_chunk_key,
      .attach = attach_ao_field,
      .check = check_with<read_ao_field_chunk>,
      .describe = describe_ao_field_chunk,
      .add_defaults = add_defaults,
      .explain_empty = explain_empty,
  };
  return module;
}

}  // namespace penumbra
