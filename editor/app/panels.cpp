// The editor's panels (panels.h): hierarchy, inspector, bake, stats, visualisation, menus.
#include "panels.h"

#include <algorithm>
#include <vector>
#include <cfloat>
#include <cinttypes>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>

#include <glm/gtc/quaternion.hpp>
#include <imgui.h>

#include "overlays.h"
#include "penumbra/core/memory.h"
#include "penumbra/ecs/transform.h"
#include "gizmo.h"
#include "penumbra/scene/animation.h"
#include "penumbra/scene/builtin.h"
#include "penumbra/scene/entity_key.h"

namespace penumbra::editor {

void FrameTimes::add(double ms, bool baking, const ViewportTimes& parts) {
  recent_ms.push_back(static_cast<float>(ms));
  if (recent_ms.size() > 240) recent_ms.pop_front();
  if (++frames <= kWarmUp) return;
  (baking ? baking_ms : idle_ms).push_back(ms);
  wait_ms.push_back(parts.wait_ms);
  record_ms.push_back(parts.record_ms);
  present_ms.push_back(parts.present_ms);
}

FrameSummary summarise(std::vector<double> ms) {
  FrameSummary s;
  s.frames = ms.size();
  if (ms.empty()) return s;
  std::sort(ms.begin(), ms.end());
  const auto at = [&](double q) { return ms[std::min(ms.size() - 1, static_cast<std::size_t>(q * double(ms.size() - 1) + 0.5))]; };
  s.median = at(0.5);
  s.p95 = at(0.95);
  s.max = ms.back();
  return s;
}

CostPlot read_cost_plot(const std::string& path, const std::string& x_column, const std::string& y_column,
                        const std::string& mark_column, const std::string& mark_value) {
  CostPlot plot;
  plot.path = path;
  plot.x_label = x_column;
  plot.y_label = y_column;
  std::ifstream in(path);
  if (!in) {
    const std::string bench = std::filesystem::path(path).stem().string();
    plot.error = path + ": no bench results; run `penumbra bench " + bench + "` to make them";
    return plot;
  }
  const auto split = [](const std::string& line) {
    std::vector<std::string> cells;
    std::stringstream s(line);
    for (std::string c; std::getline(s, c, ',');) cells.push_back(c);
    return cells;
  };
  std::string line;
  std::getline(in, line);
  const auto header = split(line);
  const auto xi = std::find(header.begin(), header.end(), x_column) - header.begin();
  const auto yi = std::find(header.begin(), header.end(), y_column) - header.begin();
  const auto mi = std::find(header.begin(), header.end(), mark_column) - header.begin();
  if (xi == static_cast<std::ptrdiff_t>(header.size()) || yi == static_cast<std::ptrdiff_t>(header.size())) {
    plot.error = path + ": no columns '" + x_column + "' and '" + y_column + "'; is it a penumbra bench CSV?";
    return plot;
  }
  while (std::getline(in, line)) {
    const auto cells = split(line);
    if (cells.size() != header.size()) continue;
    char* end = nullptr;
    const float x = std::strtof(cells[static_cast<std::size_t>(xi)].c_str(), &end);
    const float y = std::strtof(cells[static_cast<std::size_t>(yi)].c_str(), &end);
    if (!std::isfinite(x) || !std::isfinite(y)) continue;
    std::string label;
    for (std::size_t i = 0; i < std::min<std::size_t>(4, cells.size()); ++i) label += (i ? " " : "") + cells[i];
    plot.labels.push_back(label);
    plot.x.push_back(x);
    plot.y.push_back(y);
    plot.marked.push_back(!mark_column.empty() && mi < static_cast<std::ptrdiff_t>(cells.size()) &&
                          cells[static_cast<std::size_t>(mi)] == mark_value);
  }
  if (plot.x.empty()) plot.error = path + ": no rows with numbers";
  return plot;
}

CostPlot scene_cost_plot(const EditorModel& model, const std::uint64_t (&preset_hashes)[3]) {
  CostPlot plot;
  plot.x_label = "bake time (s)";
  plot.y_label = "chunk bytes (B)";
  for (Preset q : {Preset::Draft, Preset::Medium, Preset::High}) {
    const BakeEstimate* e = model.preset_estimate(q, preset_hashes[static_cast<int>(q)]);
    if (e == nullptr) continue;
    for (const BakeEstimate::Item& item : e->items)
      if (item.bytes && *item.bytes > 0 && item.seconds > 0.0) {
        plot.labels.push_back(item.baker + " " + to_string(q) + (model.preset_exact(q) ? " (baked)" : " (estimated)"));
        plot.x.push_back(static_cast<float>(item.seconds));
        plot.y.push_back(static_cast<float>(*item.bytes));
        plot.marked.push_back(q == model.bake_settings.preset);
      }
  }
  if (plot.x.empty())
    plot.error = "no estimate of this scene holds: press the button (each preset's bake is timed on samples of "
                 "it, in a fraction of its time; an edit or another seed needs a new estimate)";
  return plot;
}

namespace {

void report(UiState& ui, const Status& s, const std::string& done = {}) {
  ui.message = s ? done : s.error().message;
}

// --- Entities: create, duplicate, delete (done after the panels: UiState::entity_request) -------

// A new entity of `kind` next to `sibling` (a root when null), at the orbit camera's target.
void request_create(UiState& ui, std::string_view kind, Entity sibling) {
  const glm::vec3 at = ui.camera.target();
  ui.entity_request = [&ui, kind = std::string(kind), sibling, at](Document& doc) {
    World& w = doc.world();
    const Parent* p = w.alive(sibling) ? w.try_get<Parent>(sibling) : nullptr;
    const Entity parent = p && w.alive(p->entity) ? p->entity : Entity::null();
    const glm::vec3 local = glm::vec3(glm::inverse(parent_world_matrix(w, sibling)) * glm::vec4(at, 1.0f));
    std::string base = kind == "empty" ? "entity" : kind;
    std::replace(base.begin(), base.end(), '-', ' ');
    std::string name = base;
    for (int k = 2; doc.find(name).ok(); ++k) name = base + " " + std::to_string(k);
    auto e = doc.create_entity(kind, name, parent, local);
    report(ui, e ? Status{} : Status{e.error()}, "created '" + name + "' (Ctrl+Z removes it)");
  };
}
void request_duplicate(UiState& ui, Entity e) {
  ui.entity_request = [&ui, e](Document& doc) {
    auto copy = doc.duplicate(e);
    report(ui, copy ? Status{} : Status{copy.error()}, copy ? "duplicated as '" + doc.label(*copy) + "'" : "");
  };
}
void request_delete(UiState& ui, Entity e) {
  ui.entity_request = [&ui, e](Document& doc) {
    const std::string name = doc.label(e);
    report(ui, doc.delete_entity(e), "deleted '" + name + "' and what was below it (Ctrl+Z brings it back)");
  };
}
void create_menu_items(UiState& ui, Entity sibling) {
  for (std::string_view kind : Document::kEntityKinds)
    if (ImGui::MenuItem(std::string(kind).c_str())) request_create(ui, kind, sibling);
}

// --- Layout ------------------------------------------------------------------------------------

enum class Panel { Scene, Bake, Inspector, Stats, View, Plot };

// The panels tile the window around the 3D view: Scene over Bake on the left, Inspector over
// Stats on the right, View and the plot along the bottom, between the menu bar and the status
// bar. Column widths and the bottom row's height follow the window within readable bounds.
void place(Panel panel, const UiState& ui) {
  const ImGuiViewport* vp = ImGui::GetMainViewport();
  const float W = vp->Size.x, H = vp->Size.y, top = 20.0f, bottom = H - 22.0f, tall = bottom - top;
  const float left = std::clamp(0.2f * W, 220.0f, 380.0f), right = std::clamp(0.24f * W, 260.0f, 440.0f);
  const float row = std::clamp(0.26f * H, 160.0f, 320.0f), middle = std::max(W - left - right, 200.0f);
  ImVec2 pos, size;
  switch (panel) {
    case Panel::Scene: pos = {0, top}, size = {left, 0.55f * tall}; break;
    case Panel::Bake: pos = {0, top + 0.55f * tall}, size = {left, 0.45f * tall}; break;
    case Panel::Inspector: pos = {W - right, top}, size = {right, 0.6f * tall}; break;
    case Panel::Stats: pos = {W - right, top + 0.6f * tall}, size = {right, 0.4f * tall}; break;
    case Panel::View: pos = {left, bottom - row}, size = {0.6f * middle, row}; break;
    case Panel::Plot: pos = {left + 0.6f * middle, bottom - row}, size = {0.4f * middle, row}; break;
  }
  // Laid out again whenever the window's size changes; in between the user may move and resize.
  const ImGuiCond cond = ui.relayout ? ImGuiCond_Always : ImGuiCond_FirstUseEver;
  ImGui::SetNextWindowPos(ImVec2(vp->Pos.x + pos.x, vp->Pos.y + pos.y), cond);
  ImGui::SetNextWindowSize(size, cond);
}

// --- Hierarchy ---------------------------------------------------------------------------------

void hierarchy_node(Document& doc, UiState& ui, Entity e) {
  World& w = doc.world();
  const Children* kids = w.try_get<Children>(e);
  const bool leaf = kids == nullptr || kids->entities.empty();
  ImGuiTreeNodeFlags flags = ImGuiTreeNodeFlags_OpenOnArrow | ImGuiTreeNodeFlags_SpanAvailWidth;
  if (leaf) flags |= ImGuiTreeNodeFlags_Leaf | ImGuiTreeNodeFlags_NoTreePushOnOpen;
  if (doc.selection() == e) flags |= ImGuiTreeNodeFlags_Selected;
  std::string label = doc.label(e);
  if (w.has<Light>(e)) label += "  [light]";
  for (const EditorExtension& x : editor_extensions())
    if (x.applies(w, e)) label += "  [" + x.tag + "]";
  const bool open = ImGui::TreeNodeEx(reinterpret_cast<void*>(static_cast<std::uintptr_t>(e.index) + 1), flags, "%s",
                                      label.c_str());
  if (ImGui::IsItemClicked()) doc.select(e);
  if (ImGui::BeginPopupContextItem()) {
    doc.select(e);
    if (ImGui::MenuItem("Duplicate", "Ctrl+D")) request_duplicate(ui, e);
    if (ImGui::MenuItem("Delete", "Del")) request_delete(ui, e);
    if (ImGui::BeginMenu("Create next to it")) {
      create_menu_items(ui, e);
      ImGui::EndMenu();
    }
    ImGui::EndPopup();
  }
  if (open && !leaf) {
    for (Entity c : kids->entities)
      if (w.alive(c)) hierarchy_node(doc, ui, c);
    ImGui::TreePop();
  }
}

void hierarchy_panel(Document& doc, UiState& ui) {
  place(Panel::Scene, ui);
  ImGui::Begin("Scene");
  ImGui::TextDisabled("%s, %zu entities", doc.source().c_str(), doc.world().entity_count());
  World& w = doc.world();
  std::vector<Entity> roots;
  for (std::uint32_t i = 0, seen = 0; seen < w.entity_count() && i < (1u << 24); ++i) {
    const Entity e = w.find_entity(i);
    if (!e) continue;
    ++seen;
    const Parent* p = w.try_get<Parent>(e);
    if (p == nullptr || !w.alive(p->entity)) roots.push_back(e);
  }
  for (Entity e : roots) hierarchy_node(doc, ui, e);
  ImGui::TextDisabled("right-click an entity: duplicate, delete, create");
  ImGui::End();
}

// --- Inspector ---------------------------------------------------------------------------------

// "samples_per_axis" -> "samples per axis (unit)", angles in degrees: what the inspector shows
// above a field's widget (the script and file name stays the field's own).
std::string field_label(const FieldDesc& f) {
  std::string label = f.name;
  std::replace(label.begin(), label.end(), '_', ' ');
  const std::string unit = f.unit == "rad" ? "deg" : f.unit;
  return unit.empty() ? label : label + " (" + unit + ")";
}

// One widget for one field; edits go through the undo stack (drags merge until released).
void field_widget(Document& doc, Entity e, const FieldDesc& f, UiState& ui) {
  World& w = doc.world();
  FieldValue v = f.get(w, e);
  bool changed = false;
  const std::string id = "##" + f.component + "." + f.name;
  ImGui::TextUnformatted(field_label(f).c_str());
  if (!f.help.empty() && ImGui::IsItemHovered()) ImGui::SetTooltip("%s", f.help.c_str());
  ImGui::SetNextItemWidth(-FLT_MIN);
  if (f.read_only) ImGui::BeginDisabled();
  switch (f.kind) {
    case FieldKind::Bool: changed = ImGui::Checkbox(id.c_str(), &std::get<bool>(v)); break;
    case FieldKind::Int:
    case FieldKind::Count: {
      const auto lo = static_cast<std::int64_t>(f.min), hi = static_cast<std::int64_t>(f.max);
      changed = ImGui::DragScalar(id.c_str(), ImGuiDataType_S64, &std::get<std::int64_t>(v), f.speed, &lo, &hi);
      break;
    }
    case FieldKind::Enum: {
      auto& i = std::get<std::int64_t>(v);
      const std::size_t current = static_cast<std::size_t>(i);
      if (ImGui::BeginCombo(id.c_str(), current < f.choices.size() ? f.choices[current].c_str() : "?")) {
        for (std::size_t c = 0; c < f.choices.size(); ++c)
          if (ImGui::Selectable(f.choices[c].c_str(), c == current)) {
            i = static_cast<std::int64_t>(c);
            changed = true;
          }
        ImGui::EndCombo();
      }
      break;
    }
    case FieldKind::Float: {
      // Angles are stored in radians and shown in degrees.
      const float shown = f.unit == "rad" ? 57.29577951308232f : 1.0f;
      const float lo = static_cast<float>(std::max(f.min, -1e9)) * shown, hi = static_cast<float>(std::min(f.max, 1e9)) * shown;
      float x = std::get<float>(v) * shown;
      changed = ImGui::DragFloat(id.c_str(), &x, f.speed * shown, lo, hi, "%.4g");
      if (changed) v = FieldValue(x / shown);
      break;
    }
    case FieldKind::Vec2: changed = ImGui::DragFloat2(id.c_str(), &std::get<glm::vec2>(v).x, f.speed); break;
    case FieldKind::Vec3: changed = ImGui::DragFloat3(id.c_str(), &std::get<glm::vec3>(v).x, f.speed); break;
    case FieldKind::Color:
      changed = ImGui::ColorEdit3(id.c_str(), &std::get<glm::vec3>(v).x, ImGuiColorEditFlags_HDR | ImGuiColorEditFlags_Float);
      break;
    case FieldKind::Count3: {
      const std::uint32_t lo = static_cast<std::uint32_t>(f.min), hi = static_cast<std::uint32_t>(f.max);
      changed = ImGui::DragScalarN(id.c_str(), ImGuiDataType_U32, &std::get<glm::uvec3>(v).x, 3, f.speed, &lo, &hi);
      break;
    }
    case FieldKind::Rotation: {
      glm::vec3 degrees = glm::degrees(glm::eulerAngles(std::get<glm::quat>(v)));
      if (ImGui::DragFloat3(id.c_str(), &degrees.x, 0.5f)) {
        v = glm::quat(glm::radians(degrees));
        changed = true;
      }
      break;
    }
    case FieldKind::Text: {
      // Committed on Enter: a half-typed entry is not an edit.
      std::string& text = std::get<std::string>(v);
      std::vector<char> buffer(static_cast<std::size_t>(std::clamp(f.max, 1.0, 65536.0)) + 1, '\0');
      std::copy_n(text.begin(), std::min(text.size(), buffer.size() - 1), buffer.begin());
      if (ImGui::InputText(id.c_str(), buffer.data(), buffer.size(), ImGuiInputTextFlags_EnterReturnsTrue)) {
        text = buffer.data();
        changed = true;
      }
      break;
    }
  }
  if (f.read_only) ImGui::EndDisabled();
  if (!f.help.empty() && ImGui::IsItemHovered(ImGuiHoveredFlags_AllowWhenDisabled))
    ImGui::SetTooltip("%s", f.help.c_str());
  if (changed) {
    // An error stays in the status bar until the next edit that succeeds.
    if (Status s = doc.undo().set(w, e, f, v, /*merge=*/true); !s) {
      ui.message = ui.field_error = s.error().message;
    } else if (!ui.field_error.empty() && ui.message == ui.field_error) {
      ui.message.clear();
      ui.field_error.clear();
    }
  }
  if (ImGui::IsItemDeactivatedAfterEdit()) doc.undo().end_merge();
}

// What each module says about the entity (its baked data, its runtime outputs).
// A bake state in its colour: up to date green, out of date amber, never baked grey, loaded blue;
// the reason follows, wrapped.
void bake_state_text(const BakeState& state) {
  const ImVec4 colour = state.freshness == Freshness::UpToDate    ? ImVec4(0.45f, 0.85f, 0.45f, 1.0f)
                        : state.freshness == Freshness::OutOfDate ? ImVec4(1.0f, 0.7f, 0.25f, 1.0f)
                        : state.freshness == Freshness::Loaded    ? ImVec4(0.5f, 0.7f, 1.0f, 1.0f)
                                                                  : ImVec4(0.6f, 0.6f, 0.6f, 1.0f);
  ImGui::TextColored(colour, "%s", to_string(state.freshness));
  if (state.seconds > 0.0) {
    ImGui::SameLine();
    ImGui::TextDisabled("(%.2f s, %s)", state.seconds, format_bytes(state.bytes).c_str());
  }
  if (!state.why.empty()) {
    ImGui::Indent();
    ImGui::TextWrapped("%s%s", state.freshness == Freshness::Loaded ? "from " : "", state.why.c_str());
    ImGui::Unindent();
  }
}

void module_lines(World& w, Entity e) {
  for (const EditorExtension& x : editor_extensions())
    if (x.inspector) x.inspector(w, e);
}

void inspector_panel(Document& doc, UiState& ui) {
  place(Panel::Inspector, ui);
  ImGui::Begin("Inspector");
  World& w = doc.world();
  const Entity e = doc.selection();
  if (!w.alive(e)) {
    ImGui::TextDisabled("Select an entity in the Scene panel.");
    ImGui::End();
    return;
  }
  ImGui::Text("%s  (#%u)", doc.label(e).c_str(), e.index);
  if (const Mesh* m = w.try_get<Mesh>(e); m && m->data)
    ImGui::TextDisabled("Mesh '%s': %zu triangles, %s%s", m->data->name.c_str(), m->data->triangle_count(),
                        format_bytes(m->data->bytes()).c_str(), w.has<Static>(e) ? ", static" : "");
  for (const std::string& component : field_components()) {
    const FieldDesc* first = nullptr;
    for (const FieldDesc& f : editable_fields())
      if (f.component == component) {
        first = &f;
        break;
      }
    if (!first->present(w, e)) continue;
    if (!ImGui::CollapsingHeader(component.c_str(), ImGuiTreeNodeFlags_DefaultOpen)) continue;
    for (const ComponentPreset& p : component_presets()) {
      if (p.component != component) continue;
      ImGui::TextUnformatted("preset");
      for (Preset q : {Preset::Draft, Preset::Medium, Preset::High}) {
        ImGui::SameLine();
        if (ImGui::SmallButton(to_string(q))) {
          const Status s = doc.undo().record(w, e, component, std::string("preset ") + to_string(q),
                                             [&] { p.apply(w, e, q); });
          report(ui, s);
        }
      }
    }
    for (const BakeState& state : ui.bake_states)
      if (state.entity == e && state.component == component) {
        ImGui::TextUnformatted("bake:");
        ImGui::SameLine();
        bake_state_text(state);
      }
    for (const FieldDesc& f : editable_fields())
      if (f.component == component) field_widget(doc, e, f, ui);
    if (const ComponentInfo* info = find_authored_component(component)) {
      if (ImGui::SmallButton(("Remove " + component).c_str()))
        report(ui, doc.undo().remove_component(w, e, *info), "removed " + component + " (Ctrl+Z brings it back)");
    }
  }
  // The lighting components this entity can take, at the Bake panel's preset.
  ImGui::Separator();
  if (ImGui::BeginCombo("##add", "Add lighting component")) {
    for (const ComponentInfo* info : authored_component_infos()) {
      if (info->present(w, e)) continue;
      const bool fits = !info->on_mesh || w.has<Mesh>(e);
      if (!fits) ImGui::BeginDisabled();
      if (ImGui::Selectable(std::string(info->name).c_str()))
        report(ui, doc.undo().add_component(w, e, *info, ui.add_preset), "added " + std::string(info->name));
      if (!fits) {
        ImGui::EndDisabled();
        if (ImGui::IsItemHovered(ImGuiHoveredFlags_AllowWhenDisabled)) ImGui::SetTooltip("goes on an entity with a Mesh");
      }
    }
    ImGui::EndCombo();
  }
  module_lines(w, e);
  ImGui::End();
}

// --- Bake --------------------------------------------------------------------------------------

void bake_panel(EditorModel& model, UiState& ui) {
  place(Panel::Bake, ui);
  ImGui::Begin("Bake");
  int preset = static_cast<int>(model.bake_settings.preset);
  ImGui::Combo("preset", &preset, "draft\0medium\0high\0");
  model.bake_settings.preset = static_cast<Preset>(preset);
  const bool running = model.bakes().running();
  if (running) ImGui::BeginDisabled();
  if (ImGui::Button("Bake everything")) report(ui, model.bake({}), "bake started");
  ImGui::SameLine();
  if (ImGui::Button("Bake selection")) report(ui, model.bake_selection(), "bake started");
  ImGui::SameLine();
  if (ImGui::Button("Estimate")) report(ui, model.estimate(), "estimating the bake from samples of it");
  if (ImGui::IsItemHovered())
    ImGui::SetTooltip("times a few samples of each component's bake at this preset and extrapolates: time and "
                      "bytes per module and component, in a fraction of the bake's time");
  if (running) ImGui::EndDisabled();
  if (!running) ImGui::BeginDisabled();
  ImGui::SameLine();
  if (ImGui::Button("Cancel")) model.bakes().cancel();
  if (!running) ImGui::EndDisabled();

  const BakeStatus s = model.bakes().status();
  ImGui::Text("%s  %.2f s", to_string(s.state), s.seconds);
  // The stages while a bake runs (and where a failed or cancelled one stopped); once it is done,
  // the report per module says what each took.
  for (std::size_t i = 0; s.state != BakeStatus::State::Done && i < s.stages.size(); ++i) {
    char overlay[96];
    std::snprintf(overlay, sizeof overlay, "%zu/%d %s", i + 1, s.stage_count, s.stages[i].name.c_str());
    ImGui::ProgressBar(static_cast<float>(s.stages[i].fraction), ImVec2(-1, 0), overlay);
  }
  const BakeEstimate* estimate = model.estimate_for(ui.input_hash);
  if (estimate) {
    ImGui::Text("estimate at %s: %.2f s", to_string(model.bake_settings.preset), estimate->seconds());
    for (const BakeEstimate::Item& item : estimate->items)
      ImGui::TextDisabled("%s: ~%.2f s, %s", item.baker.c_str(), item.seconds,
                          item.bytes ? format_bytes(*item.bytes).c_str() : "bytes known after the bake");
  } else if (model.estimated()) {
    ImGui::TextDisabled("the scene or the preset changed since the estimate: estimate again");
  }
  if (s.state == BakeStatus::State::Done && !s.estimating) {
    ImGui::Text("%s in %.2f s", format_bytes(s.bytes).c_str(), s.seconds);
    ImGui::TextDisabled("ray scene %.3f s, %zu triangles", s.report.ray_scene_seconds, s.report.triangles);
    for (const auto& item : s.report.items)
      ImGui::TextDisabled("%s: %.2f s, %s", item.baker.c_str(), item.seconds, format_bytes(item.bytes).c_str());
  }
  if (!s.error.empty()) ImGui::TextWrapped("%s", s.error.c_str());
  ImGui::Checkbox("auto-bake what changed", &model.auto_bake);
  if (ImGui::IsItemHovered())
    ImGui::SetTooltip("bakes the components that are never baked or out of date once the edits have settled "
                      "for %.1f s", model.auto_bake_delay);
  if (!model.auto_bake_status().empty()) ImGui::TextDisabled("%s", model.auto_bake_status().c_str());
  // Each lighting component's state against the scene as it is now.
  ImGui::Separator();
  ImGui::TextUnformatted("Lighting components");
  Document& doc = *model.document();
  for (const BakeState& state : ui.bake_states) {
    if (state.entity && !doc.world().alive(state.entity)) continue;  // deleted since the refresh
    const std::string name = state.entity ? doc.label(state.entity) : std::string("(whole scene)");
    ImGui::PushID(&state);
    if (state.entity && ImGui::SmallButton("select")) doc.select(state.entity);
    if (state.entity) ImGui::SameLine();
    ImGui::Text("%s  %s", state.module.c_str(), name.c_str());
    ImGui::Indent();
    bake_state_text(state);
    // The estimate of this component's part of the bake (its groups: the entity key names them).
    if (estimate && state.freshness != Freshness::UpToDate) {
      const std::string key = state.entity ? entity_key(doc.world(), state.entity) : std::string();
      double seconds = 0.0;
      std::uint64_t bytes = 0;
      bool found = false, sized = false;
      for (const BakeEstimate::Group& g : estimate->groups)
        if (g.baker == state.module && (!state.entity || g.name == key)) seconds += g.seconds, found = true;
      for (const BakeEstimate::Part& p : estimate->parts)
        if (p.baker == state.module && (!state.entity || p.key == key)) bytes += p.bytes, sized = true;
      if (found || sized) {
        ImGui::SameLine();
        if (found && sized) ImGui::TextDisabled("(baking it: ~%.2f s, ~%s)", seconds, format_bytes(bytes).c_str());
        else if (found) ImGui::TextDisabled("(baking it: ~%.2f s)", seconds);
        else ImGui::TextDisabled("(baking it: ~%s, its time in another's)", format_bytes(bytes).c_str());
      }
    }
    ImGui::Unindent();
    ImGui::PopID();
  }
  ImGui::End();
}

// --- Stats -------------------------------------------------------------------------------------

void stats_panel(EditorModel& model, UiState& ui) {
  place(Panel::Stats, ui);
  ImGui::Begin("Stats");
  const std::vector<float> recent(ui.frames.recent_ms.begin(), ui.frames.recent_ms.end());
  const float last = recent.empty() ? 0.0f : recent.back();
  if (!ui.frames.wait_ms.empty())
    ImGui::Text("frame %.1f ms: GPU wait %.1f, record %.1f, submit+present %.1f", last, ui.frames.wait_ms.back(),
                ui.frames.record_ms.back(), ui.frames.present_ms.back());
  ImGui::Text("renderer record %.2f ms, %u draws, shadow layers drawn %u of %u", ui.renderer_stats.cpu_record_ms,
              ui.renderer_stats.draws, ui.renderer_stats.shadow_layers_rendered, ui.renderer_stats.shadow_layers);
  if (!recent.empty()) ImGui::PlotLines("##frames", recent.data(), static_cast<int>(recent.size()), 0, "frame ms", 0.0f, 100.0f, ImVec2(-1, 40));
  ImGui::Text("GPU memory %s", format_bytes(ui.renderer_stats.gpu_bytes).c_str());
  if (ImGui::BeginTable("systems", 2, ImGuiTableFlags_RowBg)) {
    for (const SystemInfo& sys : model.document()->world().systems()) {
      ImGui::TableNextColumn();
      ImGui::TextUnformatted(sys.name.c_str());
      ImGui::TableNextColumn();
      ImGui::Text("%.3f ms", sys.last_ms);
    }
    ImGui::EndTable();
  }
  const Document& doc = *model.document();
  if (doc.has_bake()) {
    ImGui::Separator();
    for (const BakeChunk& c : doc.baked().chunks)
      ImGui::Text("%s %-14s %s", fourcc_to_string(c.type).c_str(), c.label.c_str(), format_bytes(c.payload.size()).c_str());
  }
  ImGui::End();
}

// --- Visualisation -----------------------------------------------------------------------------

void view_panel(EditorModel& model, UiState& ui) {
  place(Panel::View, ui);
  ImGui::Begin("View");
  if (ImGui::BeginCombo("debug view", ui.render.view.c_str())) {
    for (const ViewInfo& v : ui.views) {
      if (ImGui::Selectable(std::string(v.name).c_str(), v.name == ui.render.view)) ui.render.view = v.name;
      if (ImGui::IsItemHovered()) ImGui::SetTooltip("%s", std::string(v.description).c_str());
    }
    ImGui::EndCombo();
  }
  ImGui::DragFloat("exposure", &ui.render.exposure, 0.01f, 0.01f, 100.0f);
  ImGui::TextUnformatted("gizmo");
  for (GizmoMode m : {GizmoMode::Move, GizmoMode::Rotate, GizmoMode::Scale}) {
    ImGui::SameLine();
    if (ImGui::RadioButton(to_string(m), ui.gizmo_mode == m)) ui.gizmo_mode = m;
  }
  ImGui::SliderFloat("3D resolution", &ui.render_scale, 0.25f, 1.0f, "x%.2f");
  ImGui::SliderInt("fps while baking", &ui.bake_fps, 0, 60, ui.bake_fps == 0 ? "no limit" : "%d");
  if (ImGui::IsItemHovered())
    ImGui::SetTooltip("the viewport draws at most this often while a bake runs, leaving the cores to the bake");
  ImGui::SliderFloat("3D resolution while baking", &ui.bake_render_scale, 0.25f, 1.0f, "x%.2f");
  ImGui::Checkbox("shadows", &ui.render.shadows);
  ImGui::SameLine();
  int shadow = static_cast<int>(ui.render.shadow_map_size);
  if (ImGui::InputInt("shadow map", &shadow, 256)) ui.render.shadow_map_size = static_cast<std::uint32_t>(std::clamp(shadow, 64, 4096));
  // The renderer's speed/quality trades (RenderSettings::shadow_taps, ambient_step).
  int taps = ui.render.shadow_taps == 1 ? 0 : ui.render.shadow_taps == 4 ? 1 : 2;
  if (ImGui::Combo("shadow filter", &taps, "hard (1 tap)\0tent (4 taps)\0rect lights soft (16 taps)\0"))
    ui.render.shadow_taps = taps == 0 ? 1u : taps == 1 ? 4u : 16u;
  bool half = ui.render.ambient_step == 2;
  if (ImGui::Checkbox("ambient at half resolution", &half)) ui.render.ambient_step = half ? 2 : 1;
  int mode = ui.camera.mode() == CameraControl::Mode::Orbit ? 0 : 1;
  if (ImGui::Combo("camera", &mode, "orbit (drag, wheel, middle-drag)\0fly (drag, WASD QE)\0"))
    ui.camera.set_mode(mode == 0 ? CameraControl::Mode::Orbit : CameraControl::Mode::Fly);
  World& world = model.document()->world();
  if (ImGui::Button("Scene camera") && !look_through_scene_camera(world, posed_bounds(world), ui.camera))
    ui.message = "the scene has no camera";
  if (ImGui::IsItemHovered()) ImGui::SetTooltip("look through the scene's first camera");
  ImGui::SameLine();
  if (ImGui::Button("Frame all")) ui.camera.frame(posed_bounds(world));
  // The whole real-time path against the offline reference of this frame (reference_map.h).
  if (ui.reference_job.running()) {
    if (ImGui::Button("Lit view vs reference: rendering (cancel)")) ui.reference_job.cancel();
  } else if (ImGui::Button("Lit view vs offline reference")) {
    ui.reference_requested = true;
  }
  if (ImGui::IsItemHovered())
    ImGui::SetTooltip("heat map of the lit view against a converged CPU render of this frame, in the background");
  ImGui::SameLine();
  ImGui::SetNextItemWidth(120.0f);
  ImGui::SliderInt("reference spp", &ui.reference_spp, 4, 1024, "%d", ImGuiSliderFlags_Logarithmic);
  if (ImGui::IsItemHovered())
    ImGui::SetTooltip("the reference's paths per pixel: its noise falls as 1 / sqrt(spp), its time grows with them");
  if (ui.reference_map) {
    ImGui::TextWrapped("%s", describe_reference_map(*ui.reference_map).c_str());
    if (ImGui::SmallButton("clear the reference map")) ui.reference_map.reset();
  }
  // Each module's controls (overlays, its own views).
  ViewContext view{model.document()->world(), model.document()->selection(), ui.camera_now, {}, ui.message};
  for (const EditorExtension& x : editor_extensions())
    if (x.view_options) x.view_options(view);
  ImGui::End();
}

CostPlotSource cost_plot_source(World& world, Entity e) {
  const auto extensions = editor_extensions();
  for (const EditorExtension& x : extensions)
    if (x.cost_plot && world.alive(e) && x.applies(world, e)) return x.cost_plot(world, e);
  for (const EditorExtension& x : extensions)
    if (x.cost_plot) return x.cost_plot(world, Entity::null());
  return {};
}

// A log-log scatter of `plot` filling the rest of the window: decade ticks with their values on
// both axes, the axes' names, marked points larger and yellow, the hovered point's label.
void draw_log_plot(const CostPlot& plot) {
  const ImVec2 corner = ImGui::GetCursorScreenPos();
  const ImVec2 avail(ImGui::GetContentRegionAvail().x, std::max(ImGui::GetContentRegionAvail().y, 60.0f));
  const float left = 44.0f, bottom = 30.0f;  // room for the tick values and the axis names
  const ImVec2 origin(corner.x + left, corner.y);
  const ImVec2 size(std::max(avail.x - left, 20.0f), std::max(avail.y - bottom, 20.0f));
  ImDrawList* dl = ImGui::GetWindowDrawList();
  dl->AddRectFilled(origin, ImVec2(origin.x + size.x, origin.y + size.y), IM_COL32(20, 20, 24, 255));
  const auto [xmin, xmax] = std::minmax_element(plot.x.begin(), plot.x.end());
  const auto [ymin, ymax] = std::minmax_element(plot.y.begin(), plot.y.end());
  const auto lg = [](float v) { return std::log10(std::max(v, 1e-9f)); };
  // Whole decades around the data, at least one wide.
  const float x0 = std::floor(lg(*xmin)), x1 = std::max(std::ceil(lg(*xmax)), x0 + 1.0f);
  const float y0 = std::floor(lg(*ymin)), y1 = std::max(std::ceil(lg(*ymax)), y0 + 1.0f);
  const auto px = [&](float v) { return origin.x + 4 + (lg(v) - x0) / (x1 - x0) * (size.x - 8); };
  const auto py = [&](float v) { return origin.y + size.y - 4 - (lg(v) - y0) / (y1 - y0) * (size.y - 8); };
  const ImU32 grid = IM_COL32(70, 70, 80, 255), text = IM_COL32(200, 200, 200, 255);
  char value[32];
  for (float d = x0; d <= x1 + 0.5f; d += 1.0f) {
    const float x = px(std::pow(10.0f, d));
    dl->AddLine(ImVec2(x, origin.y), ImVec2(x, origin.y + size.y), grid);
    std::snprintf(value, sizeof value, "%g", std::pow(10.0, d));
    dl->AddText(ImVec2(x - 8, origin.y + size.y + 1), text, value);
  }
  for (float d = y0; d <= y1 + 0.5f; d += 1.0f) {
    const float y = py(std::pow(10.0f, d));
    dl->AddLine(ImVec2(origin.x, y), ImVec2(origin.x + size.x, y), grid);
    std::snprintf(value, sizeof value, "%g", std::pow(10.0, d));
    dl->AddText(ImVec2(corner.x, y - 7), text, value);
  }
  dl->AddText(ImVec2(origin.x + size.x - ImGui::CalcTextSize(plot.x_label.c_str()).x, origin.y + size.y + 14), text,
              plot.x_label.c_str());
  dl->AddText(ImVec2(origin.x + 4, origin.y + 2), text, plot.y_label.c_str());
  const ImVec2 mouse = ImGui::GetIO().MousePos;
  for (std::size_t i = 0; i < plot.x.size(); ++i) {
    const ImVec2 p(px(plot.x[i]), py(plot.y[i]));
    const bool marked = i < plot.marked.size() && plot.marked[i];
    dl->AddCircleFilled(p, marked ? 4.0f : 3.0f, marked ? IM_COL32(255, 200, 60, 255) : IM_COL32(90, 180, 255, 255));
    if (std::abs(mouse.x - p.x) < 4 && std::abs(mouse.y - p.y) < 4)
      ImGui::SetTooltip("%s\n%s %.4g, %s %.4g", plot.labels[i].c_str(), plot.x_label.c_str(), plot.x[i],
                        plot.y_label.c_str(), plot.y[i]);
  }
  ImGui::Dummy(avail);
}

void plot_panel(EditorModel& model, UiState& ui) {
  Document& doc = *model.document();
  place(Panel::Plot, ui);
  ImGui::Begin("Error vs cost");
  int mode = ui.plot_scene ? 1 : 0;
  ImGui::RadioButton("bench results", &mode, 0);
  ImGui::SameLine();
  ImGui::RadioButton("this scene's presets", &mode, 1);
  if ((mode == 1) != ui.plot_scene) ui.bake_states_time = -1.0;  // hash the presets now
  ui.plot_scene = mode == 1;
  if (ui.plot_scene) {
    // The open scene: estimated time against bytes at each preset (bake/estimate.h).
    const bool running = model.bakes().running();
    if (running) ImGui::BeginDisabled();
    if (ImGui::Button("Estimate draft, medium, high"))
      report(ui, model.estimate_presets(), "estimating each preset from samples of its bake");
    ImGui::SameLine();
    if (ImGui::Button("Bake each"))
      report(ui, model.estimate_presets(true), "baking each preset to measure it (nothing is kept)");
    if (ImGui::IsItemHovered())
      ImGui::SetTooltip("bakes the scene at each preset on a copy and plots what each took: exact, at the "
                        "bakes' cost; the scene's own bake is left as it is");
    if (running) ImGui::EndDisabled();
    const CostPlot plot = scene_cost_plot(model, ui.preset_hashes);
    if (!plot.error.empty()) ImGui::TextWrapped("%s", plot.error.c_str());
    else draw_log_plot(plot);
    ImGui::End();
    return;
  }
  // The plot follows the selected component: its bench's CSV in the tool's default folder, the
  // rows of its current mode marked (cost_plot_source's default bench without a lighting selection).
  const CostPlotSource source = cost_plot_source(doc.world(), doc.selection());
  const std::string key = source.bench + "|" + source.mark_value;
  bool reload = false;
  if (key != ui.plot_source) {
    if (ui.plot_source.rfind(source.bench + "|", 0) != 0)  // another bench: its default CSV
      std::snprintf(ui.bench_path, sizeof ui.bench_path, "bench-results/%s.csv", source.bench.c_str());
    ui.plot_source = key;
    reload = true;
  }
  ImGui::InputText("csv", ui.bench_path, sizeof ui.bench_path);
  if (ImGui::Button("Load") || reload)
    ui.plot = read_cost_plot(ui.bench_path, "bake_s", source.y_column, source.mark_column, source.mark_value);
  if (!source.mark_value.empty()) {
    ImGui::SameLine();
    ImGui::TextDisabled("marked: %s", source.mark_value.c_str());
  }
  if (!ui.plot.error.empty()) ImGui::TextWrapped("%s", ui.plot.error.c_str());
  else draw_log_plot(ui.plot);
  ImGui::End();
}

// --- Menus and status --------------------------------------------------------------------------

void menu_bar(EditorModel& model, UiState& ui) {
  Document& doc = *model.document();
  if (!ImGui::BeginMainMenuBar()) return;
  if (ImGui::BeginMenu("File")) {
    for (const std::string& name : builtin_scene_names())
      if (ImGui::MenuItem(("Open builtin:" + name).c_str())) ui.open_request = "builtin:" + name;
    ImGui::Separator();
    ImGui::InputText("scene", ui.scene_path, sizeof ui.scene_path);
    if (ImGui::MenuItem("Open scene (glTF or builtin:NAME)")) ui.open_request = ui.scene_path;
    ImGui::InputText("glTF", ui.gltf_path, sizeof ui.gltf_path);
    if (ImGui::MenuItem("Save scene as glTF"))
      report(ui, doc.save_gltf(ui.gltf_path), std::string("saved ") + ui.gltf_path);
    if (ImGui::MenuItem("Save edits as script")) report(ui, doc.save_edits(ui.edits_path), "saved edits");
    ImGui::InputText("edits", ui.edits_path, sizeof ui.edits_path);
    ImGui::Separator();
    ImGui::InputText(".pbake", ui.bake_path, sizeof ui.bake_path);
    if (ImGui::MenuItem("Open .pbake")) report(ui, doc.open_bake(ui.bake_path), std::string("loaded ") + ui.bake_path);
    if (ImGui::MenuItem("Save .pbake", nullptr, false, doc.has_bake()))
      report(ui, doc.save_bake(ui.bake_path), std::string("saved ") + ui.bake_path);
    ImGui::EndMenu();
  }
  if (ImGui::BeginMenu("Edit")) {
    if (ImGui::MenuItem("Undo", "Ctrl+Z", false, doc.undo().can_undo())) doc.undo_edit();
    if (ImGui::MenuItem("Redo", "Ctrl+Y", false, doc.undo().can_redo())) doc.redo_edit();
    ImGui::Separator();
    const bool selected = doc.world().alive(doc.selection());
    if (ImGui::MenuItem("Duplicate", "Ctrl+D", false, selected)) request_duplicate(ui, doc.selection());
    if (ImGui::MenuItem("Delete", "Del", false, selected)) request_delete(ui, doc.selection());
    ImGui::EndMenu();
  }
  if (ImGui::BeginMenu("Create")) {
    create_menu_items(ui, doc.selection());
    ImGui::EndMenu();
  }
  ImGui::EndMainMenuBar();
}

void status_bar(const UiState& ui) {
  const ImGuiViewport* vp = ImGui::GetMainViewport();
  ImGui::SetNextWindowPos(ImVec2(vp->Pos.x, vp->Pos.y + vp->Size.y - 22));
  ImGui::SetNextWindowSize(ImVec2(vp->Size.x, 22));
  ImGui::Begin("##status", nullptr,
               ImGuiWindowFlags_NoDecoration | ImGuiWindowFlags_NoInputs | ImGuiWindowFlags_NoSavedSettings |
                   ImGuiWindowFlags_NoFocusOnAppearing | ImGuiWindowFlags_NoBringToFrontOnFocus);
  ImGui::TextUnformatted(ui.message.c_str());
  ImGui::End();
}

}  // namespace

void draw_panels(EditorModel& model, UiState& ui) {
  if (!model.document() || !ui.show_ui) return;
  const ImVec2 window = ImGui::GetMainViewport()->Size;
  ui.relayout = window.x != ui.laid_out_for.x || window.y != ui.laid_out_for.y;
  ui.laid_out_for = glm::vec2(window.x, window.y);
  menu_bar(model, ui);
  Document& doc = *model.document();
  // Keyboard undo/redo when no text field has focus.
  const ImGuiIO& io = ImGui::GetIO();
  if (io.KeyCtrl && !io.WantTextInput) {
    if (ImGui::IsKeyPressed(ImGui::GetKeyIndex(ImGuiKey_Z))) doc.undo_edit();
    if (ImGui::IsKeyPressed(ImGui::GetKeyIndex(ImGuiKey_Y))) doc.redo_edit();
    // 1.86 names no D key; the GLFW backend indexes keys by GLFW codes, ASCII for letters.
    if (ImGui::IsKeyPressed('D') && doc.world().alive(doc.selection()))
      request_duplicate(ui, doc.selection());
  }
  if (!io.WantTextInput && ImGui::IsKeyPressed(ImGui::GetKeyIndex(ImGuiKey_Delete)) &&
      doc.world().alive(doc.selection()))
    request_delete(ui, doc.selection());
  ui.add_preset = model.bake_settings.preset;  // an added component starts from the Bake panel's preset
  if (ImGui::GetTime() - ui.bake_states_time > 0.25 || ui.bake_states_document != &doc) {
    ui.bake_states = model.bake_states();
    ui.input_hash = model.input_hash();
    if (ui.plot_scene)
      for (Preset q : {Preset::Draft, Preset::Medium, Preset::High})
        ui.preset_hashes[static_cast<int>(q)] = model.input_hash(q);
    ui.bake_states_time = ImGui::GetTime();
    ui.bake_states_document = &doc;
  }
  hierarchy_panel(doc, ui);
  inspector_panel(doc, ui);
  bake_panel(model, ui);
  stats_panel(model, ui);
  view_panel(model, ui);
  plot_panel(model, ui);
  status_bar(ui);
  if (ui.entity_request) {
    std::exchange(ui.entity_request, {})(doc);
  }
}

}  // namespace penumbra::editor
