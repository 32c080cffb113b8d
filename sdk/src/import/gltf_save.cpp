// save_gltf (penumbra/import/gltf.h): the source's JSON edited in place with nlohmann::ordered_json, so
// that everything the edits do not touch is written back as it was read; a .glb's binary chunk is
// copied byte for byte.
#include <algorithm>
#include <cmath>
#include <cstring>
#include <fstream>
#include <iterator>
#include <map>
#include <optional>
#include <set>
#include <sstream>

#include <glm/gtc/quaternion.hpp>
#include <glm/gtc/type_ptr.hpp>
#include <nlohmann/json.hpp>

#include "penumbra/core/file.h"
#include "penumbra/import/gltf.h"

#include "gltf_json.h"

namespace penumbra {

namespace {

constexpr std::uint32_t kGlbMagic = 0x46546C67u, kJsonChunk = 0x4E4F534Au, kBinChunk = 0x004E4942u;
constexpr int kLightingExtensionVersion = 1;  // as the importer reads

std::uint32_t get32(const std::string& s, std::size_t at) {
  std::uint32_t v = 0;
  std::memcpy(&v, s.data() + at, 4);
  return v;
}
void put32(std::string& s, std::uint32_t v) { s.append(reinterpret_cast<const char*>(&v), 4); }

nlohmann::ordered_json to_json(const AuthoredValue& v) {
  return std::visit([](const auto& x) { return nlohmann::ordered_json(x); }, v);
}

// The node's local matrix as the file gives it (matrix, else T R S; identity for what is absent);
// nullopt when the fields are malformed.
std::optional<glm::mat4> file_matrix(const nlohmann::ordered_json& node) {
  const auto numbers = [&](const char* key, std::size_t n) -> std::optional<std::vector<float>> {
    if (!node.contains(key)) return std::vector<float>{};
    const auto& a = node[key];
    if (!a.is_array() || a.size() != n) return std::nullopt;
    std::vector<float> out;
    for (const auto& x : a) {
      if (!x.is_number()) return std::nullopt;
      out.push_back(x.get<float>());
    }
    return out;
  };
  const auto m = numbers("matrix", 16);
  if (!m) return std::nullopt;
  if (!m->empty()) {
    glm::mat4 out;
    for (int i = 0; i < 16; ++i) glm::value_ptr(out)[i] = (*m)[static_cast<std::size_t>(i)];
    return out;
  }
  const auto t = numbers("translation", 3), r = numbers("rotation", 4), sc = numbers("scale", 3);
  if (!t || !r || !sc) return std::nullopt;
  Transform x;
  if (!t->empty()) x.translation = glm::vec3((*t)[0], (*t)[1], (*t)[2]);
  if (!r->empty()) x.rotation = glm::quat((*r)[3], (*r)[0], (*r)[1], (*r)[2]);
  if (!sc->empty()) x.scale = glm::vec3((*sc)[0], (*sc)[1], (*sc)[2]);
  return x.matrix();
}

// Whether two local matrices agree to float rounding (the importer's normalisation of the
// rotation, a matrix read back as TRS), so that an unchanged node keeps its fields as written.
bool same_matrix(const glm::mat4& a, const glm::mat4& b) {
  for (int c = 0; c < 4; ++c)
    for (int r = 0; r < 4; ++r)
      if (std::abs(a[c][r] - b[c][r]) > 1e-5f * (1.0f + std::abs(a[c][r]))) return false;
  return true;
}

// Sets object[key] to `values` (one number, or an array of them) unless it already holds them to
// float rounding, so that what did not change keeps the file's own digits.
void set_numbers(nlohmann::ordered_json& object, const char* key, std::vector<float> values) {
  if (object.contains(key)) {
    const auto& old = object[key];
    std::vector<double> have;
    if (old.is_number()) have.push_back(old.get<double>());
    if (old.is_array())
      for (const auto& x : old)
        if (x.is_number()) have.push_back(x.get<double>());
    bool same = have.size() == values.size();
    for (std::size_t i = 0; same && i < values.size(); ++i)
      same = std::abs(have[i] - double(values[i])) <= 1e-6 * (1.0 + std::abs(have[i]));
    if (same) return;
  }
  if (values.size() == 1) object[key] = values[0];
  else object[key] = values;
}

bool finite(const Transform& t) {
  const glm::vec4 q(t.rotation.x, t.rotation.y, t.rotation.z, t.rotation.w);
  return std::isfinite(glm::dot(t.translation, t.translation) + glm::dot(t.scale, t.scale) + glm::dot(q, q));
}

// Writes one node's edit (an existing node's, or a new one's after it was appended): transform,
// KHR_lights_punctual light, PENUMBRA_lighting. `j` is the whole file (for its lights array).
Status write_node(nlohmann::ordered_json& j, nlohmann::ordered_json& node, const std::string& where,
                  const GltfNodeEdit& edit) {
  if (edit.transform) {
    const Transform& t = *edit.transform;
    if (!finite(t)) return make_error(ErrorCode::InvalidArgument, where + ": the transform is not finite");
    const std::optional<glm::mat4> before = file_matrix(node);
    if (!before || !same_matrix(*before, t.matrix())) {
      node.erase("matrix");
      node["translation"] = {t.translation.x, t.translation.y, t.translation.z};
      node["rotation"] = {t.rotation.x, t.rotation.y, t.rotation.z, t.rotation.w};
      node["scale"] = {t.scale.x, t.scale.y, t.scale.z};
    }
  }
  if (edit.light) {
    const nlohmann::ordered_json* index = nullptr;
    if (node.contains("extensions") && node["extensions"].contains("KHR_lights_punctual"))
      index = &node["extensions"]["KHR_lights_punctual"]["light"];
    nlohmann::ordered_json* lights = nullptr;
    if (j.contains("extensions") && j["extensions"].contains("KHR_lights_punctual"))
      lights = &j["extensions"]["KHR_lights_punctual"]["lights"];
    if (index == nullptr || !index->is_number_unsigned() || lights == nullptr || !lights->is_array() ||
        index->get<std::size_t>() >= lights->size())
      return make_error(ErrorCode::InvalidArgument, where + ": has no KHR_lights_punctual light to write the Light to");
    nlohmann::ordered_json& light = (*lights)[index->get<std::size_t>()];
    if (!light.is_object())
      return make_error(ErrorCode::InvalidInput, where + ": its KHR_lights_punctual light is not an object");
    const Light& l = *edit.light;
    if (l.type == Light::Type::Rect)
      return make_error(ErrorCode::InvalidArgument, where + ": a rect light has no KHR_lights_punctual form; make it a "
                                                            "point, spot or directional light");
    light["type"] = l.type == Light::Type::Directional ? "directional" : l.type == Light::Type::Point ? "point" : "spot";
    if (l.color != glm::vec3(1.0f) || light.contains("color")) set_numbers(light, "color", {l.color.x, l.color.y, l.color.z});
    if (l.intensity != 1.0f || light.contains("intensity")) set_numbers(light, "intensity", {l.intensity});
    if (l.range > 0.0f) set_numbers(light, "range", {l.range});
    else light.erase("range");
    if (l.type == Light::Type::Spot) {
      if (!light.contains("spot") || !light["spot"].is_object()) light["spot"] = nlohmann::ordered_json::object();
      set_numbers(light["spot"], "innerConeAngle", {l.inner_cone_angle});
      set_numbers(light["spot"], "outerConeAngle", {l.outer_cone_angle});
    } else {
      light.erase("spot");
    }
  }
  // PENUMBRA_lighting, written whole (or removed).
  if (node.contains("extensions") && !node["extensions"].is_object())
    return make_error(ErrorCode::InvalidInput, where + ": extensions is not an object");
  if (edit.lighting.empty() && !edit.environment) {
    if (node.contains("extensions")) {
      node["extensions"].erase("PENUMBRA_lighting");
      if (node["extensions"].empty()) node.erase("extensions");
    }
  } else {
    nlohmann::ordered_json components = nlohmann::ordered_json::object();
    for (const AuthoredComponent& c : edit.lighting) {
      nlohmann::ordered_json body = nlohmann::ordered_json::object();
      if (!c.preset.empty()) body["preset"] = c.preset;
      for (const auto& [name, value] : c.fields) body[name] = to_json(value);
      components[c.type] = std::move(body);
    }
    nlohmann::ordered_json ext = {{"version", kLightingExtensionVersion}};
    if (!edit.lighting.empty()) ext["components"] = std::move(components);
    if (edit.environment && edit.environment->map_data) {
      const Environment& sky = *edit.environment;
      if (sky.map.empty())
        return make_error(ErrorCode::InvalidArgument, where + ": the sky's map has no file name; set Environment::map "
                                                              "to its OpenEXR file's path relative to the glTF");
      if (!(std::isfinite(sky.map_scale) && sky.map_scale >= 0.0f))
        return make_error(ErrorCode::InvalidArgument, where + ": the sky's map_scale is negative or not finite");
      ext["environment"] = {{"map", sky.map}, {"map_scale", sky.map_scale}};
    } else if (edit.environment) {
      const glm::vec3 l = edit.environment->radiance;
      if (!(std::isfinite(l.x) && std::isfinite(l.y) && std::isfinite(l.z) && l.x >= 0.0f && l.y >= 0.0f && l.z >= 0.0f))
        return make_error(ErrorCode::InvalidArgument, where + ": the sky's radiance is negative or not finite");
      ext["environment"] = {{"radiance", {l.x, l.y, l.z}}};
    }
    node["extensions"]["PENUMBRA_lighting"] = std::move(ext);
  }
  return {};
}

// Takes edits.removed out of the scene and appends edits.added, each linked under its parent or
// into the scene's root list, with its copy_of node's mesh, skin and camera and a new
// KHR_lights_punctual light for its Light. Keys added to `j` may move its members: every
// reference into it is taken afresh after one is added.
Status add_and_remove_nodes(nlohmann::ordered_json& j, const std::string& file, const GltfEdits& edits) {
  if (edits.added.empty() && edits.removed.empty()) return {};
  const std::size_t count = j["nodes"].size();
  // A file without scenes shows every parentless node: it gets one scene listing them, so that a
  // node taken out of it stays out.
  if (!j.contains("scenes") || !j["scenes"].is_array() || j["scenes"].empty()) {
    std::vector<bool> child(count, false);
    for (const nlohmann::ordered_json& node : j["nodes"])
      if (node.is_object() && node.contains("children") && node["children"].is_array())
        for (const nlohmann::ordered_json& c : node["children"])
          if (c.is_number_unsigned() && c.get<std::uint64_t>() < count) child[c.get<std::size_t>()] = true;
    nlohmann::ordered_json roots = nlohmann::ordered_json::array();
    for (std::size_t i = 0; i < count; ++i)
      if (!child[i]) roots.push_back(i);
    j["scenes"] = nlohmann::ordered_json::array({{{"nodes", std::move(roots)}}});
    j["scene"] = 0;
  }
  std::size_t scene = 0;
  if (j.contains("scene") && j["scene"].is_number_unsigned() && j["scene"].get<std::uint64_t>() < j["scenes"].size())
    scene = j["scene"].get<std::size_t>();
  if (!j["scenes"][scene].is_object())
    return make_error(ErrorCode::InvalidInput, file + ": scenes[" + std::to_string(scene) + "] is not an object");

  const std::set<std::uint32_t> removed(edits.removed.begin(), edits.removed.end());
  for (std::uint32_t r : removed)
    if (r >= count)
      return make_error(ErrorCode::InvalidArgument, file + ": nodes[" + std::to_string(r) + "] to remove does not exist (the file has " +
                                                        std::to_string(count) + " nodes)");
  const auto unlink = [&](nlohmann::ordered_json& list) {
    if (!list.is_array()) return;
    list.erase(std::remove_if(list.begin(), list.end(),
                              [&](const nlohmann::ordered_json& v) {
                                return v.is_number_unsigned() && v.get<std::uint64_t>() < count &&
                                       removed.contains(v.get<std::uint32_t>());
                              }),
               list.end());
  };
  for (nlohmann::ordered_json& node : j["nodes"])
    if (node.is_object() && node.contains("children")) unlink(node["children"]);
  for (nlohmann::ordered_json& sc : j["scenes"])
    if (sc.is_object() && sc.contains("nodes")) unlink(sc["nodes"]);

  for (std::size_t i = 0; i < edits.added.size(); ++i) {
    const GltfNewNode& a = edits.added[i];
    const std::size_t index = count + i;
    const std::string where = file + ": the new node '" + a.name + "'";
    nlohmann::ordered_json node = nlohmann::ordered_json::object();
    if (!a.name.empty()) node["name"] = a.name;
    if (a.copy_of) {
      if (*a.copy_of >= count || !j["nodes"][*a.copy_of].is_object())
        return make_error(ErrorCode::InvalidArgument, where + " copies nodes[" + std::to_string(*a.copy_of) +
                                                          "], which is not a node of the file");
      const nlohmann::ordered_json& from = j["nodes"][*a.copy_of];
      for (const char* key : {"mesh", "skin", "camera"})
        if (from.contains(key)) node[key] = from[key];
    }
    if (a.light) {
      // The file's lights list, made where absent; refused where the file has another shape.
      nlohmann::ordered_json& ext = j["extensions"];
      if (ext.is_null()) ext = nlohmann::ordered_json::object();
      if (!ext.is_object()) return make_error(ErrorCode::InvalidInput, file + ": extensions is not an object");
      nlohmann::ordered_json& punctual = ext["KHR_lights_punctual"];
      if (punctual.is_null()) punctual = nlohmann::ordered_json::object();
      if (!punctual.is_object())
        return make_error(ErrorCode::InvalidInput, file + ": extensions.KHR_lights_punctual is not an object");
      nlohmann::ordered_json& lights = punctual["lights"];
      if (lights.is_null()) lights = nlohmann::ordered_json::array();
      if (!lights.is_array())
        return make_error(ErrorCode::InvalidInput, file + ": extensions.KHR_lights_punctual.lights is not an array");
      lights.push_back({{"type", "point"}});
      node["extensions"]["KHR_lights_punctual"] = {{"light", lights.size() - 1}};
      nlohmann::ordered_json& used = j["extensionsUsed"];
      if (used.is_null()) used = nlohmann::ordered_json::array();
      if (!used.is_array()) return make_error(ErrorCode::InvalidInput, file + ": extensionsUsed is not an array");
      if (std::find(used.begin(), used.end(), "KHR_lights_punctual") == used.end()) used.push_back("KHR_lights_punctual");
    }
    nlohmann::ordered_json* parent = nullptr;
    if (a.parent) {
      if (*a.parent >= count)
        return make_error(ErrorCode::InvalidArgument, where + ": its parent nodes[" + std::to_string(*a.parent) +
                                                          "] is not a node of the file");
      parent = &j["nodes"][*a.parent];
    } else if (a.added_parent) {
      if (*a.added_parent >= i)
        return make_error(ErrorCode::InvalidArgument, where + ": its parent must be added before it");
      parent = &j["nodes"][count + *a.added_parent];
    }
    if (parent != nullptr) {
      if (!parent->is_object()) return make_error(ErrorCode::InvalidInput, where + ": its parent is not an object");
      nlohmann::ordered_json& children = (*parent)["children"];
      if (!children.is_array()) children = nlohmann::ordered_json::array();
      children.push_back(index);
    } else {
      nlohmann::ordered_json& roots = j["scenes"][scene]["nodes"];
      if (!roots.is_array()) roots = nlohmann::ordered_json::array();
      roots.push_back(index);
    }
    j["nodes"].push_back(std::move(node));
    GltfNodeEdit edit;
    edit.node = static_cast<std::uint32_t>(index);
    edit.transform = a.transform;
    edit.light = a.light;
    edit.lighting = a.lighting;
    edit.environment = a.environment;
    PENUMBRA_TRY(write_node(j, j["nodes"][index], where, edit));
  }

  // A copy's skin: when every joint of its node's skin was copied along with it (the same tree of
  // added nodes), a new skin over those copies (the same inverse bind matrices); else it keeps the
  // original skin, and so the original skeleton.
  std::vector<std::size_t> tree(edits.added.size());  // each added node's top-most added ancestor
  std::map<std::pair<std::size_t, std::uint64_t>, std::size_t> copies;  // (tree, node copied) -> new index
  for (std::size_t i = 0; i < edits.added.size(); ++i) {
    const GltfNewNode& a = edits.added[i];
    tree[i] = a.added_parent ? tree[*a.added_parent] : i;
    if (a.copy_of) copies[{tree[i], *a.copy_of}] = count + i;
  }
  for (std::size_t i = 0; i < edits.added.size(); ++i) {
    const nlohmann::ordered_json& node = j["nodes"][count + i];
    if (!node.contains("skin") || !node["skin"].is_number_unsigned() || !j.contains("skins") || !j["skins"].is_array() ||
        node["skin"].get<std::uint64_t>() >= j["skins"].size())
      continue;
    nlohmann::ordered_json skin = j["skins"][node["skin"].get<std::size_t>()];
    if (!skin.is_object() || !skin.contains("joints") || !skin["joints"].is_array()) continue;
    bool all = true;
    for (nlohmann::ordered_json& joint : skin["joints"]) {
      const auto copy = joint.is_number_unsigned() ? copies.find({tree[i], joint.get<std::uint64_t>()}) : copies.end();
      if (copy == copies.end()) {
        all = false;
        break;
      }
      joint = copy->second;
    }
    if (!all) continue;
    if (skin.contains("skeleton")) {
      const auto root = skin["skeleton"].is_number_unsigned() ? copies.find({tree[i], skin["skeleton"].get<std::uint64_t>()})
                                                               : copies.end();
      if (root != copies.end()) skin["skeleton"] = root->second;
      else skin.erase("skeleton");
    }
    j["skins"].push_back(std::move(skin));
    j["nodes"][count + i]["skin"] = j["skins"].size() - 1;
  }

  // What the scene holds now; every skin a node of it uses must have its joints there too.
  const nlohmann::ordered_json& all = j["nodes"];
  std::vector<bool> in_scene(all.size(), false);
  std::vector<std::size_t> stack;
  const auto visit = [&](const nlohmann::ordered_json& list) {
    if (!list.is_array()) return;
    for (const nlohmann::ordered_json& v : list)
      if (v.is_number_unsigned() && v.get<std::uint64_t>() < all.size() && !in_scene[v.get<std::size_t>()]) {
        in_scene[v.get<std::size_t>()] = true;
        stack.push_back(v.get<std::size_t>());
      }
  };
  if (j["scenes"][scene].contains("nodes")) visit(j["scenes"][scene]["nodes"]);
  while (!stack.empty()) {
    const nlohmann::ordered_json& node = all[stack.back()];
    stack.pop_back();
    if (node.is_object() && node.contains("children")) visit(node["children"]);
  }
  for (std::size_t n = 0; n < all.size(); ++n) {
    const nlohmann::ordered_json& node = all[n];
    if (!in_scene[n] || !node.is_object() || !node.contains("skin") || !node["skin"].is_number_unsigned() ||
        !j.contains("skins") || !j["skins"].is_array() || node["skin"].get<std::uint64_t>() >= j["skins"].size())
      continue;
    const nlohmann::ordered_json& skin = j["skins"][node["skin"].get<std::size_t>()];
    if (!skin.is_object() || !skin.contains("joints") || !skin["joints"].is_array()) continue;
    for (const nlohmann::ordered_json& joint : skin["joints"])
      if (joint.is_number_unsigned() && joint.get<std::uint64_t>() < all.size() && !in_scene[joint.get<std::size_t>()])
        return make_error(ErrorCode::InvalidArgument,
                          file + ": nodes[" + std::to_string(n) + "] is skinned by skins[" +
                              std::to_string(node["skin"].get<std::size_t>()) + "], whose joint nodes[" +
                              std::to_string(joint.get<std::size_t>()) +
                              "] the edits take out of the scene; keep the joint, or remove the skinned node too");
  }
  return {};
}

}  // namespace

Status save_gltf(const std::filesystem::path& source, const std::filesystem::path& out, const GltfEdits& edits) {
  const std::string file = source.string();
  std::ifstream in(source, std::ios::binary);
  if (!in) return make_error(ErrorCode::NotFound, file + ": cannot be read; save needs the file the scene came from");
  const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const bool binary = bytes.size() >= 4 && get32(bytes, 0) == kGlbMagic;
  const std::string want = binary ? ".glb" : ".gltf";
  if (out.extension() != want)
    return make_error(ErrorCode::InvalidArgument, out.string() + ": " + file + " is a " + want +
                                                      " file; save it under a name ending in " + want);

  // The JSON text, and a .glb's binary chunk.
  std::string json_text, bin;
  if (binary) {
    if (bytes.size() < 20 || get32(bytes, 4) != 2 || get32(bytes, 16) != kJsonChunk ||
        get32(bytes, 12) > bytes.size() - 20)
      return make_error(ErrorCode::InvalidInput, file + ": not a binary glTF 2.0 with a JSON chunk; re-export it");
    json_text = bytes.substr(20, get32(bytes, 12));
    const std::size_t next = 20 + ((std::size_t{get32(bytes, 12)} + 3) & ~std::size_t{3});
    if (next + 8 <= bytes.size() && get32(bytes, next + 4) == kBinChunk) {
      const std::size_t length = get32(bytes, next);
      if (length > bytes.size() - next - 8)
        return make_error(ErrorCode::InvalidInput, file + ": the binary chunk runs past the end of the file");
      bin = bytes.substr(next + 8, length);
    }
  } else {
    json_text = bytes;
  }
  if (gltf_detail::json_depth(json_text, gltf_detail::kMaxJsonDepth) > gltf_detail::kMaxJsonDepth)
    return make_error(ErrorCode::InvalidInput, file + ": JSON nested too deeply; the file is malformed");
  nlohmann::ordered_json j;
  try {
    j = nlohmann::ordered_json::parse(json_text);
  } catch (const nlohmann::json::exception& e) {
    return make_error(ErrorCode::InvalidInput, file + ": not valid JSON (" + e.what() + ")");
  }
  if (!j.is_object()) return make_error(ErrorCode::InvalidInput, file + ": the JSON is not an object");
  nlohmann::ordered_json& nodes = j["nodes"];
  if (!nodes.is_array()) nodes = nlohmann::ordered_json::array();

  for (const GltfNodeEdit& edit : edits.nodes) {
    if (edit.node < nodes.size() && !nodes[edit.node].is_object())
      return make_error(ErrorCode::InvalidInput, file + ": nodes[" + std::to_string(edit.node) + "] is not an object");
    if (edit.node >= nodes.size())
      return make_error(ErrorCode::InvalidArgument, file + ": nodes[" + std::to_string(edit.node) +
                                                        "] does not exist (the file has " +
                                                        std::to_string(nodes.size()) + " nodes)");
    PENUMBRA_TRY(write_node(j, nodes[edit.node], file + ": nodes[" + std::to_string(edit.node) + "]", edit));
  }
  PENUMBRA_TRY(add_and_remove_nodes(j, file, edits));

  // extensionsUsed lists PENUMBRA_lighting exactly when a node declares it.
  bool declared = false;
  for (const nlohmann::ordered_json& node : j["nodes"])
    declared = declared || (node.is_object() && node.contains("extensions") && node["extensions"].is_object() &&
                            node["extensions"].contains("PENUMBRA_lighting"));
  nlohmann::ordered_json& used = j["extensionsUsed"];
  if (!used.is_array()) used = nlohmann::ordered_json::array();
  used.erase(std::remove(used.begin(), used.end(), "PENUMBRA_lighting"), used.end());
  if (declared) used.push_back("PENUMBRA_lighting");
  if (used.empty()) j.erase("extensionsUsed");
  // A file may require it; it must not once no node declares it (a required extension is a used one).
  if (j.contains("extensionsRequired") && j["extensionsRequired"].is_array() && !declared) {
    nlohmann::ordered_json& required = j["extensionsRequired"];
    required.erase(std::remove(required.begin(), required.end(), "PENUMBRA_lighting"), required.end());
    if (required.empty()) j.erase("extensionsRequired");
  }

  std::string text = j.dump(binary ? -1 : 1);
  if (!binary) return write_file_atomically(out, text + "\n");
  text.append((4 - text.size() % 4) % 4, ' ');  // chunks are 4-byte aligned; JSON pads with spaces
  std::string glb;
  const std::size_t bin_padded = (bin.size() + 3) & ~std::size_t{3};
  put32(glb, kGlbMagic);
  put32(glb, 2);
  put32(glb, static_cast<std::uint32_t>(12 + 8 + text.size() + (bin.empty() ? 0 : 8 + bin_padded)));
  put32(glb, static_cast<std::uint32_t>(text.size()));
  put32(glb, kJsonChunk);
  glb += text;
  if (!bin.empty()) {
    put32(glb, static_cast<std::uint32_t>(bin_padded));
    put32(glb, kBinChunk);
    glb += bin;
    glb.append(bin_padded - bin.size(), '\0');
  }
  return write_file_atomically(out, glb);
}

}  // namespace penumbra
