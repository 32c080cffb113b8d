// Bake state per lighting component (bake_state.h).
#include "bake_state.h"

#include <algorithm>

#include "penumbra/ecs/transform.h"
#include "penumbra/lighting/fields.h"
#include "penumbra/runtime.h"
#include "penumbra/scene/entity_key.h"

namespace penumbra::editor {

const char* to_string(Freshness f) {
  switch (f) {
    case Freshness::NeverBaked: return "never baked";
    case Freshness::UpToDate: return "up to date";
    case Freshness::OutOfDate: return "out of date";
    case Freshness::Loaded: return "loaded";
  }
  return "?";
}

namespace {

// One lighting component the bake state covers: an authoring component on an entity, or a
// module without one (null entity, no info).
struct Subject {
  const LightingModule* module = nullptr;
  const ComponentInfo* info = nullptr;
  Entity entity;
};

std::vector<Subject> subjects(World& world) {
  std::vector<Entity> entities;
  for (std::uint32_t i = 0, seen = 0; seen < world.entity_count(); ++i) {
    const Entity e = world.find_entity(i);
    if (!e) continue;
    ++seen;
    entities.push_back(e);
  }
  std::vector<Subject> out;
  for (const LightingModule* m : lighting_modules()) {
    if (world.resource<BakerRegistry>().find(m->name) == nullptr) continue;
    const ComponentInfo* authoring = nullptr;
    for (const ComponentInfo* c : m->components)
      if (c->set_preset_fields != nullptr) {
        authoring = c;
        break;
      }
    if (authoring == nullptr) {
      out.push_back({m, nullptr, Entity::null()});
      continue;
    }
    for (Entity e : entities)
      if (authoring->present(world, e)) out.push_back({m, authoring, e});
  }
  return out;
}

std::uint64_t fields_hash(const World& world, const Subject& s) {
  if (s.info == nullptr) return 0;
  Hasher h;
  hash_fields(*s.info, s.info->find(world, s.entity), h);
  return h.digest();
}

std::uint64_t transform_hash(World& world, Entity e) {
  Hasher h;
  if (!e) return h.digest();
  if (const auto* wt = world.try_get<WorldTransform>(e)) h.add(wt->matrix);
  return h.digest();
}

std::uint64_t module_hash(World& world, const LightingModule& m, const BakeSettings& settings) {
  Hasher h;
  h.add(settings.preset);
  h.add(settings.seed);
  const Baker* baker = world.resource<BakerRegistry>().find(m.name);
  if (baker != nullptr && baker->hash_inputs) baker->hash_inputs(world, settings, h);
  return h.digest();
}

std::string key_of(World& world, const Subject& s) { return s.entity ? entity_key(world, s.entity) : std::string(); }

// "light 'lamp' changed", "mesh 'crate' added", ... for the scene inputs that differ (the lights
// and the sky only for a baker that reads them); at most three named, then how many more.
void scene_changes(const std::vector<SceneInput>& then, const std::vector<SceneInput>& now, bool lights,
                   std::vector<std::string>& out) {
  auto kind = [](SceneInput::Kind k) { return k == SceneInput::Kind::Mesh ? "mesh" : "light"; };
  auto counts = [lights](const SceneInput& in) { return lights || in.kind == SceneInput::Kind::Mesh; };
  std::vector<std::string> changes;
  for (const SceneInput& n : now) {
    if (!counts(n)) continue;
    const auto old = std::find_if(then.begin(), then.end(),
                                  [&](const SceneInput& t) { return t.kind == n.kind && t.key == n.key; });
    if (n.kind == SceneInput::Kind::Environment) {
      if (old == then.end() || old->hash != n.hash) changes.push_back("the sky changed");
    } else if (old == then.end()) {
      changes.push_back(std::string(kind(n.kind)) + " '" + n.key + "' added");
    } else if (old->hash != n.hash) {
      changes.push_back(std::string(kind(n.kind)) + " '" + n.key + "' changed");
    }
  }
  for (const SceneInput& t : then) {
    const auto same = [&](const SceneInput& n) { return n.kind == t.kind && n.key == t.key; };
    if (counts(t) && std::none_of(now.begin(), now.end(), same))
      changes.push_back(std::string(kind(t.kind)) + " '" + t.key + "' removed");
  }
  for (std::size_t i = 0; i < changes.size() && i < 3; ++i) out.push_back(changes[i]);
  if (changes.size() > 3) out.push_back("and " + std::to_string(changes.size() - 3) + " more scene changes");
}

}  // namespace

BakeTracker::Records BakeTracker::begin(World& world, const std::vector<std::string>& bakers,
                                        const std::vector<Entity>& entities, const BakeSettings& settings) const {
  Records out;
  auto scene = std::make_shared<const std::vector<SceneInput>>(scene_inputs(world));
  std::map<const LightingModule*, std::uint64_t> modules;
  for (const Subject& s : subjects(world)) {
    if (!bakers.empty() && std::find(bakers.begin(), bakers.end(), s.module->name) == bakers.end()) continue;
    auto [it, added] = modules.try_emplace(s.module, 0);
    if (added) it->second = module_hash(world, *s.module, settings);
    // A selection bake bakes the selected entities' components; module-wide work needs a full bake.
    if (!entities.empty() && std::find(entities.begin(), entities.end(), s.entity) == entities.end()) {
      // A component of the module left out whose own inputs are as baked: the module's inputs now
      // hold its siblings' new values, which its data does not read (a skeleton or clip change
      // that a selection bake leaves out goes unnoticed for it).
      const auto kept = records_.find({std::string(s.module->name), key_of(world, s)});
      if (kept != records_.end() && kept->second.file.empty() && kept->second.fields == fields_hash(world, s) &&
          kept->second.transform == transform_hash(world, s.entity)) {
        Record r = kept->second;
        r.module_inputs = it->second;
        r.refresh_only = true;
        out[kept->first] = std::move(r);
      }
      continue;
    }
    Record r;
    r.component = s.info != nullptr ? std::string(s.info->name) : std::string();
    r.fields = fields_hash(world, s);
    r.transform = transform_hash(world, s.entity);
    r.module_inputs = it->second;
    r.preset = settings.preset;
    r.seed = settings.seed;
    r.scene = scene;
    out[{std::string(s.module->name), key_of(world, s)}] = std::move(r);
  }
  return out;
}

void BakeTracker::commit(Records pending, const BakeReport& report) {
  for (auto& [id, record] : pending) {
    if (!record.refresh_only)
      for (const BakeReport::Item& item : report.items)
        if (item.baker == id.first) {
          record.seconds = item.seconds;
          record.bytes = item.bytes;
        }
    record.refresh_only = false;
    records_[id] = std::move(record);
  }
}

void BakeTracker::loaded(World& world, const BakeFile& file, const std::string& file_name) {
  for (const Subject& s : subjects(world)) {
    const std::string key = key_of(world, s);
    const bool has_chunk = std::any_of(file.chunks.begin(), file.chunks.end(), [&](const BakeChunk& c) {
      if (lighting_module_for_chunk(c.type) != s.module) return false;
      return !s.entity || s.module->chunk_key == nullptr || s.module->chunk_key(c) == key;
    });
    if (!has_chunk) continue;
    Record r;
    r.component = s.info != nullptr ? std::string(s.info->name) : std::string();
    r.file = file_name;
    records_[{std::string(s.module->name), key}] = std::move(r);
  }
}

std::vector<BakeState> BakeTracker::states(World& world, const BakeSettings& settings) const {
  const std::vector<Subject> all = subjects(world);
  const std::vector<SceneInput> scene = scene_inputs(world);
  // Pass 1: each subject's own changes; whether any component of its module changed or is new.
  struct Own {
    const Record* record = nullptr;
    std::vector<std::string> reasons;
  };
  std::vector<Own> own(all.size());
  std::map<const LightingModule*, bool> sibling_changed;
  std::map<const LightingModule*, std::uint64_t> modules;
  const auto module_now = [&](const LightingModule* m) {
    auto [it, added] = modules.try_emplace(m, 0);
    if (added) it->second = module_hash(world, *m, settings);
    return it->second;
  };
  for (std::size_t i = 0; i < all.size(); ++i) {
    const Subject& s = all[i];
    const auto it = records_.find({std::string(s.module->name), key_of(world, s)});
    if (it == records_.end()) {
      sibling_changed[s.module] = true;
      continue;
    }
    own[i].record = &it->second;
    const Record& r = it->second;
    if (!r.file.empty()) continue;
    if (fields_hash(world, s) != r.fields) own[i].reasons.push_back("its settings changed");
    // Its transform counts when the module reads it (a probe grid's box; an AO field's scale, not
    // where the caster is): when the module's inputs changed too.
    if (transform_hash(world, s.entity) != r.transform && module_now(s.module) != r.module_inputs)
      own[i].reasons.push_back("its transform changed");
    if (!own[i].reasons.empty()) sibling_changed[s.module] = true;
  }
  std::vector<BakeState> out;
  for (std::size_t i = 0; i < all.size(); ++i) {
    const Subject& s = all[i];
    BakeState state;
    state.module = s.module->name;
    state.entity = s.entity;
    state.component = s.info != nullptr ? std::string(s.info->name) : std::string();
    const Record* r = own[i].record;
    if (r == nullptr) {
      out.push_back(std::move(state));
      continue;
    }
    state.seconds = r->seconds;
    state.bytes = r->bytes;
    if (!r->file.empty()) {
      state.freshness = Freshness::Loaded;
      state.why = r->file;
      out.push_back(std::move(state));
      continue;
    }
    std::vector<std::string> reasons;
    if (settings.preset != r->preset)
      reasons.push_back(std::string("the bake preset is now ") + to_string(settings.preset) + " (baked at " +
                        to_string(r->preset) + ")");
    if (settings.seed != r->seed) reasons.push_back("the bake seed changed");
    reasons.insert(reasons.end(), own[i].reasons.begin(), own[i].reasons.end());
    const Baker* baker = world.resource<BakerRegistry>().find(s.module->name);
    scene_changes(*r->scene, scene, baker == nullptr || baker->reads_lights, reasons);
    if (reasons.empty()) {
      // What else the module's bake reads (a skeleton, clips, receivers), unless another component
      // of the module changed, which alone moves that hash.
      if (module_now(s.module) != r->module_inputs && !sibling_changed[s.module])
        reasons.push_back("other inputs of the " + std::string(s.module->name) + " bake changed");
    }
    state.freshness = reasons.empty() ? Freshness::UpToDate : Freshness::OutOfDate;
    for (const std::string& reason : reasons) state.why += (state.why.empty() ? "" : "; ") + reason;
    out.push_back(std::move(state));
  }
  return out;
}

}  // namespace penumbra::editor
