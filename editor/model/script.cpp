// Script parsing and replay (script.h).
#include "script.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <optional>
#include <fstream>
#include <sstream>

namespace penumbra::editor {

namespace {

// The actions the window carries out (at the next frame).
bool is_viewport_action(const std::string& verb) {
  return verb == "screenshot" || verb == "orbit" || verb == "view" || verb == "ui" || verb == "click" ||
         verb == "gizmo" || verb == "drag-gizmo" || verb == "reset-stats" || verb == "reference-map";
}

// Splits a line into words; "double quotes" group words. False on an unterminated quote.
bool split_words(std::string_view line, std::vector<std::string>& words) {
  std::size_t i = 0;
  while (i < line.size()) {
    while (i < line.size() && (line[i] == ' ' || line[i] == '\t' || line[i] == '\r')) ++i;
    if (i == line.size()) break;
    std::string word;
    if (line[i] == '"') {
      const std::size_t end = line.find('"', i + 1);
      if (end == std::string_view::npos) return false;
      word = std::string(line.substr(i + 1, end - i - 1));
      i = end + 1;
    } else {
      while (i < line.size() && line[i] != ' ' && line[i] != '\t' && line[i] != '\r') word += line[i++];
    }
    words.push_back(std::move(word));
  }
  return true;
}

bool parse_int(std::string_view text, long long& out) {
  const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), out);
  return ec == std::errc() && end == text.data() + text.size();
}
bool parse_number(std::string_view text, double& out) {
  const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), out);
  return ec == std::errc() && end == text.data() + text.size();
}

// expect-bake's words for the states: to_string(Freshness) with '-' for ' '.
std::optional<Freshness> parse_freshness(std::string_view word) {
  for (Freshness f : {Freshness::NeverBaked, Freshness::UpToDate, Freshness::OutOfDate, Freshness::Loaded}) {
    std::string name = to_string(f);
    std::replace(name.begin(), name.end(), ' ', '-');
    if (name == word) return f;
  }
  return std::nullopt;
}

