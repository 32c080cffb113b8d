// Bake state per lighting component: whether the data a bake made for it still matches the scene
// (the Bake panel's list, the inspector's line, the script's expect-bake).
//
// A bake records what it read when it starts (BakeTracker::begin, main thread, the live World):
// per authoring component (the module component with presets, e.g. an IrradianceProbeGrid) the
// hash of its hashed fields and of its world transform, the module's bake inputs
// (Baker::hash_inputs with the preset and seed) and every scene input (scene_inputs in
// penumbra/bake/baker.h: each mesh, light and the sky). When the bake is done, commit() keeps
// the record of each component it baked; states() compares the records with the World as it is
// now and says what changed. A module without an authoring component (vertex AO) gets one state
// for the whole module.
#pragma once

#include <cstdint>
#include <map>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "penumbra/bake/baker.h"
#include "penumbra/ecs/world.h"

namespace penumbra::editor {

enum class Freshness : std::uint8_t {
  NeverBaked,  // no bake in this session made or loaded its data
  UpToDate,    // nothing it was baked from has changed
  OutOfDate,   // BakeState::why says what changed
  Loaded,      // its data came from a .pbake file, which does not say what it was baked from
};
// "never baked", "up to date", "out of date", "loaded"; the script's words are these with '-'.
const char* to_string(Freshness f);

struct BakeState {
  std::string module;        // the baker, e.g. "probe-grid"
  Entity entity;             // the component's entity; null for a module-wide state
  std::string component;     // the authoring component's type name; empty when module-wide
  Freshness freshness = Freshness::NeverBaked;
  // OutOfDate: what changed since the bake, e.g. "light 'lamp' changed; its settings changed",
  // "its transform changed" (when its module reads the transform)
  // (at most three scene inputs named, then how many more). Loaded: the file's name.
  std::string why;
  double seconds = 0.0;      // the module's time in the bake that made the data (0 when loaded)
  std::uint64_t bytes = 0;   // the module's chunk bytes in that bake
};

class BakeTracker {
 public:
  struct Record {
    std::string component;
    std::uint64_t fields = 0;         // hash_fields of the component (0 when module-wide)
    std::uint64_t transform = 0;      // its entity's WorldTransform
    std::uint64_t module_inputs = 0;  // the module's hash_inputs, preset and seed
    Preset preset = Preset::Medium;
    std::uint64_t seed = 0;
    std::shared_ptr<const std::vector<SceneInput>> scene;
    double seconds = 0.0;
    std::uint64_t bytes = 0;
    std::string file;  // set when loaded from a .pbake: then nothing else is known
    // In a pending bake: a sibling left out of a selection bake, whose record only takes the
    // module's new inputs.
    bool refresh_only = false;
  };
  // Records by (module, entity key); the key is empty for a module-wide record.
  using Records = std::map<std::pair<std::string, std::string>, Record>;

  // What a bake of `bakers` (every registered baker when empty) over the components of `entities`
  // (all when empty) reads, from the live World at its start; for a selection bake also the
  // module's other components whose own inputs are as baked, which take the module's new inputs
  // (their siblings' changes alone moved them). Cost: hash_scene plus each baked module's
  // hash_inputs.
  Records begin(World& world, const std::vector<std::string>& bakers, const std::vector<Entity>& entities,
                const BakeSettings& settings) const;
  // The bake of `pending` finished: its records replace those of the same components, with the
  // report's time and bytes per module (a selection bake's siblings keep theirs).
  void commit(Records pending, const BakeReport& report);
  // A .pbake file was attached: every component of a module with chunks in it is Loaded from
  // `file_name` (replacing what was recorded).
  void loaded(World& world, const BakeFile& file, const std::string& file_name);

  // One state per authoring component in the World and per module without one, in module order,
  // then entity order. Cost: scene_inputs plus each module's hash_inputs; the UI calls it a few
  // times a second, not per frame.
  std::vector<BakeState> states(World& world, const BakeSettings& settings) const;

 private:
  Records records_;
};

}  // namespace penumbra::editor
