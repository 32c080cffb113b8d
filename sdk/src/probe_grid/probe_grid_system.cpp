// Probe-grid runtime: the lighting system for ProbeLit receivers, attaching baked grids, the
// default grid and the module descriptor (see probe_grid_system.h).
#include "penumbra/probe_grid/probe_grid_system.h"

#include <algorithm>
#include <cmath>
#include <string>
#include <utility>

#include <glm/common.hpp>

#include "penumbra/ecs/transform.h"
#include "penumbra/lighting/module.h"
#include "penumbra/scene/animation.h"

namespace penumbra {

namespace {

// The system's memory between runs: how many grids were active (a removal changes it).
struct ProbeGridSystemState {
  std::size_t grids = 0;
};

}  // namespace

std::vector<BlendedProbeGrid> blended_probe_grids(World& world) {
  std::vector<BlendedProbeGrid> grids;
  world.view<IrradianceProbeGrid>().each([&](Entity e, IrradianceProbeGrid& g) {
    if (!g.data) return;
    const float spacing = std::min({g.data->layout.spacing.x, g.data->layout.spacing.y, g.data->layout.spacing.z});
    grids.push_back({g.data, g.priority, e.index, g.blend_distance > 0.0f ? g.blend_distance : spacing});
  });
  std::sort(grids.begin(), grids.end(), [](const BlendedProbeGrid& a, const BlendedProbeGrid& b) {
    return a.priority != b.priority ? a.priority > b.priority : a.index < b.index;
  });
  return grids;
}

float probe_grid_coverage(const BlendedProbeGrid& g, glm::vec3 x) {
  const glm::vec3 u(g.data->layout.world_to_grid * glm::vec4(x, 1.0f));
  if (!(u.x >= 0.0f && u.y >= 0.0f && u.z >= 0.0f && u.x <= 1.0f && u.y <= 1.0f && u.z <= 1.0f)) return 0.0f;
  const glm::vec3 size = g.data->layout.spacing * glm::vec3(g.data->layout.resolution - 1u);
  const glm::vec3 border = glm::min(u, 1.0f - u) * size;
  const float d = std::min({border.x, border.y, border.z});
  return glm::clamp(d / g.blend, 1e-4f, 1.0f);
}

bool probe_grid_weights(std::span<const BlendedProbeGrid> grids, glm::vec3 x, std::vector<float>& weights) {
  weights.assign(grids.size(), 0.0f);
  float left = 1.0f;
  std::size_t last = grids.size();
  for (std::size_t i = 0; i < grids.size(); ++i) {
    const float f = probe_grid_coverage(grids[i], x);
    if (f <= 0.0f) continue;
    weights[i] = left * f;
    left -= weights[i];
    last = i;
  }
  if (last == grids.size()) return false;
  weights[last] += left;  // the last covering grid takes all that is left
  return true;
}

glm::vec3 probe_lit_position(const World& world, Entity e) {
  const glm::mat4& m = world.get<WorldTransform>(e).matrix;
  const Mesh* mesh = world.try_get<Mesh>(e);
  if (mesh == nullptr || !mesh->data || mesh->data->bounds.empty()) return glm::vec3(m[3]);
  const Aabb& b = mesh->data->bounds;
  return glm::vec3(m * glm::vec4(0.5f * (b.min + b.max), 1.0f));
}

std::size_t update_probe_lighting(World& world, std::uint64_t since) {
  // The pools looked up per entity, found once.
  const ComponentPool<WorldTransform> transforms = world.pool<WorldTransform>();
  const ComponentPool<ProbeLit> lits = world.pool<ProbeLit>();
  const ComponentPool<Mesh> meshes = world.pool<Mesh>();
  bool grids_changed = false;
  world.view<IrradianceProbeGrid>().each([&](Entity e, IrradianceProbeGrid&) {
    if (world.changed_tick<IrradianceProbeGrid>(e) > since || transforms.changed_tick(e) > since)
      grids_changed = true;
  });
  const std::vector<BlendedProbeGrid> grids = blended_probe_grids(world);
  auto& state = world.resource<ProbeGridSystemState>();
  if (state.grids != grids.size()) grids_changed = true;
  state.grids = grids.size();

  // The receivers to update: all when a grid changed, else those that moved or are new.
  std::vector<Entity> receivers;
  world.view<ProbeLit, WorldTransform>().each([&](Entity e, ProbeLit&, WorldTransform&) {
    if (grids_changed || transforms.changed_tick(e) > since || lits.changed_tick(e) > since ||
        meshes.changed_tick(e) > since)
      receivers.push_back(e);
  });

  std::vector<float> weights;
  for (Entity e : receivers) {
    const glm::vec3 x = probe_lit_position(world, e);
    const bool covered = probe_grid_weights(grids, x, weights);
    SH9rgb sum;
    bool l2 = false;
    for (std::size_t i = 0; i < grids.size(); ++i) {
      if (weights[i] <= 0.0f) continue;
      sum += interpolate(*grids[i].data, x) * weights[i];
      l2 = l2 || grids[i].data->sh_order == ProbeShOrder::L2;
    }
    ProbeLit& lit = world.patch<ProbeLit>(e);
    lit.covered = covered;
    lit.position = x;
    lit.irradiance = sum;
    lit.order = l2 ? ProbeShOrder::L2 : ProbeShOrder::L1;
    lit.updated_tick = world.tick();
  }
  return receivers.size();
}

void register_probe_grid_system(World& world) {
  SystemDesc desc;
  desc.name = "probe-grid";
  desc.phase = Phase::Lighting;
  desc.reads = {component_id<WorldTransform>(), component_id<IrradianceProbeGrid>()};
  desc.writes = {component_id<ProbeLit>()};
  desc.run = [](World& w, const SystemContext& ctx) { update_probe_lighting(w, ctx.last_run); };
  world.add_system(std::move(desc));
}

namespace {

// The static geometry's bounds, from the world-space corners of each mesh's local bounds.
Aabb static_bounds(World& world) {
  Aabb bounds;
  world.each<Static, Mesh, WorldTransform>([&](Static&, Mesh& m, WorldTransform& wt) {
    if (!m.data || m.data->bounds.empty()) return;
    for (int c = 0; c < 8; ++c) {
      const glm::vec3 corner((c & 1) ? m.data->bounds.max.x : m.data->bounds.min.x,
                             (c & 2) ? m.data->bounds.max.y : m.data->bounds.min.y,
                             (c & 4) ? m.data->bounds.max.z : m.data->bounds.min.z);
      bounds.extend(glm::vec3(wt.matrix * glm::vec4(corner, 1.0f)));
    }
  });
  return bounds;
}

// A level's bounds inset by 2% (at least 1 cm) per side, so that no node sits in a wall's surface.
Aabb inset_box(const Aabb& bounds) {
  const glm::vec3 inset = glm::max(0.02f * bounds.extent(), glm::vec3(0.01f));
  Aabb box;
  box.min = bounds.min + inset;
  box.max = glm::max(bounds.max - inset, box.min + 0.01f);
  return box;
}

}  // namespace

void fit_probe_grid(World& world, Entity e) {
  IrradianceProbeGrid* grid = world.try_get<IrradianceProbeGrid>(e);
  if (!grid) return;
  Aabb box = posed_bounds(world, e);
  if (!box.empty()) {
    const glm::vec3 grow = glm::max(0.1f * box.extent(), glm::vec3(0.05f));
    box.min -= grow;
    box.max += grow;
  } else if (const Aabb level = static_bounds(world); !level.empty()) {
    box = inset_box(level);
  } else if (const Aabb all = posed_bounds(world); !all.empty()) {
    box = inset_box(all);
  } else {
    return;
  }
  world.patch<IrradianceProbeGrid>(e).box = box;
}

Result<Entity> add_default_probe_grid(World& world, Preset preset) {
  Entity existing;
  world.view<IrradianceProbeGrid>().each([&](Entity e, IrradianceProbeGrid&) {
    if (!existing || e.index < existing.index) existing = e;
  });
  if (existing) return existing;
  const Aabb bounds = static_bounds(world);
  if (bounds.empty())
    return make_error(ErrorCode::InvalidInput, "add_default_probe_grid: the scene has no static geometry to cover; "
                                               "add a Static mesh or an IrradianceProbeGrid with an explicit box");
  IrradianceProbeGrid grid = IrradianceProbeGrid::preset(preset);
  grid.box = inset_box(bounds);
  const Entity e = world.create();
  world.add<Name>(e, Name{"probe grid"});
  world.add<IrradianceProbeGrid>(e, std::move(grid));
  world.add<Transform>(e);
  world.add<WorldTransform>(e);
  return e;
}

namespace {

Status attach_probe_grid(World& world, const BakeChunk& chunk, const EntityKeys& keys) {
  auto data = read_probe_grid_chunk(chunk);
  if (!data) return data.error();
  auto e = keyed_owner<IrradianceProbeGrid>(world, keys, data->key, "chunk 'PRBG' (" + chunk.label + ")",
                                            "IrradianceProbeGrid");
  if (!e) return e.error();
  world.patch<IrradianceProbeGrid>(*e).data = std::make_shared<const ProbeGridData>(std::move(*data));
  return {};
}

Status add_defaults(World& world, Preset preset, bool authored) {
  // A scene without static geometry (a character alone) has nothing for a grid to light.
  if (authored || static_bounds(world).empty()) return {};
  auto grid = add_default_probe_grid(world, preset);
  return grid ? Status{} : Status{grid.error()};
}

constexpr std::uint32_t kChunkTypes[] = {kProbeGridChunkType};

std::string explain_empty(World& world) {
  const std::size_t grids = world.view<const IrradianceProbeGrid>().count();
  if (grids == 0)
    return "probe-grid bakes entities with an IrradianceProbeGrid and this scene has none (the built-in scenes "
           "get one; in a glTF file, declare one on a node whose scale spans the grid's box: \"extensions\": "
           "{\"PENUMBRA_lighting\": {\"version\": 1, \"components\": {\"IrradianceProbeGrid\": {\"preset\": "
           "\"medium\"}}}}, or add it in the editor or from code)";
  return "probe-grid found " + std::to_string(grids) + " IrradianceProbeGrid entities but no Static geometry "
         "to bake them against";
}

}  // namespace

const LightingModule& probe_grid_module() {
  static const ComponentInfo* const components[] = {&irradiance_probe_grid_info(), &probe_lit_info()};
  static const LightingModule module{
      .name = "probe-grid",
      .description = "irradiance probe grids (SH per node, point, supersampled (Kontkanen & Laine 2006) or fitted)",
      .chunk_types = kChunkTypes,
      .components = components,
      .register_runtime = register_probe_grid_system,
      .chunk_key = leading_chunk_key,
      .attach = attach_probe_grid,
      .check = check_with<read_probe_grid_chunk>,
      .describe = describe_probe_grid_chunk,
      .add_defaults = add_defaults,
      .explain_empty = explain_empty,
  };
  return module;
}

}  // namespace penumbra