// The arity and argument rules of each verb; "" when the action is well formed.
std::string check_action(const ScriptAction& a) {
  const std::size_t n = a.args.size();
  const std::string& v = a.verb;
  const auto preset_ok = [](const std::string& s) { return parse_preset(s).ok(); };
  if (v == "open") {
    if (n < 1 || n > 2 || (n == 2 && !preset_ok(a.args[1])))
      return "'open' takes a scene (builtin:NAME or a .gltf/.glb path) and an optional preset (draft, medium, high)";
  } else if (v == "open-bake" || v == "save-bake" || v == "save-edits" || v == "save-gltf" || v == "screenshot") {
    if (n != 1) return "'" + v + "' takes one PATH";
  } else if (v == "select") {
    if (n != 1) return "'select' takes one entity: its Name (quoted when it has blanks) or #INDEX";
  } else if (v == "set") {
    if (n < 3) return "'set' takes an entity, COMPONENT.FIELD and a value, e.g. set lamp Light.intensity 40";
    const std::size_t dot = a.args[1].find('.');
    if (dot == std::string::npos)
      return "'set': '" + a.args[1] + "' is not COMPONENT.FIELD (e.g. Transform.translation)";
    const FieldDesc* f = find_field(a.args[1].substr(0, dot), a.args[1].substr(dot + 1));
    if (f == nullptr) return "'set': no editable field " + a.args[1] + "; the inspector lists the fields";
    if (f->read_only) return "'set': " + a.args[1] + " is written by the runtime and cannot be set";
    std::string value;
    for (std::size_t i = 2; i < n; ++i) value += (i > 2 ? " " : "") + a.args[i];
    if (auto parsed = parse_field_value(*f, value); !parsed) return "'set': " + parsed.error().message;
  } else if (v == "add" || v == "remove") {
    if (n != 2) return "'" + v + "' takes an entity and a lighting component, e.g. " + v + " crate AOFieldCaster";
    if (find_authored_component(a.args[1]) == nullptr)
      return "'" + v + "': no lighting component '" + a.args[1] + "' can be added; use " + authored_component_names();
  } else if (v == "estimate") {
    if (n > 2 || (n >= 1 && !preset_ok(a.args[0]) && a.args[0] != "all") ||
        (n == 2 && (a.args[0] != "all" || a.args[1] != "exact")))
      return "'estimate' takes an optional preset (draft, medium, high) or all (each in turn; 'all exact' bakes "
             "each); 'wait' then waits for it";
  } else if (v == "create") {
    if (n < 2 || n > 3 ||
        std::find(std::begin(Document::kEntityKinds), std::end(Document::kEntityKinds), a.args[0]) ==
            std::end(Document::kEntityKinds))
      return "'create' takes a kind (empty, point-light, spot-light, directional-light, rect-light), a name and an "
             "optional parent, e.g. create point-light lamp2";
  } else if (v == "duplicate" || v == "delete") {
    if (n != 1) return "'" + v + "' takes one entity: its Name (quoted when it has blanks) or #INDEX";
  } else if (v == "preset") {
    if (n != 3) return "'preset' takes an entity, a lighting module's name and a preset (draft, medium, high)";
    if (find_preset(a.args[1]) == nullptr) {
      std::string known;
      for (const auto& p : component_presets()) known += (known.empty() ? "" : ", ") + p.technique;
      return "'preset': unknown technique '" + a.args[1] + "'; use " + known;
    }
    if (!preset_ok(a.args[2])) return "'preset': unknown preset '" + a.args[2] + "'; use draft, medium or high";
  } else if (v == "bake") {
    if (n < 1 || n > 2 || a.args[0].empty() || (n == 2 && !preset_ok(a.args[1])))
      return "'bake' takes all, selection or lighting module names (comma-separated), then an optional preset "
             "(draft, medium, high)";
  } else if (v == "auto-bake") {
    double delay = 0.0;
    if (n < 1 || n > 2 || (a.args[0] != "on" && a.args[0] != "off") ||
        (n == 2 && (!parse_number(a.args[1], delay) || delay < 0.0 || delay > 3600.0)))
      return "'auto-bake' takes on or off, then an optional delay in seconds (0 to 3600; default 1)";
  } else if (v == "expect-bake") {
    if (n != 2 || !parse_freshness(a.args[1]))
      return "'expect-bake' takes an entity (or all) and never-baked, up-to-date, out-of-date or loaded";
  } else if (v == "undo" || v == "redo" || v == "cancel" || v == "wait" || v == "reset-stats") {
    if (n != 0) return "'" + v + "' takes no arguments";
  } else if (v == "frames") {
    long long k = 0;
    if (n != 1 || !parse_int(a.args[0], k) || k < 1 || k > 1000000) return "'frames' takes a count from 1 to 1000000";
  } else if (v == "orbit") {
    double x = 0.0;
    bool ok = n == 2 || n == 3;
    for (const auto& s : a.args) ok = ok && parse_number(s, x);
    if (!ok) return "'orbit' takes YAW and PITCH in degrees and an optional DISTANCE in metres";
  } else if (v == "view") {
    if (n != 1) return "'view' takes a debug view: lit, direct, indirect, ao, albedo or validity";
  } else if (v == "ui") {
    if (n != 1 || (a.args[0] != "on" && a.args[0] != "off")) return "'ui' takes on or off (the panels over the viewport)";
  } else if (v == "click") {
    long long x = 0, y = 0;
    if (n != 2 || !parse_int(a.args[0], x) || !parse_int(a.args[1], y) || x < 0 || y < 0 || x > 16384 || y > 16384)
      return "'click' takes X and Y in window pixels from the top left, e.g. click 20 10";
  } else if (v == "gizmo") {
    if (n != 1 || (a.args[0] != "move" && a.args[0] != "rotate" && a.args[0] != "scale"))
      return "'gizmo' takes move, rotate or scale";
  } else if (v == "drag-gizmo") {
    double pixels = 0.0;
    if (n != 2 || (a.args[0] != "x" && a.args[0] != "y" && a.args[0] != "z") || !parse_number(a.args[1], pixels) ||
        std::abs(pixels) > 4096.0)
      return "'drag-gizmo' takes an axis (x, y or z) and a distance in pixels along its arrow (-4096 to 4096)";
  } else if (v == "reference-map") {
    long long spp = 0;
    if (n != 1 || !parse_int(a.args[0], spp) || spp < 2 || spp > 65536)
      return "'reference-map' takes the offline reference's paths per pixel (2 to 65536); it waits for the map";
  } else if (v == "quit") {
    long long k = 0;
    if (n > 1 || (n == 1 && (!parse_int(a.args[0], k) || k < 0 || k > 255)))
      return "'quit' takes an optional exit code from 0 to 255";
  } else {
    return "unknown action '" + v +
           "'; actions: open, open-bake, save-bake, save-edits, save-gltf, select, set, add, remove, create, duplicate, "
           "delete, preset, undo, redo, bake, estimate, cancel, wait, auto-bake, expect-bake, "
           "frames, screenshot, orbit, view, ui, click, drag-gizmo, reset-stats, gizmo, reference-map, quit";
  }
  return {};
}

