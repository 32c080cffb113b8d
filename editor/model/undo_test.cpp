// Undo/redo of field edits and the field table, on real built-in scenes.
#include "undo.h"

#include <gtest/gtest.h>

#include "document.h"
#include "penumbra/ecs/transform.h"
#include "penumbra/probe_grid/probe_grid.h"
#include "penumbra/scene/components.h"

namespace penumbra::editor {
namespace {

std::unique_ptr<Document> courtyard() {
  auto doc = Document::open("builtin:courtyard");
  EXPECT_TRUE(doc.ok()) << (doc.ok() ? "" : doc.error().message);
  return std::move(*doc);
}

TEST(Undo, SetUndoRedoRestoresExactValues) {
  auto doc = courtyard();
  World& w = doc->world();
  const Entity lamp = *doc->find("lamp");
  const FieldDesc& f = *find_field("Light", "intensity");
  const float before = w.get<Light>(lamp).intensity;
  ASSERT_TRUE(doc->undo().set(w, lamp, f, FieldValue(40.0f)).ok());
  EXPECT_EQ(w.get<Light>(lamp).intensity, 40.0f);
  ASSERT_TRUE(doc->undo().undo(w));
  EXPECT_EQ(w.get<Light>(lamp).intensity, before);
  EXPECT_FALSE(doc->undo().undo(w));
  ASSERT_TRUE(doc->undo().redo(w));
  EXPECT_EQ(w.get<Light>(lamp).intensity, 40.0f);
  EXPECT_FALSE(doc->undo().redo(w));
}

TEST(Undo, AddAndRemoveALightingComponentAreEntriesThatRestoreItsFields) {
  auto doc = courtyard();
  World& w = doc->world();
  const Entity lamp = *doc->find("lamp");
  const ComponentInfo& grid = *find_authored_component("IrradianceProbeGrid");
  ASSERT_TRUE(doc->undo().add_component(w, lamp, grid, Preset::Draft).ok());
  ASSERT_TRUE(w.has<IrradianceProbeGrid>(lamp));
  EXPECT_EQ(w.get<IrradianceProbeGrid>(lamp).samples_per_node, IrradianceProbeGrid::preset(Preset::Draft).samples_per_node);
  ASSERT_TRUE(doc->undo().set(w, lamp, *find_field("IrradianceProbeGrid", "spacing"), FieldValue(0.75f)).ok());
  // Remove, then undo the removal: the edited value comes back.
  ASSERT_TRUE(doc->undo().remove_component(w, lamp, grid).ok());
  EXPECT_FALSE(w.has<IrradianceProbeGrid>(lamp));
  ASSERT_TRUE(doc->undo().undo(w));
  ASSERT_TRUE(w.has<IrradianceProbeGrid>(lamp));
  EXPECT_EQ(w.get<IrradianceProbeGrid>(lamp).spacing, 0.75f);
  // Undo the edit and the add: no grid; redo both: the grid with the edit.
  ASSERT_TRUE(doc->undo().undo(w));
  ASSERT_TRUE(doc->undo().undo(w));
  EXPECT_FALSE(w.has<IrradianceProbeGrid>(lamp));
  ASSERT_TRUE(doc->undo().redo(w));
  ASSERT_TRUE(doc->undo().redo(w));
  EXPECT_EQ(w.get<IrradianceProbeGrid>(lamp).spacing, 0.75f);
  // Refused: a second one, a per-mesh component on an entity without a Mesh, removing what is absent.
  EXPECT_FALSE(doc->undo().add_component(w, lamp, grid, std::nullopt).ok());
  const Status no_mesh = doc->undo().add_component(w, lamp, *find_authored_component("AOFieldCaster"), std::nullopt);
  ASSERT_FALSE(no_mesh.ok());
  EXPECT_NE(no_mesh.error().message.find("belongs on a mesh"), std::string::npos) << no_mesh.error().message;
  EXPECT_FALSE(doc->undo().remove_component(w, lamp, *find_authored_component("SkinnedPoseAO")).ok());
}

TEST(Undo, EditsStampTheChangeTick) {
  auto doc = courtyard();
  World& w = doc->world();
  const Entity lamp = *doc->find("lamp");
  const std::uint64_t tick = w.changed_tick<Light>(lamp);
  w.update(0.0);
  ASSERT_TRUE(doc->undo().set(w, lamp, *find_field("Light", "color"), FieldValue(glm::vec3(0.5f))).ok());
  EXPECT_GT(w.changed_tick<Light>(lamp), tick);  // systems and the renderer see the edit
}

TEST(Undo, ADragMergesIntoOneEntryUntilItEnds) {
  auto doc = courtyard();
  World& w = doc->world();
  const Entity crate = *doc->find("crate");
  const FieldDesc& f = *find_field("Transform", "translation");
  const glm::vec3 start = w.get<Transform>(crate).translation;
  for (int i = 1; i <= 5; ++i)
    ASSERT_TRUE(doc->undo().set(w, crate, f, FieldValue(start + glm::vec3(0.1f * float(i), 0, 0)), true).ok());
  EXPECT_EQ(doc->undo().size(), 1u);
  doc->undo().end_merge();
  ASSERT_TRUE(doc->undo().set(w, crate, f, FieldValue(start + glm::vec3(1, 0, 0)), true).ok());
  EXPECT_EQ(doc->undo().size(), 2u);
  // A merged drag of another field starts its own entry.
  ASSERT_TRUE(doc->undo().set(w, crate, *find_field("Transform", "scale"), FieldValue(glm::vec3(2.0f)), true).ok());
  EXPECT_EQ(doc->undo().size(), 3u);
  ASSERT_TRUE(doc->undo().undo(w));
  ASSERT_TRUE(doc->undo().undo(w));
  EXPECT_EQ(w.get<Transform>(crate).translation, start + glm::vec3(0.5f, 0, 0));
  ASSERT_TRUE(doc->undo().undo(w));
  EXPECT_EQ(w.get<Transform>(crate).translation, start);
}

TEST(Undo, ANewEditDropsTheUndoneOnes) {
  auto doc = courtyard();
  World& w = doc->world();
  const Entity lamp = *doc->find("lamp");
  const FieldDesc& f = *find_field("Light", "range");
  ASSERT_TRUE(doc->undo().set(w, lamp, f, FieldValue(5.0f)).ok());
  ASSERT_TRUE(doc->undo().set(w, lamp, f, FieldValue(6.0f)).ok());
  ASSERT_TRUE(doc->undo().undo(w));
  ASSERT_TRUE(doc->undo().set(w, lamp, f, FieldValue(7.0f)).ok());
  EXPECT_EQ(doc->undo().size(), 2u);
  EXPECT_FALSE(doc->undo().can_redo());
  ASSERT_TRUE(doc->undo().undo(w));
  EXPECT_EQ(w.get<Light>(lamp).range, 5.0f);
}

TEST(Undo, PresetIsOneEntryOfTheChangedFields) {
  auto doc = courtyard();
  World& w = doc->world();
  const Entity grid = *doc->find("probe grid");
  const IrradianceProbeGrid before = w.get<IrradianceProbeGrid>(grid);  // medium (the default)
  const ComponentPreset& p = *find_preset("probe-grid");
  ASSERT_TRUE(doc->undo().record(w, grid, p.component, "preset", [&] { p.apply(w, grid, Preset::Draft); }).ok());
  const IrradianceProbeGrid& draft = w.get<IrradianceProbeGrid>(grid);
  const IrradianceProbeGrid expected = IrradianceProbeGrid::preset(Preset::Draft);
  EXPECT_EQ(draft.samples_per_node, expected.samples_per_node);
  EXPECT_EQ(draft.spacing, expected.spacing);
  EXPECT_EQ(draft.sampling, expected.sampling);
  EXPECT_EQ(draft.box.min, before.box.min);  // placement kept
  ASSERT_EQ(doc->undo().size(), 1u);
  EXPECT_GE(doc->undo().entry(0).changes.size(), 3u);
  ASSERT_TRUE(doc->undo().undo(w));
  const IrradianceProbeGrid& back = w.get<IrradianceProbeGrid>(grid);
  EXPECT_EQ(back.samples_per_node, before.samples_per_node);
  EXPECT_EQ(back.spacing, before.spacing);
  EXPECT_EQ(back.sampling, before.sampling);
  EXPECT_EQ(back.bounces, before.bounces);
}

TEST(Undo, BadEditsChangeNothing) {
  auto doc = courtyard();
  World& w = doc->world();
  const Entity lamp = *doc->find("lamp");
  const Entity ground = *doc->find("ground");
  // Out of range, wrong type, missing component, read-only, stale entity.
  EXPECT_FALSE(doc->undo().set(w, lamp, *find_field("Light", "intensity"), FieldValue(-1.0f)).ok());
  EXPECT_FALSE(doc->undo().set(w, lamp, *find_field("Light", "intensity"), FieldValue(true)).ok());
  const auto missing = doc->undo().set(w, ground, *find_field("Light", "intensity"), FieldValue(2.0f));
  ASSERT_FALSE(missing.ok());
  EXPECT_NE(missing.error().message.find("no Light component"), std::string::npos) << missing.error().message;
  EXPECT_FALSE(doc->undo().set(w, ground, *find_field("ProbeLit", "covered"), FieldValue(true)).ok());
  EXPECT_EQ(w.get<Light>(lamp).intensity, 20.0f);
  EXPECT_EQ(doc->undo().size(), 0u);
  // An entry whose entity was destroyed is dropped, not applied.
  ASSERT_TRUE(doc->undo().set(w, lamp, *find_field("Light", "intensity"), FieldValue(3.0f)).ok());
  w.destroy(lamp);
  EXPECT_FALSE(doc->undo().undo(w));
  EXPECT_EQ(doc->undo().size(), 0u);
}

// Every editable field of every entity of the courtyard: format then parse gives the value back,
// and setting it through the table leaves the component unchanged.
TEST(Fields, FormatParseRoundTripsOnEveryEntity) {
  auto doc = courtyard();
  World& w = doc->world();
  int checked = 0;
  for (std::uint32_t i = 0; i < 400; ++i) {
    const Entity e = w.find_entity(i);
    if (!e) continue;
    for (const FieldDesc& f : editable_fields()) {
      if (!f.present(w, e)) continue;
      const FieldValue v = f.get(w, e);
      const std::string text = format_field_value(f, v);
      auto back = parse_field_value(f, text);
      if (f.read_only) continue;
      ASSERT_TRUE(back.ok()) << f.component << "." << f.name << " '" << text << "': " << back.error().message;
      if (f.kind == FieldKind::Rotation) {
        const glm::quat a = std::get<glm::quat>(v), b = std::get<glm::quat>(*back);
        EXPECT_NEAR(std::abs(glm::dot(a, b)), 1.0f, 1e-5f) << text;  // q and -q are one rotation
      } else {
        EXPECT_TRUE(*back == v) << f.component << "." << f.name << " '" << text << "'";
      }
      ++checked;
    }
  }
  EXPECT_GT(checked, 100);
}

TEST(Fields, ParseErrorsNameTheFieldAndTheExpectedForm) {
  const FieldDesc& order = *find_field("IrradianceProbeGrid", "sh_order");
  auto bad = parse_field_value(order, "L3");
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(bad.error().message.find("IrradianceProbeGrid.sh_order"), std::string::npos);
  EXPECT_NE(bad.error().message.find("L1 L2"), std::string::npos) << bad.error().message;
  EXPECT_FALSE(parse_field_value(*find_field("Transform", "translation"), "1 2").ok());
  EXPECT_FALSE(parse_field_value(*find_field("Transform", "translation"), "1 2 x").ok());
  EXPECT_FALSE(parse_field_value(*find_field("AOFieldCaster", "resolution"), "2.5").ok());
  EXPECT_FALSE(parse_field_value(*find_field("AOFieldCaster", "resolution"), "300").ok());
  EXPECT_EQ(std::get<std::int64_t>(*parse_field_value(order, "L1")), 0);
  const glm::quat q = std::get<glm::quat>(*parse_field_value(*find_field("Transform", "rotation"), "0 90 0"));
  const glm::vec3 x = q * glm::vec3(1, 0, 0);
  EXPECT_NEAR(x.z, -1.0f, 1e-6f);  // +90 degrees about Y takes +X to -Z
}

}  // namespace
}  // namespace penumbra::editor
