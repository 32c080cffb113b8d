// Baker registry, input hashing and the bake driver shared by every technique.
#include "penumbra/bake/baker.h"

#include <algorithm>
#include <chrono>

#include "penumbra/bake/ray_scene.h"
#include "drive.h"
#include "penumbra/core/version.h"
#include "penumbra/ecs/transform.h"
#include "penumbra/scene/components.h"

namespace penumbra {

double seconds_since(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

Baker baker_for(const LightingModule& module) {
  Baker b;
  b.name = std::string(module.name);
  b.description = std::string(module.description);
  b.describe = module.describe;
  b.attach = module.attach;
  b.check = module.check;
  b.chunk_key = module.chunk_key;
  return b;
}

Result<std::string> bake_key(const BakeInputs& in, Entity e, std::string_view what) {
  std::string key = entity_key(in.world, e);
  const std::string where(what);
  if (key.empty())
    return make_error(ErrorCode::InvalidInput, where + " has neither a Name nor an EntityKey, so its baked data "
                                                       "could not find it again; name the entity or set an EntityKey");
  auto found = in.keys.find(key, where);
  if (!found) return found.error();
  if (*found != e)
    return make_error(ErrorCode::InvalidInput, where + ": its key '" + key + "' is another entity's; give it a unique "
                                                       "name or EntityKey");
  return key;
}

Result<std::vector<std::string>> bake_keys(const BakeInputs& in, const std::vector<Entity>& entities,
                                           std::string_view what) {
  std::vector<std::string> keys;
  keys.reserve(entities.size());
  for (Entity e : entities) {
    const Name* name = in.world.try_get<Name>(e);
    auto key = bake_key(in, e, std::string(what) + (name ? " '" + name->value + "'" : std::string()) + " (entity " +
                                   std::to_string(e.index) + ")");
    if (!key) return key.error();
    keys.push_back(std::move(*key));
  }
  return keys;
}

void BakerRegistry::add(Baker baker) {
  for (Baker& b : bakers_)
    if (b.name == baker.name) {
      b = std::move(baker);
      return;
    }
  bakers_.push_back(std::move(baker));
}

const Baker* BakerRegistry::find(std::string_view name) const {
  for (const Baker& b : bakers_)
    if (b.name == name) return &b;
  return nullptr;
}

namespace {

// What hash_scene adds for one entity with a Mesh (after its key). A movable or skinned mesh's
// world transform is left out: the bakers' shared ray scene holds the static geometry only, and a
// module that bakes a moving mesh in its own frame adds what it reads of the transform (AO
// fields: the scale; pose-AO: world up in the mesh frame, the character's meshes relative to
// each other), so an animated character or a pushed crate does not make a bake out of date.
void hash_mesh_entity(World& world, Entity e, Hasher& h) {
  const Mesh& mesh = world.get<Mesh>(e);
  if (mesh.data) {
    h.add(mesh.data->positions);
    h.add(mesh.data->normals);
    h.add(mesh.data->indices);
    h.add(mesh.data->joints);
    h.add(mesh.data->weights);
  }
  const bool still = world.has<Static>(e);
  if (const auto* wt = world.try_get<WorldTransform>(e); wt && still) h.add(wt->matrix);
  h.add(still);
  if (const auto* m = world.try_get<Material>(e)) {
    h.add(m->base_color);
    h.add(m->emissive);
    h.add(m->double_sided);
    if (m->base_color_texture) h.add(m->base_color_texture->rgba8);
  }
}

// What hash_scene adds for the sky: its radiance, or with a map the map's digest and scale (the
// authored path is left out: the same texels from another file bake the same).
void hash_environment(World& world, Hasher& h) {
  const Environment sky = world_environment(world);
  if (!sky.map_data) {
    h.add(sky.radiance);
    return;
  }
  h.add(sky.map_data->digest);
  h.add(sky.map_scale);
}

// What hash_scene adds for one entity with a Light (after its key). An enabled dynamic light's
// world transform is left out: the probe grid does not bake it, the indirect transport's operator
// does not depend on where it is, and the transport's own inputs hold a fixed one's place
// (DynamicLight::moves), so carrying a moving one around changes nothing baked.
void hash_light_entity(World& world, Entity e, Hasher& h) {
  hash_light(world.get<Light>(e), h);
  const DynamicLight* d = world.try_get<DynamicLight>(e);
  if (const auto* wt = world.try_get<WorldTransform>(e); wt && !(d && d->enabled)) h.add(wt->matrix);
  h.add(static_cast<std::uint8_t>(d == nullptr ? 0 : d->enabled ? 1 : 2));
}

}  // namespace

void hash_light(const Light& l, Hasher& h) {
  h.add(l.type);
  h.add(l.color);
  h.add(l.intensity);
  h.add(l.range);
  h.add(l.inner_cone_angle);
  h.add(l.outer_cone_angle);
  h.add(l.size);
}

void hash_scene(World& world, Hasher& h) {
  for (Entity e : world.view<Mesh>().sorted_entities()) {
    h.add(std::string_view(entity_key(world, e)));
    hash_mesh_entity(world, e, h);
  }
  hash_environment(world, h);
  for (Entity e : world.view<Light>().sorted_entities()) {
    h.add(std::string_view(entity_key(world, e)));
    hash_light_entity(world, e, h);
  }
}

std::vector<SceneInput> scene_inputs(World& world) {
  std::vector<SceneInput> out;
  for (Entity e : world.view<Mesh>().sorted_entities()) {
    Hasher h;
    hash_mesh_entity(world, e, h);
    out.push_back({entity_key(world, e), SceneInput::Kind::Mesh, h.digest()});
  }
  for (Entity e : world.view<Light>().sorted_entities()) {
    Hasher h;
    hash_light_entity(world, e, h);
    out.push_back({entity_key(world, e), SceneInput::Kind::Light, h.digest()});
  }
  Hasher sky;
  hash_environment(world, sky);
  out.push_back({"environment", SceneInput::Kind::Environment, sky.digest()});
  return out;
}

Result<std::vector<const Baker*>> select_bakers(const BakerRegistry& registry, const std::vector<std::string>& names) {
  std::vector<const Baker*> selected;
  for (const std::string& name : names) {
    if (registry.find(name) == nullptr) {
      std::string known;
      for (const Baker& b : registry.all()) known += (known.empty() ? "" : ", ") + b.name;
      return make_error(ErrorCode::NotFound, "no baker named '" + name + "'; known bakers: " + known);
    }
  }
  for (const Baker& b : registry.all())
    if (names.empty() || std::find(names.begin(), names.end(), b.name) != names.end()) selected.push_back(&b);
  return selected;
}

std::uint64_t bake_input_hash(World& world, const std::vector<std::string>& names, const BakeSettings& settings) {
  Hasher h;
  h.add(std::string_view(sdk_version()));
  hash_scene(world, h);
  h.add(settings.preset);
  h.add(settings.seed);
  auto bakers = select_bakers(world.resource<BakerRegistry>(), names);
  if (bakers) {
    for (const Baker* b : *bakers) {
      h.add(std::string_view(b->name));
      if (b->hash_inputs) b->hash_inputs(world, settings, h);
    }
  }
  return h.digest();
}

Status drive_bake(World& world, const std::vector<const Baker*>& bakers, const BakeSettings& settings,
                  JobContext& jobs, BakeReport& report, const DriveStep& step) {
  int stages = 1;
  for (const Baker* b : bakers) stages += b->stages;
  jobs.set_stage_count(stages);

  // Build the ray scene once for every baker (static geometry; bakers bake what does not move).
  jobs.begin_stage("ray scene", 1);
  auto start = std::chrono::steady_clock::now();
  RaySceneOptions options;
  options.build_threads = jobs.concurrency();
  options.include_dynamic = false;
  auto rays = RayScene::build(world, options);
  if (!rays) return rays.error();
  jobs.advance(1);
  report.ray_scene_seconds = seconds_since(start);
  report.ray_scene_bytes = rays->bvh_bytes();
  report.triangles = rays->triangle_count();

  MemoryBudget budget(settings.memory_limit_bytes);
  const EntityKeys keys = EntityKeys::build(world);
  for (const Baker* b : bakers) {
    if (jobs.cancelled()) return make_error(ErrorCode::Cancelled, "the bake was cancelled");
    start = std::chrono::steady_clock::now();
    BakeInputs inputs{world, *rays, settings, jobs, budget, keys};
    auto work = b->plan(inputs);
    if (!work) return Error{work.error().code, b->name + ": " + work.error().message};
    BakeReport::Item item;
    item.baker = b->name;
    if (Status s = step(*b, *work, item); !s) return Error{s.error().code, b->name + ": " + s.error().message};
    item.seconds = seconds_since(start);
    report.items.push_back(std::move(item));
  }
  return {};
}

Result<std::vector<BakeChunk>> finish_groups(const Baker& baker, const std::vector<BakeGroup>& groups,
                                             const std::vector<std::vector<std::byte>>& results, JobContext& jobs) {
  std::vector<BakedGroup> baked(groups.size());
  for (std::size_t g = 0; g < groups.size(); ++g) baked[g] = BakedGroup{&groups[g], results[g]};
  return baker.finish(baked, jobs);
}

Result<BakeResult> bake_world(World& world, const std::vector<std::string>& names, const BakeSettings& settings,
                              JobContext& jobs) {
  auto bakers = select_bakers(world.resource<BakerRegistry>(), names);
  if (!bakers) return bakers.error();
  if (bakers->empty()) return make_error(ErrorCode::NotFound, "no baker is registered; link a lighting module");

  BakeResult result;
  result.file.input_hash = bake_input_hash(world, names, settings);
  result.file.sdk_version = std::string(sdk_version());
  const EntityKeys keys = EntityKeys::build(world);
  // Every group whole, then the global steps: what `penumbra merge` does with the parts of a
  // sharded bake.
  const auto bake_whole = [&](const Baker& b, BakeWork& work, BakeReport::Item& item) -> Status {
    std::vector<std::vector<std::byte>> results(work.groups.size());
    for (std::size_t g = 0; g < work.groups.size(); ++g) {
      if (work.groups[g].elements == 0) continue;
      auto r = work.run(g, 0, work.groups[g].elements, jobs);
      if (!r) return r.error();
      results[g] = std::move(*r);
    }
    auto chunks = finish_groups(b, work.groups, results, jobs);
    if (!chunks) return chunks.error();
    for (BakeChunk& chunk : *chunks) {
      item.bytes += chunk.payload.size();
      if (b.describe)
        for (auto& line : b.describe(chunk)) item.lines.push_back(std::move(line));
      // What the file holds is what the World shows.
      if (b.attach) PENUMBRA_TRY(b.attach(world, chunk, keys));
      result.file.chunks.push_back(std::move(chunk));
    }
    return {};
  };
  PENUMBRA_TRY(drive_bake(world, *bakers, settings, jobs, result.report, bake_whole));
  return result;
}

}  // namespace penumbra