std::vector<std::string> split_commas(const std::string& text) {
  std::vector<std::string> out;
  std::stringstream in(text);
  for (std::string item; std::getline(in, item, ',');)
    if (!item.empty()) out.push_back(item);
  return out;
}

}  // namespace

Result<Script> parse_script(std::string_view text, std::string_view name) {
  Script script;
  script.name = std::string(name);
  int line_no = 0;
  std::size_t pos = 0;
  while (pos <= text.size()) {
    const std::size_t end = std::min(text.find('\n', pos), text.size());
    const std::string_view line = text.substr(pos, end - pos);
    pos = end + 1;
    ++line_no;
    std::vector<std::string> words;
    const std::string where = std::string(name) + ":" + std::to_string(line_no) + ": ";
    if (!split_words(line, words))
      return make_error(ErrorCode::InvalidArgument, where + "unterminated quote; close it with \"");
    if (words.empty() || words[0].starts_with("#")) continue;
    ScriptAction action{words[0], {words.begin() + 1, words.end()}, line_no};
    if (const std::string problem = check_action(action); !problem.empty())
      return make_error(ErrorCode::InvalidArgument, where + problem);
    script.actions.push_back(std::move(action));
  }
  return script;
}

Result<Script> load_script(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in)
    return make_error(ErrorCode::NotFound, path.string() + ": cannot open the script; check the path");
  std::stringstream buffer;
  buffer << in.rdbuf();
  if (in.bad()) return make_error(ErrorCode::Io, path.string() + ": reading the script failed");
  return parse_script(buffer.str(), path.filename().string());
}

ScriptRunner::ScriptRunner(Script script, ViewportFn viewport)
    : script_(std::move(script)), viewport_(std::move(viewport)) {}

Status ScriptRunner::step(EditorModel& model) {
  while (!finished()) {
    const ScriptAction& a = script_.actions[next_];
    bool wait_here = false;
    const bool yields = is_viewport_action(a.verb);
    if (Status s = run(model, a, wait_here); !s) {
      next_ = script_.actions.size();
      exit_code_ = 1;
      return Error{s.error().code, script_.name + ":" + std::to_string(a.line) + ": " + a.verb + ": " +
                                       s.error().message};
    }
    if (wait_here) return {};
    ++next_;
    if (yields) return {};  // the viewport shows the change in the next frame
  }
  return {};
}

