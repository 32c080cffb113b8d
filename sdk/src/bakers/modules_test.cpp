// The module list and every component's field list: one name and chunk type per module, defaults
// and presets within the fields' ranges, presets that keep placement, and an input hash that
// follows every hashed field (and ignores the others), changing each field in turn.
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <set>
#include <string>

#include <nlohmann/json.hpp>
#include <unistd.h>

#include "penumbra/ao_field/ao_field.h"
#include "penumbra/bake/baker.h"
#include "penumbra/bakers.h"
#include "penumbra/import/gltf.h"
#include "penumbra/probe_grid/probe_grid.h"
#include "penumbra/runtime.h"
#include "penumbra/scene/builtin.h"
#include "penumbra/scene/components.h"
#include "test_courtyard.h"
#include "checkout_paths.h"

namespace penumbra {
namespace {

World courtyard() { return test_scenes::courtyard_with_defaults(); }

// A value of the field's type, within its range, different from `v`.
FieldValue changed(const FieldInfo& f, const FieldValue& v) {
  const auto step = [&](double x, double delta) {
    const double up = x + delta;
    return up <= f.max ? up : x - delta;
  };
  switch (f.type) {
    case FieldType::Bool: return !std::get<bool>(v);
    case FieldType::Enum: {
      const auto n = static_cast<std::int64_t>(f.choices.size());
      return (std::get<std::int64_t>(v) + 1) % n;
    }
    case FieldType::Int:
    case FieldType::Count: return static_cast<std::int64_t>(step(double(std::get<std::int64_t>(v)), 1.0));
    case FieldType::Float: {
      const float x = std::get<float>(v);
      return static_cast<float>(step(x, 0.01 * (f.max - f.min) < 0.25 ? 0.01 * (f.max - f.min) : 0.25));
    }
    case FieldType::Vec2: return std::get<glm::vec2>(v) + glm::vec2(0.125f, 0.0f);
    case FieldType::Vec3:
    case FieldType::Color: {
      glm::vec3 x = std::get<glm::vec3>(v);
      x.y = static_cast<float>(step(x.y, 0.125));
      return x;
    }
    case FieldType::Count3: return std::get<glm::uvec3>(v) + glm::uvec3(0u, 1u, 0u);
    case FieldType::Rotation: return std::get<glm::quat>(v) * glm::quat(glm::vec3(0.0f, 0.25f, 0.0f));
    case FieldType::Text: return std::get<std::string>(v) + (std::get<std::string>(v).empty() ? "x=0.5" : ", x=0.5");
  }
  return v;
}

TEST(LightingModules, OneNameAndChunkTypeEach) {
  std::set<std::string> names;
  std::set<std::uint32_t> types;
  for (const LightingModule* m : lighting_modules()) {
    EXPECT_TRUE(names.insert(std::string(m->name)).second) << m->name;
    EXPECT_EQ(find_lighting_module(m->name), m);
    EXPECT_NE(m->attach, nullptr) << m->name;
    EXPECT_NE(m->describe, nullptr) << m->name;
    for (std::uint32_t t : m->chunk_types) {
      EXPECT_TRUE(types.insert(t).second) << fourcc_to_string(t);
      EXPECT_EQ(lighting_module_for_chunk(t), m);
    }
  }
  // Each module's baker has the module's name.
  World world = courtyard();
  for (const LightingModule* m : lighting_modules())
    EXPECT_NE(world.resource<BakerRegistry>().find(m->name), nullptr) << m->name;
  EXPECT_EQ(world.resource<BakerRegistry>().all().size(), lighting_modules().size());
}

TEST(LightingModules, DefaultsAndPresetsLieWithinTheFieldRanges) {
  for (const LightingModule* m : lighting_modules())
    for (const ComponentInfo* c : m->components) {
      std::set<std::string_view> fields;
      for (const FieldInfo& f : c->fields) {
        EXPECT_TRUE(fields.insert(f.name).second) << c->name << "." << f.name;
        EXPECT_NE(f.get, nullptr);
        EXPECT_EQ(f.set == nullptr, f.read_only) << c->name << "." << f.name;
        EXPECT_FALSE(f.read_only && (f.hashed || f.preset)) << c->name << "." << f.name;
        if (f.type == FieldType::Enum) {
          EXPECT_EQ(f.max, double(f.choices.size() - 1)) << f.name;
        }
      }
      Status d = check_fields(*c, c->defaults, c->name);
      EXPECT_TRUE(d.ok()) << d.error().message;
    }
}

// What moves in a game leaves every bake's input hash alone: the walker animating and walking, a
// pushed crate, the carried lamp (a dynamic light). A crate's scale (its AO field's validation),
// a static wall and a baked light change it. scene_inputs lists one input per mesh, per light and
// the sky.
TEST(LightingModules, TheInputHashIgnoresWhatMovesInTheGame) {
  World world = courtyard();
  BakeSettings settings;
  const std::uint64_t base = bake_input_hash(world, {}, settings);
  const auto entity = [&](std::string_view name) {
    for (Entity e : world.view<Name>().sorted_entities())
      if (world.get<Name>(e).value == name) return e;
    ADD_FAILURE() << "no " << name;
    return Entity::null();
  };
  const Entity crate = entity("crate"), wall = entity("north_wall");
  Entity lamp;
  world.view<DynamicLight>().each([&](Entity e, DynamicLight&) { lamp = e; });
  ASSERT_TRUE(lamp) << "the courtyard's lamp is a dynamic light";
  for (int frame = 0; frame < 30; ++frame) {
    world.patch<Transform>(crate).translation.x += 0.01f;
    world.patch<Transform>(lamp).translation.z += 0.02f;
    world.update(1.0 / 30.0);
  }
  EXPECT_EQ(bake_input_hash(world, {}, settings), base);
  world.patch<Transform>(crate).scale = glm::vec3(1.25f);
  world.update(0.0);
  const std::uint64_t scaled = bake_input_hash(world, {}, settings);
  EXPECT_NE(scaled, base);
  world.patch<Transform>(wall).translation.y += 0.01f;
  world.update(0.0);
  EXPECT_NE(bake_input_hash(world, {}, settings), scaled);

  const std::vector<SceneInput> inputs = scene_inputs(world);
  const std::size_t meshes = world.view<Mesh>().count(), lights = world.view<Light>().count();
  ASSERT_EQ(inputs.size(), meshes + lights + 1);
  EXPECT_EQ(inputs.back().kind, SceneInput::Kind::Environment);
  EXPECT_EQ(inputs[meshes].kind, SceneInput::Kind::Light);
}

// Every hashed field of every authoring component changes the module's input hash; the fields
// that the bake does not read (priority, blending, receivers) leave it alone. A field added to a
// component's list without `hashed` that the bake reads fails here only if someone marks it; one
// marked hashed but missed by hash_fields fails here always.
TEST(LightingModules, TheInputHashFollowsEachHashedFieldAndIgnoresTheOthers) {
  World world = courtyard();
  BakeSettings settings;
  for (const LightingModule* m : lighting_modules()) {
    const std::vector<std::string> bakers{std::string(m->name)};
    for (const ComponentInfo* c : m->components) {
      if (std::all_of(c->fields.begin(), c->fields.end(), [](const FieldInfo& f) { return f.read_only; })) continue;
      // The first entity with the component.
      Entity e;
      for (Entity candidate : world.view<Name>().sorted_entities())
        if (c->present(world, candidate)) {
          e = candidate;
          break;
        }
      ASSERT_TRUE(e) << "the courtyard has no " << c->name;
      for (const FieldInfo& f : c->fields) {
        if (f.read_only) continue;
        const FieldValue before = f.get(c->find(world, e));
        const std::uint64_t base = bake_input_hash(world, bakers, settings);
        const FieldValue after = changed(f, before);
        ASSERT_TRUE(check_field_value(f, after).ok()) << c->name << "." << f.name;
        ASSERT_NE(before, after) << c->name << "." << f.name;
        f.set(c->patch(world, e), after);
        const std::uint64_t edited = bake_input_hash(world, bakers, settings);
        if (f.hashed)
          EXPECT_NE(edited, base) << c->name << "." << f.name << " is hashed but does not change the input hash";
        else
          EXPECT_EQ(edited, base) << c->name << "." << f.name << " is not read by the bake but changes its hash";
        f.set(c->patch(world, e), before);
        EXPECT_EQ(bake_input_hash(world, bakers, settings), base) << c->name << "." << f.name;
      }
    }
  }
}

// A preset sets the preset fields and keeps every other one (placement, blending, content).
TEST(LightingModules, PresetsSetTheirFieldsAndKeepTheRest) {
  World world = courtyard();
  for (const LightingModule* m : lighting_modules())
    for (const ComponentInfo* c : m->components) {
      if (c->set_preset_fields == nullptr) continue;
      Entity e;
      for (Entity candidate : world.view<Name>().sorted_entities())
        if (c->present(world, candidate)) e = candidate;
      ASSERT_TRUE(e) << c->name;
      // Move every settable field off its value, then apply the high preset.
      std::vector<FieldValue> moved;
      for (const FieldInfo& f : c->fields) {
        moved.push_back(f.read_only ? f.get(c->find(world, e)) : changed(f, f.get(c->find(world, e))));
        if (!f.read_only) f.set(c->patch(world, e), moved.back());
      }
      apply_preset(*c, world, e, Preset::High);
      Status s = check_fields(*c, c->find(world, e), c->name);
      EXPECT_TRUE(s.ok()) << s.error().message;
      std::size_t set_by_preset = 0;
      for (std::size_t i = 0; i < c->fields.size(); ++i) {
        const FieldInfo& f = c->fields[i];
        if (f.preset) {
          ++set_by_preset;
        } else {
          EXPECT_EQ(f.get(c->find(world, e)), moved[i]) << c->name << "." << f.name << " is not a preset field";
        }
      }
      EXPECT_GT(set_by_preset, 0u) << c->name;
    }
}

// Every module's check accepts the chunks its baker wrote and refuses a truncated one, naming it.
TEST(LightingModules, ChecksAcceptBakedChunksAndRefuseDamagedOnes) {
  World world = courtyard();
  JobContext jobs;
  BakeSettings settings;
  settings.preset = Preset::Draft;
  auto baked = bake_world(world, {}, settings, jobs);
  ASSERT_TRUE(baked.ok()) << baked.error().message;
  std::set<std::string_view> checked;
  for (const BakeChunk& chunk : baked->file.chunks) {
    const LightingModule* m = lighting_module_for_chunk(chunk.type);
    ASSERT_NE(m, nullptr);
    ASSERT_NE(m->check, nullptr) << m->name;
    EXPECT_TRUE(m->check(chunk).ok()) << m->name;
    BakeChunk cut = chunk;
    cut.payload.resize(cut.payload.size() / 2);
    const Status bad = m->check(cut);
    ASSERT_FALSE(bad.ok()) << m->name;
    EXPECT_NE(bad.error().message.find(fourcc_to_string(chunk.type)), std::string::npos) << bad.error().message;
    checked.insert(m->name);
  }
  EXPECT_EQ(checked.size(), lighting_modules().size()) << "the courtyard's bake has a chunk of every module";
}

// attach_bake hands each chunk to the module that owns its type, skips types no module owns, and
// names the key of a chunk whose entity this World lacks.
TEST(LightingModules, AttachBakeRoutesChunksAndNamesMissingKeys) {
  World world = courtyard();
  JobContext jobs;
  BakeSettings settings;
  settings.preset = Preset::Draft;
  auto baked = bake_world(world, {"vertex-ao", "ao-field"}, settings, jobs);
  ASSERT_TRUE(baked.ok()) << baked.error().message;
  BakeFile file = baked->file;
  file.chunks.push_back(BakeChunk{fourcc("ZZZZ"), 1, "from a newer SDK", {}});
  World fresh = courtyard();
  Status attached = attach_bake(fresh, file);
  ASSERT_TRUE(attached.ok()) << attached.error().message;
  std::size_t casters = 0;
  fresh.view<AOFieldCaster>().each([&](AOFieldCaster& c) { casters += c.data ? 1 : 0; });
  EXPECT_EQ(casters, 4u);
  // The same file on a courtyard whose crates were renamed: the first AO-field chunk names its key.
  World renamed = courtyard();
  for (Entity e : renamed.view<AOFieldCaster>().sorted_entities()) renamed.patch<Name>(e).value += " (moved)";
  Status missing = attach_bake(renamed, file);
  ASSERT_FALSE(missing.ok());
  EXPECT_EQ(missing.error().code, ErrorCode::NotFound);
  EXPECT_NE(missing.error().message.find("no entity has the key 'crate'"), std::string::npos) << missing.error().message;
}

// A re-export that writes the nodes in another order (every node two places on, children lists
// reversed) keeps every node's name path, so a bake of the original attaches to it: the same
// fields on the same named entities.
TEST(LightingModules, ABakeAttachesToAReexportWithReorderedNodes) {
  const std::filesystem::path source = std::filesystem::path(checkout::kSourceDir) / "tests/data/gltf/lighting_extension.gltf";
  nlohmann::json doc = nlohmann::json::parse(std::ifstream(source));
  const std::size_t n = doc["nodes"].size();
  const auto moved = [n](std::size_t i) { return (i + 2) % n; };  // old index -> new
  nlohmann::json nodes = nlohmann::json::array();
  for (std::size_t i = 0; i < n; ++i) nodes.push_back(doc["nodes"][(i + n - 2) % n]);
  for (auto& node : nodes)
    if (node.contains("children")) {
      nlohmann::json children = nlohmann::json::array();
      for (auto it = node["children"].rbegin(); it != node["children"].rend(); ++it)
        children.push_back(moved(it->get<std::size_t>()));
      node["children"] = children;
    }
  doc["nodes"] = nodes;
  for (auto& scene : doc["scenes"])
    for (auto& root : scene["nodes"]) root = moved(root.get<std::size_t>());
  for (auto& animation : doc["animations"])
    for (auto& channel : animation["channels"]) channel["target"]["node"] = moved(channel["target"]["node"].get<std::size_t>());
  const std::filesystem::path reexport = std::filesystem::temp_directory_path() /
                                         ("penumbra_reordered_" + std::to_string(::getpid()) + ".gltf");
  std::ofstream(reexport) << doc.dump();

  const auto load = [](const std::filesystem::path& path) {
    World w;
    register_lighting(w);
    register_bakers(w);
    auto imported = import_gltf(w, path);
    EXPECT_TRUE(imported.ok()) << imported.error().message;
    w.update(0.0);
    EXPECT_TRUE(add_default_lighting(w, Preset::Draft, /*authored=*/true).ok());
    return w;
  };
  World original = load(source), reordered = load(reexport);
  std::filesystem::remove(reexport);
  JobContext jobs;
  BakeSettings settings;
  settings.preset = Preset::Draft;
  auto baked = bake_world(original, {"ao-field", "probe-grid"}, settings, jobs);
  ASSERT_TRUE(baked.ok()) << baked.error().message;
  Status attached = attach_bake(reordered, baked->file);
  ASSERT_TRUE(attached.ok()) << attached.error().message;
  // The crate's field (the file's one caster, on the crate's primitive) and the grid arrived, equal
  // to the original's.
  const auto caster_of = [](World& w) {
    std::shared_ptr<const AOFieldData> data;
    w.view<const AOFieldCaster>().each([&](const AOFieldCaster& c) { data = c.data; });
    return data;
  };
  const auto grid_of = [](World& w) {
    std::shared_ptr<const ProbeGridData> data;
    w.view<const IrradianceProbeGrid>().each([&](const IrradianceProbeGrid& g) { data = g.data; });
    return data;
  };
  ASSERT_TRUE(caster_of(reordered) && grid_of(reordered));
  const glm::vec3 x(0.9f, 0.05f, 0.3f), up(0.0f, 1.0f, 0.0f);
  EXPECT_EQ(evaluate_local(*caster_of(reordered), x, up), evaluate_local(*caster_of(original), x, up));
  EXPECT_EQ(evaluate(*grid_of(reordered), x, up), evaluate(*grid_of(original), x, up));
  EXPECT_GT(evaluate_local(*caster_of(reordered), x, up), 0.0f);
}

}  // namespace
}  // namespace penumbra
