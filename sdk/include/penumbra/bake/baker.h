// Bakers: the offline half of every lighting technique. A module registers its Baker with a
// World's BakerRegistry (register_bakers() in penumbra/bakers.h registers every module's);
// `bake_world` builds the RayScene once, runs the selected bakers in registration order and
// collects their chunks into a BakeFile (penumbra/core/pbake.h), which attach_bake()
// (penumbra/runtime.h) loads back through the same modules.
//
// Every bake runs in two steps, so that it can be split over machines (penumbra/bake/shard.h):
//   plan + run   from the scene: groups of independent elements (probe nodes, AO-field texels,
//                reference poses, vertices), each element's results a function of its own index;
//   finish       from the results alone, without the scene: what needs every element together
//                (a neighbour fill, a least-squares fit), ending in the chunks.
// A single-machine bake runs each whole group and finishes; a shard runs some blocks of some
// groups (its work items) and `penumbra merge` finishes, so both give the same bytes.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <span>
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
struct Light;

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

// One group of a baker's work: `elements` independent units whose results each depend on the
// element's index alone. A work item, the unit a shard takes, is a block of `block` consecutive
// elements; item ids ("probe-grid:hall#3") are stable whatever the thread or shard count.
struct BakeGroup {
  std::string name;             // unique within the baker: the entity key of what it bakes
  std::uint64_t elements = 0;
  std::uint64_t block = 1;      // elements per work item, >= 1: a constant of the baker
  double element_cost = 1.0;    // estimated cost of one element (rays traced), to balance shards
  std::vector<std::byte> header;  // what finish() needs besides the results (layouts, settings)
};

// A planned bake: the groups, and how to bake a range of a group's elements.
struct BakeWork {
  std::vector<BakeGroup> groups;
  // The results of elements [begin, end) of groups[group] (begin < end <= elements), each
  // element's bytes a function of its index alone, concatenated in element order: the results of
  // consecutive ranges, concatenated, are the results of their union. Opens its own progress
  // stage. Valid while the BakeInputs given to plan() live.
  std::function<Result<std::vector<std::byte>>(std::size_t group, std::uint64_t begin, std::uint64_t end,
                                               JobContext& jobs)>
      run;
};

// A group and the results of all its elements, in element order: what finish() reads.
struct BakedGroup {
  const BakeGroup* group = nullptr;
  std::span<const std::byte> results;
};

struct Baker {
  std::string name;         // the module's name, what `--only` names, e.g. "vertex-ao"
  std::string description;  // one line for `penumbra bake --help`
  int stages = 1;           // how many progress stages run() and finish() open
  // Whether the bake reads the scene's lights and sky (the probe grid's does; the AO bakes do not,
  // and the transport reads only its fixed DynamicLights, which its hash_inputs holds): a change
  // of a light or the sky leaves the others' data valid (the editor's bake state). The input hash
  // holds the lights for every baker regardless.
  bool reads_lights = true;
  // Adds everything plan() reads (scene content it depends on, its settings) to the input hash,
  // so that an unchanged scene is not baked again.
  std::function<void(World&, const BakeSettings&, Hasher&)> hash_inputs;
  // Checks the scene's components and plans the work; no group when there is nothing to bake.
  std::function<Result<BakeWork>(BakeInputs&)> plan;
  // The chunks from every group's results (groups in plan order), without the scene: the global
  // steps, which `penumbra merge` runs. InvalidInput when results do not parse (a corrupt part).
  std::function<Result<std::vector<BakeChunk>>(std::span<const BakedGroup>, JobContext&)> finish;
  // Human-readable lines about one of its chunks (the module's describe, LightingModule).
  std::function<std::vector<std::string>(const BakeChunk&)> describe;
  // Attaches one of its chunks to the World (the module's attach, LightingModule).
  Status (*attach)(World& world, const BakeChunk& chunk, const EntityKeys& keys) = nullptr;
  // Reads one of its chunks with every check, attaching nothing (the module's check): what a merge
  // checks its output with, since parts come from other machines.
  Status (*check)(const BakeChunk& chunk) = nullptr;
  // The entity key one of its chunks belongs to, "" for a scene-wide chunk (the module's chunk_key;
  // null when its chunks name no entity).
  std::string (*chunk_key)(const BakeChunk& chunk) = nullptr;
};

// A Baker with the module's name, description, describe(), attach(), check() and chunk_key(); the
// module sets the rest.
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
// its entity key, in entity order: the part of the input hash that every baker shares. The world
// transforms of movable and skinned meshes and of enabled dynamic lights are not in it (no
// baker reads where they are; a module that reads part of one hashes that part itself).
void hash_scene(World& world, Hasher& hasher);
// A Light's own fields (type, colour, intensity, range, cone angles, size; not its place), as
// hash_scene adds them for each light: for a module that hashes a light itself. O(1).
void hash_light(const Light& light, Hasher& hasher);

// hash_scene's inputs one at a time, for telling what changed since a bake: one per entity with a
// Mesh, then one per entity with a Light (in entity order, each with its entity key and the hash
// of what hash_scene adds for it), then the environment (key "environment"). Cost: hash_scene's.
struct SceneInput {
  enum class Kind : std::uint8_t { Mesh, Light, Environment };
  std::string key;
  Kind kind = Kind::Mesh;
  std::uint64_t hash = 0;
  bool operator==(const SceneInput&) const = default;
};
std::vector<SceneInput> scene_inputs(World& world);

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

// The bakers `names` selects, in registration order (all when empty). NotFound naming an unknown
// baker and listing the known ones.
Result<std::vector<const Baker*>> select_bakers(const BakerRegistry& registry, const std::vector<std::string>& names);

// Runs the named bakers (all registered ones when `names` is empty): plans each, runs every group
// whole, finishes, and attaches the chunks to `world` (so it shows what the file holds). Fails
// naming an unknown baker and listing the known ones. The World must be up to date (world
// transforms computed).
Result<BakeResult> bake_world(World& world, const std::vector<std::string>& names, const BakeSettings& settings,
                              JobContext& jobs);

}  // namespace penumbra