Status ScriptRunner::run(EditorModel& model, const ScriptAction& a, bool& wait_here) {
  const auto& args = a.args;
  if (a.verb == "open") return model.open(args[0], args.size() == 2 ? *parse_preset(args[1]) : Preset::Medium);
  if (a.verb == "quit") {
    quit_ = true;
    exit_code_ = args.empty() ? 0 : std::stoi(args[0]);
    return {};
  }
  if (a.verb == "frames") {
    if (frames_left_ < 0) frames_left_ = std::stoi(args[0]);
    wait_here = frames_left_-- > 0;
    if (!wait_here) frames_left_ = -1;
    return {};
  }
  if (is_viewport_action(a.verb)) {
    if (!viewport_) return make_error(ErrorCode::Unsupported, "needs the window (run without --headless)");
    return viewport_(a, wait_here);
  }

  Document* doc = model.document();
  if (doc == nullptr) return make_error(ErrorCode::InvalidArgument, "no scene is open; start with 'open SCENE'");
  World& world = doc->world();
  if (a.verb == "open-bake") return doc->open_bake(args[0]);
  if (a.verb == "save-bake") return doc->save_bake(args[0]);
  if (a.verb == "save-edits") return doc->save_edits(args[0]);
  if (a.verb == "save-gltf") return doc->save_gltf(args[0]);
  if (a.verb == "add" || a.verb == "remove") {
    auto e = doc->find(args[0]);
    if (!e) return e.error();
    const ComponentInfo& info = *find_authored_component(args[1]);
    return a.verb == "add" ? doc->undo().add_component(world, *e, info, model.bake_settings.preset)
                           : doc->undo().remove_component(world, *e, info);
  }
  if (a.verb == "create") {
    Entity parent;
    if (args.size() == 3) {
      auto p = doc->find(args[2]);
      if (!p) return p.error();
      parent = *p;
    }
    auto e = doc->create_entity(args[0], args[1], parent);
    return e ? Status{} : Status{e.error()};
  }
  if (a.verb == "duplicate" || a.verb == "delete") {
    auto e = doc->find(args[0]);
    if (!e) return e.error();
    if (a.verb == "delete") return doc->delete_entity(*e);
    auto copy = doc->duplicate(*e);
    return copy ? Status{} : Status{copy.error()};
  }
  if (a.verb == "select") {
    auto e = doc->find(args[0]);
    if (!e) return e.error();
    doc->select(*e);
    return {};
  }
  if (a.verb == "set") {
    auto e = doc->find(args[0]);
    if (!e) return e.error();
    const std::size_t dot = args[1].find('.');
    const FieldDesc* f = find_field(args[1].substr(0, dot), args[1].substr(dot + 1));
    std::string value;
    for (std::size_t i = 2; i < args.size(); ++i) value += (i > 2 ? " " : "") + args[i];
    auto parsed = parse_field_value(*f, value);
    if (!parsed) return parsed.error();
    return doc->undo().set(world, *e, *f, *parsed);
  }
  if (a.verb == "preset") {
    auto e = doc->find(args[0]);
    if (!e) return e.error();
    const ComponentPreset* p = find_preset(args[1]);
    if (!p->present(world, *e))
      return make_error(ErrorCode::InvalidArgument,
                        "'" + args[0] + "' has no " + p->component + " component; select one that has");
    const Preset q = *parse_preset(args[2]);
    const Entity entity = *e;
    return doc->undo().record(world, entity, p->component, "preset " + args[1] + " " + args[2],
                              [&] { p->apply(world, entity, q); });
  }
  if (a.verb == "undo") {
    if (!doc->undo_edit()) return make_error(ErrorCode::InvalidArgument, "nothing to undo");
    return {};
  }
  if (a.verb == "redo") {
    if (!doc->redo_edit()) return make_error(ErrorCode::InvalidArgument, "nothing to redo");
    return {};
  }
  if (a.verb == "bake") {
    if (args.size() == 2) model.bake_settings.preset = *parse_preset(args[1]);
    if (args[0] == "selection") return model.bake_selection();
    return model.bake(args[0] == "all" ? std::vector<std::string>{} : split_commas(args[0]));
  }
  if (a.verb == "estimate") {
    if (!args.empty() && args[0] == "all") return model.estimate_presets(args.size() == 2);
    if (args.size() == 1) model.bake_settings.preset = *parse_preset(args[0]);
    return model.estimate();
  }
  if (a.verb == "cancel") {
    model.bakes().cancel();
    return {};
  }
  if (a.verb == "auto-bake") {
    model.auto_bake = args[0] == "on";
    if (args.size() == 2) model.auto_bake_delay = std::stod(args[1]);
    return {};
  }
  if (a.verb == "expect-bake") {
    Entity only = Entity::null();
    if (args[0] != "all") {
      auto e = doc->find(args[0]);
      if (!e) return e.error();
      only = *e;
    }
    const Freshness expected = *parse_freshness(args[1]);
    std::string wrong;
    int checked = 0;
    for (const BakeState& state : model.bake_states()) {
      if (only && state.entity != only) continue;
      ++checked;
      if (state.freshness == expected) continue;
      wrong += std::string(wrong.empty() ? "" : "; ") + state.module + " " +
               (state.entity ? "on '" + doc->label(state.entity) + "' " : std::string()) + "is " +
               to_string(state.freshness) + (state.why.empty() ? "" : " (" + state.why + ")");
    }
    if (checked == 0)
      return make_error(ErrorCode::InvalidArgument, "'" + args[0] + "' has no lighting component to bake");
    if (!wrong.empty())
      return make_error(ErrorCode::InvalidInput, "expected " + args[1] + ", but " + wrong);
    return {};
  }
  if (a.verb == "wait") {
    // Read before poll(): a bake that ends between the two is then attached by the next frame's
    // poll() before the script goes on, never left unattached.
    const bool was_running = model.bakes().running();
    model.poll();  // attaches a finished bake; may start the next preset of `estimate all`
    if (was_running || model.bakes().running()) {
      wait_here = true;
      return {};
    }
    const BakeStatus status = model.bakes().status();
    if (status.state == BakeStatus::State::Failed)
      return make_error(ErrorCode::InvalidInput, std::string(status.estimating ? "the estimate" : "the bake") +
                                                     " failed: " + status.error);
    return {};
  }
  return make_error(ErrorCode::Internal, "unhandled action '" + a.verb + "'");
}

}  // namespace penumbra::editor
