// save_gltf (penumbra/import/gltf.h): the source's JSON edited in place with nlohmann::ordered_json, so
// that everything the edits do not touch is written back as it was read; a .glb's binary chunk is
// copied byte for byte.
#include <cmath>
#include <cstring>
#include <fstream>
#include <iterator>
#include <set>
#include <sstream>

#include <glm/gtc/quaternion.hpp>
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

bool finite(const Transform& t) {
  const glm::vec4 q(t.rotation.x, t.rotation.y, t.rotation.z, t.rotation.w);
  return std::isfinite(glm::dot(t.translation, t.translation) + glm::dot(t.scale, t.scale) + glm::dot(q, q));
}

}  // namespace

Status save_gltf(const std::filesystem::path& source, const std::filesystem::path& out,
                 std::span<const GltfNodeEdit> edits) {
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

  for (const GltfNodeEdit& edit : edits) {
    if (edit.node >= nodes.size())
      return make_error(ErrorCode::InvalidArgument, file + ": nodes[" + std::to_string(edit.node) +
                                                        "] does not exist (the file has " +
                                                        std::to_string(nodes.size()) + " nodes)");
    nlohmann::ordered_json& node = nodes[edit.node];
    const std::string where = file + ": nodes[" + std::to_string(edit.node) + "]";
    if (edit.transform) {
      const Transform& t = *edit.transform;
      if (!finite(t)) return make_error(ErrorCode::InvalidArgument, where + ": the transform is not finite");
      node.erase("matrix");
      node["translation"] = {t.translation.x, t.translation.y, t.translation.z};
      node["rotation"] = {t.rotation.x, t.rotation.y, t.rotation.z, t.rotation.w};
      node["scale"] = {t.scale.x, t.scale.y, t.scale.z};
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
      const Light& l = *edit.light;
      light["color"] = {l.color.x, l.color.y, l.color.z};
      light["intensity"] = l.intensity;
      if (l.range > 0.0f) light["range"] = l.range;
      else light.erase("range");
      if (l.type == Light::Type::Spot)
        light["spot"] = {{"innerConeAngle", l.inner_cone_angle}, {"outerConeAngle", l.outer_cone_angle}};
    }
    // PENUMBRA_lighting, written whole (or removed).
    if (edit.lighting.empty()) {
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
      node["extensions"]["PENUMBRA_lighting"] = {{"version", kLightingExtensionVersion}, {"components", components}};
    }
  }

  // extensionsUsed lists PENUMBRA_lighting exactly when a node declares it.
  bool declared = false;
  for (const nlohmann::ordered_json& node : nodes)
    declared = declared || (node.is_object() && node.contains("extensions") && node["extensions"].is_object() &&
                            node["extensions"].contains("PENUMBRA_lighting"));
  nlohmann::ordered_json& used = j["extensionsUsed"];
  if (!used.is_array()) used = nlohmann::ordered_json::array();
  used.erase(std::remove(used.begin(), used.end(), "PENUMBRA_lighting"), used.end());
  if (declared) used.push_back("PENUMBRA_lighting");
  if (used.empty()) j.erase("extensionsUsed");

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
