// Bakers: the offline half of every lighting technique. A module registers its Baker with a
// World's BakerRegistry (register_bakers() in penumbra/bakers.h registers every module's);
// `bake_world` builds the RayScene once, runs the selected bakers in registration order and
// collects their chunks into a BakeFile (penumbra/core/pbake.h), which attach_bake()
// (penumbra/runtime.h) loads back through the same modules.
#pragma once

#include <cstdint>
#include <functional>
#include <string>
#include <string_view>
#include <vector>

#include "penumbra/core/pbake.h"
#include "penumbra/core/hash.h"
#include "penumbra/core/jobs.h"
#include "penumbra/core/memory.h"
#include "penumbra/core/result.h"
#include "penumbra/ecs/world.h"
#include "penumbra/lighting/module.h"
#include "penumbra/lighting/settings.h"
#include "penumbra/scene/entity_key.h"

namespace penumbra {

class RayScene;

struct BakeSettings {
  Preset preset = Preset::Medium;
  std::uint64_t seed = 1;
  std::uint64_t memory_limit_bytes = 0;  // 0: unlimited
};

// What a baker receives. `jobs` already carries the host's scheduler, progress and cancellation;
// a baker opens its own stages with jobs.begin_stage().
struct BakeInputs {
  World& world;
  const RayScene& rays;
  const BakeSettings& settings;
  JobContext& jobs;
  MemoryBudget& budget;
  const EntityKeys& keys;  // every keyed entity of the World, for bake_key()
};

// The stable key (scene/entity_key.h) that a chunk names entity `e` by. InvalidInput naming `what`
// (the entity, e.g. "probe grid 'hall' (entity 12)") when it has no key or shares it with another
// entity: give it a unique Name or an EntityKey.
Result<std::string> bake_key(const BakeInputs& in, Entity e, std::string_view what);
// bake_key of each of `entities`, before any ray is traced: the first without a unique key fails
// the bake, named as "<what> '<Name>' (entity <index>)".
Result<std::vector<std::string>> bake_keys(const BakeInputs& in, const std::vector<Entity>& entities,
                                           std::string_view what);

struct Baker {
  std::string name;         // the module's name, what `--only` names, e.g. "vertex-ao"
  std::string description;  // one line for `penumbra bake --help`
  int stages = 1;           // how many progress stages bake() opens
  // Adds everything bake() reads (scene content it depends on, its settings) to the input hash,
  // so that an unchanged scene is not baked again.
  std::function<void(World&, const BakeSettings&, Hasher&)> hash_inputs;
  std::function<Result<std::vector<BakeChunk>>(BakeInputs&)> bake;
  // Human-readable lines about one of its chunks (the module's describe, LightingModule).
  std::function<std::vector<std::string>(const BakeChunk&)> describe;
};

// A Baker with the module's name, description and describe(); the module sets the rest.
Baker baker_for(const LightingModule& module);

// The bakers a World knows: world.resource<BakerRegistry>().
class BakerRegistry {
 public:
  void add(Baker baker);
  const Baker* find(std::string_view name) const;
  const std::vector<Baker>& all() const { return bakers_; }

 private:
  std::vector<Baker> bakers_;
};

// Hashes the geometry, materials, lights and transforms of every entity with a Mesh or Light, with
// its entity key, in entity order: the part of the input hash that every baker shares.
void hash_scene(World& world, Hasher& hasher);

// The input hash of a bake of `names` with `settings` (the seed included, the thread count not).
std::uint64_t bake_input_hash(World& world, const std::vector<std::string>& names, const BakeSettings& settings);

// What a bake did: per baker, the wall time, the bytes of its chunks and its description lines.
struct BakeReport {
  struct Item {
    std::string baker;
    double seconds = 0.0;
    std::uint64_t bytes = 0;
    std::vector<std::string> lines;
  };
  double ray_scene_seconds = 0.0;
  std::uint64_t ray_scene_bytes = 0;
  std::size_t triangles = 0;
  std::vector<Item> items;
};

struct BakeResult {
  BakeFile file;
  BakeReport report;
};

// Runs the named bakers (all registered ones when `names` is empty). Fails naming an unknown baker
// and listing the known ones. The World must be up to date (world transforms computed).
Result<BakeResult> bake_world(World& world, const std::vector<std::string>& names, const BakeSettings& settings,
                              JobContext& jobs);

}  // namespace penumbra
