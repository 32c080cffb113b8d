// glTF 2.0 import through tinygltf (Khronos glTF 2.0 specification, sections 3.6 "Binary data
// storage", 3.7 "Geometry", 3.8 "Texture data", 3.11 "Animations"; KHR_lights_punctual;
// KHR_materials_emissive_strength). tinygltf parses JSON, loads buffers and decodes images; this
// file validates everything else and builds the entities (see gltf.h for the mapping).
#include "penumbra/import/gltf.h"

#include "penumbra/scene/builtin.h"

#include "gltf_json.h"

#include <array>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <memory>
#include <optional>
#include <sstream>

#include <glm/gtc/quaternion.hpp>
#include <glm/gtc/type_ptr.hpp>
#include <nlohmann/json.hpp>
#include <tiny_gltf.h>

#include "penumbra/core/log.h"
#include "penumbra/import/environment.h"
#include "penumbra/ecs/transform.h"
#include "penumbra/scene/components.h"
#include "penumbra/scene/mesh.h"

namespace penumbra {

namespace {

// A sky value of the lighting extension (a radiance channel, a map scale): a JSON number that is
// finite, >= 0 and fits a float; nullopt otherwise.
std::optional<float> radiance_value(const nlohmann::json& v) {
  const double x = v.is_number() ? v.get<double>() : -1.0;
  if (!(std::isfinite(x) && x >= 0.0 && x <= 3.0e38)) return std::nullopt;
  return static_cast<float>(x);
}

using gltf_detail::json_depth;
using gltf_detail::kMaxJsonDepth;

// Extensions this importer implements; any other one listed in extensionsRequired is refused.
constexpr std::array<std::string_view, 3> kSupportedExtensions = {"KHR_lights_punctual",
                                                                  "KHR_materials_emissive_strength",
                                                                  "PENUMBRA_lighting"};
// The PENUMBRA_lighting version this importer reads.
constexpr int kLightingExtensionVersion = 1;

std::string element(std::string_view kind, std::size_t index) {
  return std::string(kind) + "[" + std::to_string(index) + "]";
}

int component_count(int type) {
  switch (type) {
    case TINYGLTF_TYPE_SCALAR: return 1;
    case TINYGLTF_TYPE_VEC2: return 2;
    case TINYGLTF_TYPE_VEC3: return 3;
    case TINYGLTF_TYPE_VEC4: return 4;
    case TINYGLTF_TYPE_MAT2: return 4;
    case TINYGLTF_TYPE_MAT3: return 9;
    case TINYGLTF_TYPE_MAT4: return 16;
    default: return 0;
  }
}

int component_bytes(int component_type) {
  switch (component_type) {
    case TINYGLTF_COMPONENT_TYPE_BYTE:
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE: return 1;
    case TINYGLTF_COMPONENT_TYPE_SHORT:
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT: return 2;
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT:
    case TINYGLTF_COMPONENT_TYPE_FLOAT: return 4;
    default: return 0;
  }
}

// An accessor's element in words, e.g. "VEC4 of unsigned bytes" (the codes for unknown values).
std::string accessor_words(int type, int component_type) {
  std::string t;
  switch (type) {
    case TINYGLTF_TYPE_SCALAR: t = "SCALAR"; break;
    case TINYGLTF_TYPE_VEC2: t = "VEC2"; break;
    case TINYGLTF_TYPE_VEC3: t = "VEC3"; break;
    case TINYGLTF_TYPE_VEC4: t = "VEC4"; break;
    case TINYGLTF_TYPE_MAT2: t = "MAT2"; break;
    case TINYGLTF_TYPE_MAT3: t = "MAT3"; break;
    case TINYGLTF_TYPE_MAT4: t = "MAT4"; break;
    default: t = "type " + std::to_string(type);
  }
  std::string c;
  switch (component_type) {
    case TINYGLTF_COMPONENT_TYPE_BYTE: c = "signed bytes"; break;
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE: c = "unsigned bytes"; break;
    case TINYGLTF_COMPONENT_TYPE_SHORT: c = "signed shorts"; break;
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT: c = "unsigned shorts"; break;
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT: c = "unsigned ints"; break;
    case TINYGLTF_COMPONENT_TYPE_FLOAT: c = "floats"; break;
    default: c = "componentType " + std::to_string(component_type);
  }
  return t + " of " + c;
}

// sRGB EOTF (IEC 61966-2-1) for an 8-bit code value.
float srgb_to_linear(std::uint8_t code) {
  const float c = static_cast<float>(code) / 255.0f;
  return c <= 0.04045f ? c / 12.92f : std::pow((c + 0.055f) / 1.055f, 2.4f);
}

bool skip_image_decoding(tinygltf::Image*, const int, std::string*, std::string*, int, int,
                         const unsigned char*, int, void*) {
  return true;
}

// One accessor decoded to floats (normalised integers mapped per the spec) or to integers.
struct AccessorView {
  const tinygltf::Accessor* accessor = nullptr;
  const unsigned char* data = nullptr;  // null: no bufferView, all zeros
  std::size_t stride = 0;
  int components = 0;

  double component(std::size_t element_index, int c) const {
    if (!data) return 0.0;
    const unsigned char* p = data + element_index * stride +
                             static_cast<std::size_t>(c * component_bytes(accessor->componentType));
    const bool norm = accessor->normalized;
    switch (accessor->componentType) {
      case TINYGLTF_COMPONENT_TYPE_BYTE: {
        std::int8_t v; std::memcpy(&v, p, 1);
        return norm ? std::max(static_cast<double>(v) / 127.0, -1.0) : v;
      }
      case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE: {
        std::uint8_t v; std::memcpy(&v, p, 1);
        return norm ? static_cast<double>(v) / 255.0 : v;
      }
      case TINYGLTF_COMPONENT_TYPE_SHORT: {
        std::int16_t v; std::memcpy(&v, p, 2);
        return norm ? std::max(static_cast<double>(v) / 32767.0, -1.0) : v;
      }
      case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT: {
        std::uint16_t v; std::memcpy(&v, p, 2);
        return norm ? static_cast<double>(v) / 65535.0 : v;
      }
      case TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT: {
        std::uint32_t v; std::memcpy(&v, p, 4);
        return v;
      }
      default: {
        float v; std::memcpy(&v, p, 4);
        return v;
      }
    }
  }
  std::size_t count() const { return accessor->count; }
};

class Importer {
 public:
  Importer(World& world, const tinygltf::Model& model, const nlohmann::json& json, std::string file,
           const ImportOptions& options)
      : world_(world), model_(model), json_(json), file_(std::move(file)), options_(options) {}

  Result<ImportedScene> run();
  // Destroys every entity created so far (after an error).
  void roll_back() {
    for (auto it = created_.rbegin(); it != created_.rend(); ++it)
      if (world_.alive(*it)) world_.destroy(*it);
  }

 private:
  Error fail(ErrorCode code, const std::string& where, const std::string& what) const {
    return make_error(code, file_ + ": " + where + ": " + what);
  }
  void warn(const std::string& where, const std::string& what) {
    std::string message = file_ + ": " + where + ": " + what;
    log(LogLevel::Warning, message);
    out_.warnings.push_back(std::move(message));
  }
  Entity create(std::string name) {
    const Entity e = world_.create();
    created_.push_back(e);
    world_.add<Name>(e, Name{std::move(name)});
    return e;
  }

  Status check_extensions();
  Result<AccessorView> accessor(int index, const std::string& user, std::initializer_list<int> types,
                                std::initializer_list<int> component_types);
  Status check_finite(const AccessorView& view, int index, const std::string& user);
  Status load_textures();
  Status load_materials();
  Result<std::shared_ptr<const MeshData>> load_primitive(std::size_t mesh, std::size_t primitive);
  Status load_meshes();
  Status create_nodes();
  Status create_node(int index, Entity parent, bool animated);
  Status load_skins();
  Status load_animations();
  Status attach_node_contents(std::size_t node, bool animated);
  // The node's PENUMBRA_lighting extension as an AuthoredLighting on its entity (`meshes`: the
  // entities made for its primitives).
  Status read_lighting_extension(std::size_t node, const nlohmann::json& ext, std::vector<Entity> meshes);

  World& world_;
  const tinygltf::Model& model_;
  const nlohmann::json& json_;  // the same file as parsed by nlohmann (check_structure)
  std::string file_;
  const ImportOptions& options_;
  ImportedScene out_;
  std::vector<Entity> created_;
  std::vector<std::shared_ptr<const Texture>> textures_;  // per glTF texture (null: unusable)
  std::vector<Material> materials_;
  std::vector<std::vector<std::shared_ptr<const MeshData>>> meshes_;  // per mesh, per primitive (null: skipped)
  std::vector<Skin> skins_;
  std::vector<bool> animated_nodes_;
  std::shared_ptr<std::vector<AnimationClip>> clips_;
};

Status Importer::check_extensions() {
  for (const std::string& name : model_.extensionsRequired) {
    bool supported = false;
    for (std::string_view s : kSupportedExtensions) supported |= s == name;
    if (!supported)
      return fail(ErrorCode::Unsupported, "extensionsRequired",
                  "extension '" + name + "' is required but not supported (Penumbra supports "
                  "KHR_lights_punctual, KHR_materials_emissive_strength and PENUMBRA_lighting); export without it");
  }
  return {};
}

Result<AccessorView> Importer::accessor(int index, const std::string& user, std::initializer_list<int> types,
                                        std::initializer_list<int> component_types) {
  if (index < 0 || static_cast<std::size_t>(index) >= model_.accessors.size())
    return fail(ErrorCode::InvalidInput, user,
                "refers to accessor " + std::to_string(index) + " but the file has " +
                    std::to_string(model_.accessors.size()) + " accessors");
  const auto ai = static_cast<std::size_t>(index);
  const tinygltf::Accessor& a = model_.accessors[ai];
  const std::string where = element("accessors", ai) + " (" + user + ")";
  if (std::find(types.begin(), types.end(), a.type) == types.end() ||
      std::find(component_types.begin(), component_types.end(), a.componentType) == component_types.end()) {
    std::string allowed;
    for (int t : types)
      for (int c : component_types) allowed += (allowed.empty() ? "" : ", ") + accessor_words(t, c);
    return fail(ErrorCode::InvalidInput, where,
                "is " + accessor_words(a.type, a.componentType) + ", which the glTF specification does not allow "
                "here; it takes " + allowed + " (re-export the attribute in one of those)");
  }
  if (a.sparse.isSparse)
    return fail(ErrorCode::Unsupported, where, "sparse accessors are not supported; export without sparse data");
  // The largest accessor the importer reads (2^27 elements: 1.5 GiB of positions), checked before
  // anything is allocated or visited, so that a count without data behind it (no bufferView)
  // cannot make the import loop or allocate for hours.
  constexpr std::size_t kMaxAccessorElements = std::size_t{1} << 27;
  if (a.count > kMaxAccessorElements)
    return fail(ErrorCode::InvalidInput, where,
                "count " + std::to_string(a.count) + " exceeds the importer's limit of " +
                    std::to_string(kMaxAccessorElements) + " elements; split the mesh");
  AccessorView view;
  view.accessor = &a;
  view.components = component_count(a.type);
  const std::size_t element_size = static_cast<std::size_t>(view.components * component_bytes(a.componentType));
  if (a.bufferView < 0) return view;  // spec: no bufferView means all zeros
  if (static_cast<std::size_t>(a.bufferView) >= model_.bufferViews.size())
    return fail(ErrorCode::InvalidInput, where,
                "bufferView " + std::to_string(a.bufferView) + " does not exist (the file has " +
                    std::to_string(model_.bufferViews.size()) + ")");
  const auto vi = static_cast<std::size_t>(a.bufferView);
  const tinygltf::BufferView& bv = model_.bufferViews[vi];
  if (bv.buffer < 0 || static_cast<std::size_t>(bv.buffer) >= model_.buffers.size())
    return fail(ErrorCode::InvalidInput, element("bufferViews", vi),
                "buffer " + std::to_string(bv.buffer) + " does not exist (the file has " +
                    std::to_string(model_.buffers.size()) + ")");
  const auto bi = static_cast<std::size_t>(bv.buffer);
  const std::size_t buffer_size = model_.buffers[bi].data.size();
  if (bv.byteOffset > buffer_size || bv.byteLength > buffer_size - bv.byteOffset)
    return fail(ErrorCode::InvalidInput, element("bufferViews", vi),
                "bytes " + std::to_string(bv.byteOffset) + ".." + std::to_string(bv.byteOffset + bv.byteLength) +
                    " lie past the end of " + element("buffers", bi) + ", which holds " +
                    std::to_string(buffer_size) + " bytes (short or truncated buffer); re-export the file");
  view.stride = bv.byteStride != 0 ? bv.byteStride : element_size;
  if (view.stride < element_size)
    return fail(ErrorCode::InvalidInput, element("bufferViews", vi),
                "byteStride " + std::to_string(bv.byteStride) + " is smaller than the " +
                    std::to_string(element_size) + "-byte elements of " + element("accessors", ai));
  if (a.count > 0) {
    if (a.count - 1 > bv.byteLength / view.stride)  // also keeps the product below from overflowing
      return fail(ErrorCode::InvalidInput, where,
                  "count " + std::to_string(a.count) + " cannot fit in " + element("bufferViews", vi) + " (" +
                      std::to_string(bv.byteLength) + " bytes); the accessor runs past its buffer view");
    const std::size_t needed = a.byteOffset + view.stride * (a.count - 1) + element_size;
    if (a.byteOffset > bv.byteLength || needed > bv.byteLength)
      return fail(ErrorCode::InvalidInput, where,
                  "count " + std::to_string(a.count) + " from byteOffset " + std::to_string(a.byteOffset) +
                      " needs " + std::to_string(needed) + " bytes but " + element("bufferViews", vi) +
                      " holds " + std::to_string(bv.byteLength) + "; the accessor runs past its buffer view");
  }
  view.data = model_.buffers[bi].data.data() + bv.byteOffset + a.byteOffset;
  return view;
}

Status Importer::check_finite(const AccessorView& view, int index, const std::string& user) {
  if (view.data == nullptr) return {};  // no bufferView: all zeros
  for (std::size_t i = 0; i < view.count(); ++i)
    for (int c = 0; c < view.components; ++c)
      if (!std::isfinite(view.component(i, c)))
        return fail(ErrorCode::InvalidInput, element("accessors", static_cast<std::size_t>(index)) + " (" + user + ")",
                    "element " + std::to_string(i) + " component " + std::to_string(c) +
                        " is NaN or Inf; fix the exporter or the source data");
  return {};
}

Status Importer::load_textures() {
  // Decode each glTF texture's image to RGBA8 once and measure its mean linear colour.
  textures_.resize(model_.textures.size());
  for (std::size_t t = 0; t < model_.textures.size(); ++t) {
    const int source = model_.textures[t].source;
    if (source < 0 || static_cast<std::size_t>(source) >= model_.images.size()) {
      warn(element("textures", t), "has no valid image source; it is ignored");
      continue;
    }
    const tinygltf::Image& image = model_.images[static_cast<std::size_t>(source)];
    if (!options_.load_textures) continue;
    const std::string where = element("images", static_cast<std::size_t>(source));
    if (image.width <= 0 || image.height <= 0 || image.image.empty() || image.component < 1 ||
        image.component > 4 || (image.bits != 8 && image.bits != 16)) {
      warn(where, "could not be decoded to 8- or 16-bit pixels; the material uses its factor only");
      continue;
    }
    const auto pixels = static_cast<std::size_t>(image.width) * static_cast<std::size_t>(image.height);
    const auto channels = static_cast<std::size_t>(image.component);
    const std::size_t bytes_per_channel = image.bits == 16 ? 2 : 1;
    if (image.image.size() < pixels * channels * bytes_per_channel) {
      warn(where, "pixel data is shorter than its size says; it is ignored");
      continue;
    }
    auto texture = std::make_shared<Texture>();
    texture->name = image.name.empty() ? where : image.name;
    texture->width = image.width;
    texture->height = image.height;
    texture->rgba8.resize(pixels * 4);
    std::array<float, 256> lut{};
    for (int i = 0; i < 256; ++i) lut[static_cast<std::size_t>(i)] = srgb_to_linear(static_cast<std::uint8_t>(i));
    glm::dvec3 sum(0.0);
    for (std::size_t p = 0; p < pixels; ++p) {
      std::array<std::uint8_t, 4> rgba = {0, 0, 0, 255};
      for (std::size_t c = 0; c < channels; ++c) {
        // 16-bit channels keep their high byte (little-endian storage).
        const std::size_t offset = (p * channels + c) * bytes_per_channel + (bytes_per_channel - 1);
        rgba[c] = image.image[offset];
      }
      if (channels <= 2) rgba[1] = rgba[2] = rgba[0];   // grey (+ alpha)
      if (channels == 2) rgba[3] = image.image[(p * channels + 1) * bytes_per_channel + (bytes_per_channel - 1)];
      std::memcpy(&texture->rgba8[4 * p], rgba.data(), 4);
      sum += glm::dvec3(lut[rgba[0]], lut[rgba[1]], lut[rgba[2]]);
    }
    texture->average_linear = glm::vec3(sum / static_cast<double>(pixels));
    textures_[t] = std::move(texture);
    ++out_.textures;
  }
  return {};
}

Status Importer::load_materials() {
  materials_.resize(model_.materials.size());
  for (std::size_t m = 0; m < model_.materials.size(); ++m) {
    const tinygltf::Material& src = model_.materials[m];
    const std::string where = element("materials", m);
    Material& dst = materials_[m];
    const std::vector<double>& base = src.pbrMetallicRoughness.baseColorFactor;
    if (base.size() == 4) dst.base_color = glm::vec4(base[0], base[1], base[2], base[3]);
    const int texture = src.pbrMetallicRoughness.baseColorTexture.index;
    if (texture >= 0) {
      if (static_cast<std::size_t>(texture) >= textures_.size())
        return fail(ErrorCode::InvalidInput, where,
                    "baseColorTexture refers to texture " + std::to_string(texture) + " but the file has " +
                        std::to_string(textures_.size()));
      dst.base_color_texture = textures_[static_cast<std::size_t>(texture)];
      if (src.pbrMetallicRoughness.baseColorTexture.texCoord != 0)
        warn(where, "baseColorTexture uses TEXCOORD_" +
                        std::to_string(src.pbrMetallicRoughness.baseColorTexture.texCoord) +
                        "; Penumbra reads TEXCOORD_0");
    }
    if (src.emissiveFactor.size() == 3)
      dst.emissive = glm::vec3(src.emissiveFactor[0], src.emissiveFactor[1], src.emissiveFactor[2]);
    if (auto it = src.extensions.find("KHR_materials_emissive_strength"); it != src.extensions.end()) {
      const tinygltf::Value& strength = it->second.Get("emissiveStrength");
      if (strength.IsNumber()) dst.emissive *= static_cast<float>(strength.GetNumberAsDouble());
    }
    if (src.emissiveTexture.index >= 0) warn(where, "emissiveTexture is ignored; the emissive factor is used");
    dst.double_sided = src.doubleSided;
    if (!std::isfinite(dst.base_color.x + dst.base_color.y + dst.base_color.z + dst.base_color.w) ||
        !std::isfinite(dst.emissive.x + dst.emissive.y + dst.emissive.z))
      return fail(ErrorCode::InvalidInput, where, "has a NaN or Inf colour factor");
    ++out_.materials;
  }
  return {};
}

Result<std::shared_ptr<const MeshData>> Importer::load_primitive(std::size_t mesh_index, std::size_t prim_index) {
  const tinygltf::Primitive& prim = model_.meshes[mesh_index].primitives[prim_index];
  const std::string where = element("meshes", mesh_index) + ".primitives[" + std::to_string(prim_index) + "]";
  if (prim.mode != TINYGLTF_MODE_TRIANGLES) {
    warn(where, "mode " + std::to_string(prim.mode) + " is not a triangle list; the primitive is skipped");
    return std::shared_ptr<const MeshData>();
  }
  auto mesh = std::make_shared<MeshData>();
  mesh->name = model_.meshes[mesh_index].name.empty() ? where : model_.meshes[mesh_index].name;
  auto attribute = [&](const char* name) {
    auto it = prim.attributes.find(name);
    return it == prim.attributes.end() ? -1 : it->second;
  };
  constexpr int kFloat = TINYGLTF_COMPONENT_TYPE_FLOAT, kU8 = TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE,
                kU16 = TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT, kU32 = TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT;

  // POSITION (required), then the optional attributes, each checked against the vertex count.
  const int position_index = attribute("POSITION");
  if (position_index < 0) return fail(ErrorCode::InvalidInput, where, "has no POSITION attribute");
  auto positions = accessor(position_index, where + ".attributes.POSITION", {TINYGLTF_TYPE_VEC3}, {kFloat});
  if (!positions) return positions.error();
  PENUMBRA_TRY(check_finite(*positions, position_index, where + ".attributes.POSITION"));
  const std::size_t n = positions->count();
  mesh->positions.resize(n);
  for (std::size_t i = 0; i < n; ++i)
    for (int c = 0; c < 3; ++c) mesh->positions[i][c] = static_cast<float>(positions->component(i, c));

  auto read_attribute = [&](const char* name, std::initializer_list<int> types,
                            std::initializer_list<int> component_types, auto& values, bool finite) -> Status {
    const int index = attribute(name);
    if (index < 0) return {};
    const std::string user = where + ".attributes." + name;
    auto view = accessor(index, user, types, component_types);
    if (!view) return view.error();
    if (view->count() != n)
      return fail(ErrorCode::InvalidInput, element("accessors", static_cast<std::size_t>(index)) + " (" + user + ")",
                  "has " + std::to_string(view->count()) + " elements but POSITION has " + std::to_string(n));
    if (finite) PENUMBRA_TRY(check_finite(*view, index, user));
    values.resize(n);
    for (std::size_t i = 0; i < n; ++i)
      for (int c = 0; c < view->components; ++c)
        values[i][c] = static_cast<std::remove_reference_t<decltype(values[i][c])>>(view->component(i, c));
    return {};
  };
  PENUMBRA_TRY(read_attribute("NORMAL", {TINYGLTF_TYPE_VEC3}, {kFloat}, mesh->normals, true));
  PENUMBRA_TRY(read_attribute("TEXCOORD_0", {TINYGLTF_TYPE_VEC2}, {kFloat, kU8, kU16}, mesh->uvs, true));
  PENUMBRA_TRY(read_attribute("JOINTS_0", {TINYGLTF_TYPE_VEC4}, {kU8, kU16}, mesh->joints, false));
  // Integer weights must be normalized (glTF 2.0, 3.7.3.1): read raw, they would be 0..255 or 0..65535.
  if (const int w = attribute("WEIGHTS_0"); w >= 0 && static_cast<std::size_t>(w) < model_.accessors.size()) {
    const tinygltf::Accessor& a = model_.accessors[static_cast<std::size_t>(w)];
    if (a.componentType != kFloat && !a.normalized)
      return fail(ErrorCode::InvalidInput, element("accessors", static_cast<std::size_t>(w)) + " (" + where +
                                               ".attributes.WEIGHTS_0)",
                  "integer weights without \"normalized\": true; the specification requires it: re-export");
  }
  PENUMBRA_TRY(read_attribute("WEIGHTS_0", {TINYGLTF_TYPE_VEC4}, {kFloat, kU8, kU16}, mesh->weights, true));
  if (mesh->joints.empty() != mesh->weights.empty())
    return fail(ErrorCode::InvalidInput, where, "has only one of JOINTS_0 and WEIGHTS_0; skinning needs both");

  // Weights: must sum to 1 (spec 3.7.3.3); small exporter drift is renormalised.
  bool renormalised = false;
  for (std::size_t i = 0; i < mesh->weights.size(); ++i) {
    glm::vec4& w = mesh->weights[i];
    const float sum = w.x + w.y + w.z + w.w;
    if (glm::any(glm::lessThan(w, glm::vec4(0.0f))) || !(sum > 0.0f))
      return fail(ErrorCode::InvalidInput, where + ".attributes.WEIGHTS_0",
                  "vertex " + std::to_string(i) + " has negative weights or weights summing to zero");
    if (std::abs(sum - 1.0f) > 1e-6f) {
      renormalised |= std::abs(sum - 1.0f) > 1e-2f;
      w /= sum;
    }
  }
  if (renormalised) warn(where + ".attributes.WEIGHTS_0", "weights did not sum to 1 and were renormalised");

  // Indices (or the implicit 0..n-1), all in range.
  if (prim.indices >= 0) {
    const std::string user = where + ".indices";
    auto indices = accessor(prim.indices, user, {TINYGLTF_TYPE_SCALAR}, {kU8, kU16, kU32});
    if (!indices) return indices.error();
    mesh->indices.resize(indices->count());
    for (std::size_t i = 0; i < indices->count(); ++i) {
      const double v = indices->component(i, 0);
      if (v >= static_cast<double>(n))
        return fail(ErrorCode::InvalidInput, element("accessors", static_cast<std::size_t>(prim.indices)) + " (" + user + ")",
                    "index " + std::to_string(i) + " is " + std::to_string(static_cast<std::uint64_t>(v)) +
                        " but POSITION has only " + std::to_string(n) + " vertices");
      mesh->indices[i] = static_cast<std::uint32_t>(v);
    }
  } else {
    mesh->indices.resize(n);
    for (std::size_t i = 0; i < n; ++i) mesh->indices[i] = static_cast<std::uint32_t>(i);
  }
  if (mesh->indices.size() % 3 != 0)
    return fail(ErrorCode::InvalidInput, where,
                std::to_string(mesh->indices.size()) + " indices is not a multiple of 3 for a triangle list");

  // Degenerate triangles are dropped and counted; then normals (computed when absent or zero).
  const std::size_t dropped = remove_degenerate_triangles(*mesh, options_.degenerate_epsilon);
  if (dropped > 0) {
    out_.dropped_degenerate += dropped;
    warn(where, "dropped " + std::to_string(dropped) + " degenerate triangle(s)");
  }
  bool recompute = mesh->normals.empty();
  for (glm::vec3& nrm : mesh->normals) {
    const float len = glm::length(nrm);
    if (len > 0.0f) nrm /= len; else recompute = true;
  }
  if (recompute) compute_normals(*mesh);
  if (Status s = mesh->validate(file_ + ": " + where); !s) return s.error();
  return std::shared_ptr<const MeshData>(std::move(mesh));
}

Status Importer::load_meshes() {
  meshes_.resize(model_.meshes.size());
  for (std::size_t m = 0; m < model_.meshes.size(); ++m)
    for (std::size_t p = 0; p < model_.meshes[m].primitives.size(); ++p) {
      auto data = load_primitive(m, p);
      if (!data) return data.error();
      meshes_[m].push_back(std::move(*data));
    }
  return {};
}

// Transform of a node: TRS, or a decomposed matrix (columns' lengths are the scale; a negative
// determinant flips the X scale).
Result<Transform> node_transform(const tinygltf::Node& node) {
  Transform t;
  if (node.matrix.size() == 16) {
    glm::mat4 m(1.0f);
    for (int i = 0; i < 16; ++i) glm::value_ptr(m)[i] = static_cast<float>(node.matrix[static_cast<std::size_t>(i)]);
    t.translation = glm::vec3(m[3]);
    glm::mat3 r(m);
    t.scale = glm::vec3(glm::length(r[0]), glm::length(r[1]), glm::length(r[2]));
    if (glm::determinant(r) < 0.0f) t.scale.x = -t.scale.x;
    if (t.scale.x == 0.0f || t.scale.y == 0.0f || t.scale.z == 0.0f) return Error{};
    r[0] /= t.scale.x; r[1] /= t.scale.y; r[2] /= t.scale.z;
    t.rotation = glm::normalize(glm::quat_cast(r));
  } else {
    if (node.translation.size() == 3)
      t.translation = glm::vec3(node.translation[0], node.translation[1], node.translation[2]);
    if (node.rotation.size() == 4)
      t.rotation = glm::normalize(glm::quat(static_cast<float>(node.rotation[3]), static_cast<float>(node.rotation[0]),
                                            static_cast<float>(node.rotation[1]), static_cast<float>(node.rotation[2])));
    if (node.scale.size() == 3) t.scale = glm::vec3(node.scale[0], node.scale[1], node.scale[2]);
  }
  const glm::vec4 q(t.rotation.x, t.rotation.y, t.rotation.z, t.rotation.w);
  if (!std::isfinite(glm::dot(t.translation, t.translation) + glm::dot(t.scale, t.scale) + glm::dot(q, q)))
    return Error{};
  return t;
}

Status Importer::create_node(int index, Entity parent, bool animated) {
  if (index < 0 || static_cast<std::size_t>(index) >= model_.nodes.size())
    return fail(ErrorCode::InvalidInput, "nodes", "node " + std::to_string(index) + " is referenced but the file has " +
                                                      std::to_string(model_.nodes.size()) + " nodes");
  const auto ni = static_cast<std::size_t>(index);
  const std::string where = element("nodes", ni);
  if (out_.nodes[ni])
    return fail(ErrorCode::InvalidInput, where, "is reachable twice (a cycle or a shared child); nodes must form a forest");
  const tinygltf::Node& node = model_.nodes[ni];
  auto transform = node_transform(node);
  if (!transform)
    return fail(ErrorCode::InvalidInput, where, "has a non-finite or singular transform");
  const Entity e = create(node.name.empty() ? where : node.name);
  out_.nodes[ni] = e;
  world_.add<GltfNode>(e, GltfNode{static_cast<std::uint32_t>(ni)});
  world_.add<Transform>(e, *transform);
  set_parent(world_, e, parent);
  animated_nodes_[ni] = animated || animated_nodes_[ni];
  return {};
}

Status Importer::attach_node_contents(std::size_t ni, bool animated) {
  const tinygltf::Node& node = model_.nodes[ni];
  const std::string where = element("nodes", ni);
  const Entity e = out_.nodes[ni];
  if (node.camera >= 0) {
    if (static_cast<std::size_t>(node.camera) >= model_.cameras.size())
      return fail(ErrorCode::InvalidInput, where, "camera " + std::to_string(node.camera) + " does not exist");
    const tinygltf::Camera& src = model_.cameras[static_cast<std::size_t>(node.camera)];
    if (src.type == "perspective") {
      Camera camera;
      camera.yfov = static_cast<float>(src.perspective.yfov);
      camera.aspect = static_cast<float>(src.perspective.aspectRatio);
      camera.znear = static_cast<float>(src.perspective.znear);
      if (src.perspective.zfar > 0.0) camera.zfar = static_cast<float>(src.perspective.zfar);
      world_.add<Camera>(e, camera);
      ++out_.cameras;
    } else {
      warn(element("cameras", static_cast<std::size_t>(node.camera)), "orthographic cameras are not supported; skipped");
    }
  }
  if (auto it = node.extensions.find("KHR_lights_punctual"); it != node.extensions.end()) {
    const tinygltf::Value& index = it->second.Get("light");
    if (!index.IsNumber() || index.GetNumberAsInt() < 0 ||
        static_cast<std::size_t>(index.GetNumberAsInt()) >= model_.lights.size())
      return fail(ErrorCode::InvalidInput, where, "KHR_lights_punctual.light refers to a light that does not exist");
    const auto li = static_cast<std::size_t>(index.GetNumberAsInt());
    const tinygltf::Light& src = model_.lights[li];
    Light light;
    if (src.type == "directional") light.type = Light::Type::Directional;
    else if (src.type == "point") light.type = Light::Type::Point;
    else if (src.type == "spot") light.type = Light::Type::Spot;
    else return fail(ErrorCode::InvalidInput, "KHR_lights_punctual.lights[" + std::to_string(li) + "]",
                     "unknown type '" + src.type + "' (directional, point or spot)");
    const std::string lwhere = "KHR_lights_punctual.lights[" + std::to_string(li) + "]";
    if (src.color.size() == 3) light.color = glm::vec3(src.color[0], src.color[1], src.color[2]);
    light.intensity = static_cast<float>(src.intensity);
    light.range = static_cast<float>(src.range);
    if (!(std::isfinite(light.intensity) && light.intensity >= 0.0f))
      return fail(ErrorCode::InvalidInput, lwhere,
                  "intensity " + std::to_string(src.intensity) + " is negative or not finite; give a value >= 0");
    if (!(std::isfinite(light.range) && light.range >= 0.0f))
      return fail(ErrorCode::InvalidInput, lwhere,
                  "range " + std::to_string(src.range) + " is negative or not finite; give a value > 0, or none");
    for (int c = 0; c < 3; ++c)
      if (!(std::isfinite(light.color[c]) && light.color[c] >= 0.0f))
        return fail(ErrorCode::InvalidInput, lwhere, "color has a negative or non-finite channel; give linear RGB >= 0");
    if (light.type == Light::Type::Spot) {
      light.inner_cone_angle = static_cast<float>(src.spot.innerConeAngle);
      light.outer_cone_angle = static_cast<float>(src.spot.outerConeAngle);
    }
    world_.add<Light>(e, light);
    ++out_.lights;
  }
  // The node's PENUMBRA_lighting in the raw JSON (null when absent).
  const nlohmann::json* lighting = nullptr;
  if (const auto nodes = json_.find("nodes"); nodes != json_.end() && nodes->is_array() && ni < nodes->size()) {
    const nlohmann::json& n = (*nodes)[ni];
    if (const auto ext = n.find("extensions"); n.is_object() && ext != n.end() && ext->is_object())
      if (const auto it = ext->find("PENUMBRA_lighting"); it != ext->end()) lighting = &*it;
  }
  std::vector<Entity> mesh_entities;
  if (node.mesh < 0) return lighting == nullptr ? Status{} : read_lighting_extension(ni, *lighting, {});
  if (static_cast<std::size_t>(node.mesh) >= meshes_.size())
    return fail(ErrorCode::InvalidInput, where, "mesh " + std::to_string(node.mesh) + " does not exist");
  const Skin* skin = nullptr;
  if (node.skin >= 0) {
    if (static_cast<std::size_t>(node.skin) >= skins_.size())
      return fail(ErrorCode::InvalidInput, where, "skin " + std::to_string(node.skin) + " does not exist");
    skin = &skins_[static_cast<std::size_t>(node.skin)];
  }
  const auto mi = static_cast<std::size_t>(node.mesh);
  for (std::size_t p = 0; p < meshes_[mi].size(); ++p) {
    const std::shared_ptr<const MeshData>& data = meshes_[mi][p];
    if (!data || data->indices.empty()) continue;
    const std::string prim = element("meshes", mi) + ".primitives[" + std::to_string(p) + "]";
    if (skin)
      for (std::size_t v = 0; v < data->joints.size(); ++v)
        for (int k = 0; k < 4; ++k)
          if (data->weights[v][k] > 0.0f && data->joints[v][k] >= skin->joints.size())
            return fail(ErrorCode::InvalidInput, prim + ".attributes.JOINTS_0",
                        "vertex " + std::to_string(v) + " uses joint " + std::to_string(data->joints[v][k]) +
                            " but " + element("skins", static_cast<std::size_t>(node.skin)) + " (used by " + where +
                            ") has " + std::to_string(skin->joints.size()) + " joints");
    const Entity pe = create(data->name + "/" + std::to_string(p));
    world_.add<Transform>(pe);
    set_parent(world_, pe, e);
    world_.add<Mesh>(pe, Mesh{data});
    const int material = model_.meshes[mi].primitives[p].material;
    if (material >= 0 && static_cast<std::size_t>(material) >= materials_.size())
      return fail(ErrorCode::InvalidInput, prim, "material " + std::to_string(material) + " does not exist");
    world_.add<Material>(pe, material >= 0 ? materials_[static_cast<std::size_t>(material)] : Material{});
    const bool skinned = skin && !data->joints.empty();
    if (skinned) world_.add<Skin>(pe, *skin);
    if (options_.mark_static && !skinned && !animated) world_.add<Static>(pe);
    ++out_.mesh_entities;
    out_.triangles += data->triangle_count();
    mesh_entities.push_back(pe);
  }
  if (lighting != nullptr) return read_lighting_extension(ni, *lighting, std::move(mesh_entities));
  return {};
}

Status Importer::read_lighting_extension(std::size_t ni, const nlohmann::json& ext, std::vector<Entity> meshes) {
  const tinygltf::Node& node = model_.nodes[ni];
  const std::string where = element("nodes", ni) + (node.name.empty() ? "" : " '" + node.name + "'") +
                            ".extensions.PENUMBRA_lighting";
  if (!ext.is_object()) return fail(ErrorCode::InvalidInput, where, "is not an object");
  if (!ext.contains("version") || !ext["version"].is_number())
    return fail(ErrorCode::InvalidInput, where, "has no \"version\"; give \"version\": " +
                                                    std::to_string(kLightingExtensionVersion));
  if (ext["version"].get<double>() != kLightingExtensionVersion) {
    char given[32];
    std::snprintf(given, sizeof given, "%g", ext["version"].get<double>());
    return fail(ErrorCode::Unsupported, where,
                std::string("version ") + given + " is not the version this Penumbra reads (" +
                    std::to_string(kLightingExtensionVersion) + "); update Penumbra or export version " +
                    std::to_string(kLightingExtensionVersion));
  }
  for (const auto& [key, value] : ext.items())
    if (key != "version" && key != "components" && key != "environment")
      return fail(ErrorCode::InvalidInput, where, "unknown key \"" + key + "\" (version, components, environment)");
  // "environment": {"radiance": [r, g, b]} or {"map": "sky.exr", "map_scale": s}, the sky
  // (scene/components.h, Environment) on the node; the map's path is relative to the file.
  if (const auto sky = ext.find("environment"); sky != ext.end()) {
    const std::string swhere = where + ".environment";
    if (!sky->is_object())
      return fail(ErrorCode::InvalidInput, swhere, "is not an object; give {\"radiance\": [r, g, b]} or {\"map\": \"sky.exr\"}");
    for (const auto& [key, value] : sky->items())
      if (key != "radiance" && key != "map" && key != "map_scale")
        return fail(ErrorCode::InvalidInput, swhere, "unknown key \"" + key + "\" (radiance, map, map_scale)");
    Environment env;
    if (const auto map = sky->find("map"); map != sky->end()) {
      if (!map->is_string() || map->get<std::string>().empty())
        return fail(ErrorCode::InvalidInput, swhere + ".map", "is not a file name; give the equirectangular OpenEXR "
                                                              "file's path relative to the glTF, e.g. \"sky.exr\"");
      if (sky->contains("radiance"))
        return fail(ErrorCode::InvalidInput, swhere, "gives both \"radiance\" and \"map\"; keep one (a map replaces "
                                                     "the constant sky; scale it with \"map_scale\")");
      if (const auto scale = sky->find("map_scale"); scale != sky->end()) {
        const std::optional<float> x = radiance_value(*scale);
        if (!x)
          return fail(ErrorCode::InvalidInput, swhere + ".map_scale", "is not a finite number >= 0; give the factor "
                                                                      "the map's texels are multiplied by (1: as stored)");
        env.map_scale = *x;
      }
      env.map = map->get<std::string>();
      const std::filesystem::path full = std::filesystem::path(file_).parent_path() / env.map;
      std::error_code ec;
      if (!std::filesystem::is_regular_file(full, ec))
        return fail(ErrorCode::NotFound, swhere + ".map", "'" + env.map + "' is not a file (looked for " +
                                                               full.string() + "); put it next to the glTF or fix the path");
      auto loaded = load_environment_map(full);
      if (!loaded) return fail(loaded.error().code, swhere + ".map", loaded.error().message);
      env.map_data = std::move(*loaded);
    } else {
      if (sky->contains("map_scale"))
        return fail(ErrorCode::InvalidInput, swhere, "gives \"map_scale\" without a \"map\"; add the map or drop the scale");
      const auto radiance = sky->find("radiance");
      if (radiance == sky->end() || !radiance->is_array() || radiance->size() != 3)
        return fail(ErrorCode::InvalidInput, swhere, "\"radiance\" is missing or not 3 numbers; give linear RGB in "
                                                     "W/(m^2 sr), e.g. [0.2, 0.25, 0.35] (or a \"map\")");
      for (std::size_t c = 0; c < 3; ++c) {
        const std::optional<float> x = radiance_value((*radiance)[c]);
        if (!x)
          return fail(ErrorCode::InvalidInput, swhere + ".radiance",
                      "element " + std::to_string(c) + " is not a finite number >= 0; give linear RGB in W/(m^2 sr)");
        env.radiance[static_cast<int>(c)] = *x;
      }
    }
    world_.add<Environment>(out_.nodes[ni], std::move(env));
    if (!ext.contains("components")) return {};
  }
  if (!ext.contains("components") || !ext["components"].is_object())
    return fail(ErrorCode::InvalidInput, where, "\"components\" is missing or not an object of component name -> "
                                                "fields (or give an \"environment\")");
  AuthoredLighting authored;
  authored.source = file_ + ": " + where;
  authored.meshes = std::move(meshes);
  for (const auto& [type, body] : ext["components"].items()) {
    const std::string cwhere = where + ".components." + type;
    if (!body.is_object()) return fail(ErrorCode::InvalidInput, cwhere, "is not an object of field -> value");
    AuthoredComponent c;
    c.type = type;
    for (const auto& [field, v] : body.items()) {
      if (field == "preset") {
        if (!v.is_string()) return fail(ErrorCode::InvalidInput, cwhere, "\"preset\" is not a string (draft, medium, high)");
        c.preset = v.get<std::string>();
      } else if (v.is_boolean()) {
        c.fields.emplace_back(field, AuthoredValue(v.get<bool>()));
      } else if (v.is_number()) {
        c.fields.emplace_back(field, AuthoredValue(v.get<double>()));
      } else if (v.is_string()) {
        c.fields.emplace_back(field, AuthoredValue(v.get<std::string>()));
      } else if (v.is_array()) {
        std::vector<double> numbers;
        for (std::size_t i = 0; i < v.size(); ++i) {
          if (!v[i].is_number())
            return fail(ErrorCode::InvalidInput, cwhere + "." + field, "element " + std::to_string(i) + " is not a number");
          numbers.push_back(v[i].get<double>());
        }
        c.fields.emplace_back(field, AuthoredValue(std::move(numbers)));
      } else {
        return fail(ErrorCode::InvalidInput, cwhere + "." + field,
                    "is not a boolean, number, string or array of numbers");
      }
    }
    authored.components.push_back(std::move(c));
  }
  world_.add<AuthoredLighting>(out_.nodes[ni], std::move(authored));
  return {};
}

Status Importer::load_skins() {
  // Joint entities exist by now; inverse bind matrices default to identity. Only the skins of the
  // scene's nodes: one that no node there uses (its character left out of the scene) is not read.
  skins_.resize(model_.skins.size());
  std::vector<bool> used(model_.skins.size(), false);
  for (std::size_t i = 0; i < model_.nodes.size(); ++i)
    if (out_.nodes[i] && model_.nodes[i].skin >= 0 && static_cast<std::size_t>(model_.nodes[i].skin) < used.size())
      used[static_cast<std::size_t>(model_.nodes[i].skin)] = true;
  for (std::size_t s = 0; s < model_.skins.size(); ++s) {
    if (!used[s]) continue;
    const tinygltf::Skin& src = model_.skins[s];
    const std::string where = element("skins", s);
    Skin& dst = skins_[s];
    for (int joint : src.joints) {
      if (joint < 0 || static_cast<std::size_t>(joint) >= model_.nodes.size() || !out_.nodes[static_cast<std::size_t>(joint)])
        return fail(ErrorCode::InvalidInput, where,
                    "joint node " + std::to_string(joint) + " does not exist or is not in the scene");
      dst.joints.push_back(out_.nodes[static_cast<std::size_t>(joint)]);
    }
    dst.inverse_bind.assign(dst.joints.size(), glm::mat4(1.0f));
    if (src.inverseBindMatrices >= 0) {
      auto view = accessor(src.inverseBindMatrices, where + ".inverseBindMatrices", {TINYGLTF_TYPE_MAT4},
                           {TINYGLTF_COMPONENT_TYPE_FLOAT});
      if (!view) return view.error();
      if (view->count() < dst.joints.size())
        return fail(ErrorCode::InvalidInput, where,
                    "has " + std::to_string(dst.joints.size()) + " joints but inverseBindMatrices holds " +
                        std::to_string(view->count()));
      PENUMBRA_TRY(check_finite(*view, src.inverseBindMatrices, where + ".inverseBindMatrices"));
      for (std::size_t j = 0; j < dst.joints.size(); ++j)
        for (int c = 0; c < 16; ++c)
          glm::value_ptr(dst.inverse_bind[j])[c] = static_cast<float>(view->component(j, c));
    }
    ++out_.skins;
  }
  return {};
}

Status Importer::load_animations() {
  clips_ = std::make_shared<std::vector<AnimationClip>>();
  for (std::size_t a = 0; a < model_.animations.size(); ++a) {
    const tinygltf::Animation& src = model_.animations[a];
    const std::string where = element("animations", a);
    AnimationClip clip;
    clip.name = src.name.empty() ? where : src.name;
    std::vector<int> target_nodes;
    for (std::size_t c = 0; c < src.channels.size(); ++c) {
      const tinygltf::AnimationChannel& ch = src.channels[c];
      const std::string cwhere = where + ".channels[" + std::to_string(c) + "]";
      AnimationChannel dst;
      if (ch.target_path == "translation") dst.path = AnimationChannel::Path::Translation;
      else if (ch.target_path == "rotation") dst.path = AnimationChannel::Path::Rotation;
      else if (ch.target_path == "scale") dst.path = AnimationChannel::Path::Scale;
      else {
        warn(cwhere, "target path '" + ch.target_path + "' (morph weights) is not supported; channel skipped");
        continue;
      }
      if (ch.target_node < 0 || static_cast<std::size_t>(ch.target_node) >= model_.nodes.size())
        return fail(ErrorCode::InvalidInput, cwhere, "target node " + std::to_string(ch.target_node) + " does not exist");
      if (!out_.nodes[static_cast<std::size_t>(ch.target_node)]) {  // a valid node the scene leaves out
        warn(cwhere, "target node " + std::to_string(ch.target_node) + " is not in the scene; channel skipped");
        continue;
      }
      if (ch.sampler < 0 || static_cast<std::size_t>(ch.sampler) >= src.samplers.size())
        return fail(ErrorCode::InvalidInput, cwhere, "sampler " + std::to_string(ch.sampler) + " does not exist");
      const tinygltf::AnimationSampler& sampler = src.samplers[static_cast<std::size_t>(ch.sampler)];
      const std::string swhere = where + ".samplers[" + std::to_string(ch.sampler) + "]";
      if (sampler.interpolation == "STEP") dst.interpolation = AnimationChannel::Interpolation::Step;
      else if (sampler.interpolation == "CUBICSPLINE") dst.interpolation = AnimationChannel::Interpolation::CubicSpline;
      else if (sampler.interpolation == "LINEAR" || sampler.interpolation.empty()) dst.interpolation = AnimationChannel::Interpolation::Linear;
      else return fail(ErrorCode::InvalidInput, swhere, "unknown interpolation '" + sampler.interpolation + "'");

      // Key times: finite and strictly increasing.
      auto input = accessor(sampler.input, swhere + ".input", {TINYGLTF_TYPE_SCALAR}, {TINYGLTF_COMPONENT_TYPE_FLOAT});
      if (!input) return input.error();
      PENUMBRA_TRY(check_finite(*input, sampler.input, swhere + ".input"));
      if (input->count() == 0) return fail(ErrorCode::InvalidInput, swhere, "has no keyframes");
      for (std::size_t k = 0; k < input->count(); ++k) {
        dst.times.push_back(static_cast<float>(input->component(k, 0)));
        if (k > 0 && !(dst.times[k] > dst.times[k - 1]))
          return fail(ErrorCode::InvalidInput, swhere + ".input", "key times are not strictly increasing at key " + std::to_string(k));
      }
      // Values: vec3 for translation/scale, quaternion (float or normalised integers) for rotation.
      const bool rotation = dst.path == AnimationChannel::Path::Rotation;
      auto output = rotation ? accessor(sampler.output, swhere + ".output", {TINYGLTF_TYPE_VEC4},
                                        {TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_COMPONENT_TYPE_BYTE,
                                         TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE, TINYGLTF_COMPONENT_TYPE_SHORT,
                                         TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT})
                             : accessor(sampler.output, swhere + ".output", {TINYGLTF_TYPE_VEC3}, {TINYGLTF_COMPONENT_TYPE_FLOAT});
      if (!output) return output.error();
      PENUMBRA_TRY(check_finite(*output, sampler.output, swhere + ".output"));
      const std::size_t per_key = dst.interpolation == AnimationChannel::Interpolation::CubicSpline ? 3 : 1;
      if (output->count() != per_key * dst.times.size())
        return fail(ErrorCode::InvalidInput, swhere,
                    "output has " + std::to_string(output->count()) + " values for " + std::to_string(dst.times.size()) +
                        " keys; " + sampler.interpolation + " needs " + std::to_string(per_key) + " per key");
      dst.values.resize(output->count(), glm::vec4(0.0f));
      for (std::size_t v = 0; v < output->count(); ++v)
        for (int k = 0; k < output->components; ++k) dst.values[v][k] = static_cast<float>(output->component(v, k));
      // Target index within the clip.
      auto found = std::find(target_nodes.begin(), target_nodes.end(), ch.target_node);
      dst.target = static_cast<std::uint32_t>(found - target_nodes.begin());
      if (found == target_nodes.end()) {
        target_nodes.push_back(ch.target_node);
        clip.targets.push_back(out_.nodes[static_cast<std::size_t>(ch.target_node)]);
      }
      clip.duration = std::max(clip.duration, dst.times.back());
      clip.channels.push_back(std::move(dst));
    }
    clips_->push_back(std::move(clip));
    ++out_.animations;
  }
  return {};
}

Status Importer::create_nodes() {
  // The scene's root nodes (default scene, else the first; without scenes, every parentless node).
  std::vector<int> roots;
  if (!model_.scenes.empty()) {
    const int scene = model_.defaultScene >= 0 ? model_.defaultScene : 0;
    if (static_cast<std::size_t>(scene) >= model_.scenes.size())
      return fail(ErrorCode::InvalidInput, "scene", "default scene " + std::to_string(scene) + " does not exist");
    roots = model_.scenes[static_cast<std::size_t>(scene)].nodes;
  } else {
    std::vector<bool> is_child(model_.nodes.size(), false);
    for (const tinygltf::Node& n : model_.nodes)
      for (int c : n.children)
        if (c >= 0 && static_cast<std::size_t>(c) < is_child.size()) is_child[static_cast<std::size_t>(c)] = true;
    for (std::size_t i = 0; i < model_.nodes.size(); ++i)
      if (!is_child[i]) roots.push_back(static_cast<int>(i));
  }
  // Nodes targeted by animation channels move, and so do their descendants.
  animated_nodes_.assign(model_.nodes.size(), false);
  for (const tinygltf::Animation& anim : model_.animations)
    for (const tinygltf::AnimationChannel& ch : anim.channels)
      if (ch.target_node >= 0 && static_cast<std::size_t>(ch.target_node) < model_.nodes.size())
        animated_nodes_[static_cast<std::size_t>(ch.target_node)] = true;
  out_.nodes.assign(model_.nodes.size(), Entity::null());
  // Depth-first with an explicit stack: a hostile file's deep hierarchy cannot overflow ours.
  struct Pending {
    int node;
    Entity parent;
    bool parent_animated;
  };
  std::vector<Pending> stack;
  for (auto it = roots.rbegin(); it != roots.rend(); ++it) stack.push_back({*it, out_.root, false});
  while (!stack.empty()) {
    const Pending p = stack.back();
    stack.pop_back();
    PENUMBRA_TRY(create_node(p.node, p.parent, p.parent_animated));
    const auto ni = static_cast<std::size_t>(p.node);
    const std::vector<int>& children = model_.nodes[ni].children;
    for (auto it = children.rbegin(); it != children.rend(); ++it)
      stack.push_back({*it, out_.nodes[ni], animated_nodes_[ni]});
  }
  return {};
}

Result<ImportedScene> Importer::run() {
  PENUMBRA_TRY(check_extensions());
  PENUMBRA_TRY(load_textures());
  PENUMBRA_TRY(load_materials());
  PENUMBRA_TRY(load_meshes());
  out_.root = create(file_);
  world_.add<Transform>(out_.root);
  // Hierarchy first; mesh contents need the skins, which need the joint entities.
  PENUMBRA_TRY(create_nodes());
  GltfScene imported;
  for (std::size_t i = 0; i < out_.nodes.size(); ++i)
    if (out_.nodes[i]) imported.nodes.push_back(static_cast<std::uint32_t>(i));
  world_.add<GltfScene>(out_.root, std::move(imported));
  PENUMBRA_TRY(load_skins());
  for (std::size_t i = 0; i < model_.nodes.size(); ++i)
    if (out_.nodes[i]) PENUMBRA_TRY(attach_node_contents(i, animated_nodes_[i]));
  PENUMBRA_TRY(load_animations());
  if (!clips_->empty()) world_.add<Animator>(out_.root, Animator{clips_});
  return std::move(out_);
}

// The glTF's integer property `key` of `object` (`fallback` when absent, or when present but not
// a non-negative integer, an error naming `where`, the value and the fix).
Result<std::uint64_t> json_count(const nlohmann::json& object, const char* key, std::uint64_t fallback,
                                 const std::string& where, const char* fix) {
  if (!object.contains(key)) return fallback;
  const nlohmann::json& v = object[key];
  if (v.is_number_unsigned()) return v.get<std::uint64_t>();
  return make_error(ErrorCode::InvalidInput, where + "." + key + " is " + v.dump() + ", not an integer >= 0; " + fix);
}

// The decoded size of a base64 data URI's payload (its padding and non-alphabet tail excluded).
std::uint64_t data_uri_bytes(std::string_view uri) {
  const std::size_t comma = uri.find(',');
  if (comma == std::string_view::npos) return 0;
  std::string_view payload = uri.substr(comma + 1);
  while (!payload.empty() && payload.back() == '=') payload.remove_suffix(1);
  return payload.size() * 3 / 4;
}

// The structural pre-check (before tinygltf decodes anything, images included): every buffer's
// byteLength against the bytes it has (external file, data URI, the binary chunk of a .glb); every
// bufferView's buffer, byteOffset, byteLength and byteStride (4..252, a multiple of 4, as the
// specification requires) against its buffer's byteLength; every accessor's and image's
// bufferView index and the accessor's byteOffset and count. Errors name `file`, the element, the
// value and the fix.
Status check_structure(const nlohmann::json& json, const std::string& file, const std::filesystem::path& path,
                       std::optional<std::uint64_t> glb_binary_bytes) {
  auto array = [&](const char* key) -> const nlohmann::json* {
    return json.contains(key) && json[key].is_array() ? &json[key] : nullptr;
  };
  auto fail = [&](const std::string& message) { return make_error(ErrorCode::InvalidInput, file + ": " + message); };
  std::vector<std::uint64_t> buffer_bytes;
  if (const nlohmann::json* buffers = array("buffers")) {
    for (std::size_t b = 0; b < buffers->size(); ++b) {
      const nlohmann::json& buffer = (*buffers)[b];
      const std::string where = element("buffers", b);
      if (!buffer.is_object()) return fail(where + " is not an object; fix or re-export the file");
      auto length = json_count(buffer, "byteLength", 0, where, "give the buffer's size in bytes");
      if (!length) return fail(length.error().message);
      std::optional<std::uint64_t> has;
      std::string source;
      if (buffer.contains("uri") && buffer["uri"].is_string()) {
        const std::string uri = buffer["uri"].get<std::string>();
        if (uri.rfind("data:", 0) == 0) {
          has = data_uri_bytes(uri);
          source = "its data URI decodes to";
        } else {
          std::error_code ec;
          const std::filesystem::path external = path.parent_path() / uri;
          if (!std::filesystem::is_regular_file(external, ec))
            return make_error(ErrorCode::NotFound, file + ": " + where + ": external buffer '" + uri +
                                                       "' not found (looked for " + external.string() +
                                                       "); put it next to the .gltf or fix the uri");
          has = std::filesystem::file_size(external, ec);
          source = "'" + uri + "' holds";
        }
      } else if (b == 0 && glb_binary_bytes) {
        has = *glb_binary_bytes;
        source = "the binary chunk holds";
      } else {
        // Only a .glb's first buffer may leave out its uri: it is the binary chunk (glTF 2.0, GLB-stored buffer).
        return fail(where + " has no 'uri' and " +
                    (b > 0 ? std::string("only buffers[0] of a .glb can be its binary chunk")
                           : std::string("the file has no binary chunk")) +
                    "; give it a uri (a file next to the .gltf or a data: URI), or re-export as .glb");
      }
      if (has && *has < *length)
        return fail(where + ": byteLength is " + std::to_string(*length) + " but " + source + " " +
                    std::to_string(*has) + " bytes; the file is truncated or damaged, re-export it");
      buffer_bytes.push_back(*length);
    }
  }
  std::size_t views = 0;
  if (const nlohmann::json* list = array("bufferViews")) {
    views = list->size();
    for (std::size_t v = 0; v < views; ++v) {
      const nlohmann::json& view = (*list)[v];
      const std::string where = element("bufferViews", v);
      if (!view.is_object()) return fail(where + " is not an object; fix or re-export the file");
      if (!view.contains("buffer")) return fail(where + " names no buffer; give it the index of one of the file's buffers");
      auto buffer = json_count(view, "buffer", 0, where, "name one of the file's buffers");
      auto offset = json_count(view, "byteOffset", 0, where, "give an offset in bytes >= 0");
      auto length = json_count(view, "byteLength", 0, where, "give the view's size in bytes");
      auto stride = json_count(view, "byteStride", 0, where, "give a stride of 4..252 bytes");
      for (const auto* r : {&buffer, &offset, &length, &stride})
        if (!*r) return fail(r->error().message);
      if (*buffer >= buffer_bytes.size())
        return fail(where + ".buffer is " + std::to_string(*buffer) + " but the file has " +
                    std::to_string(buffer_bytes.size()) + " buffers; fix the index");
      const std::uint64_t size = buffer_bytes[*buffer];
      if (*offset > size || *length > size - *offset)
        return fail(where + ": bytes " + std::to_string(*offset) + ".." + std::to_string(*offset + *length) +
                    " run past the end of " + element("buffers", *buffer) + " (" + std::to_string(size) +
                    " bytes); the file is damaged, re-export it");
      if (view.contains("byteStride") && (*stride < 4 || *stride > 252 || *stride % 4 != 0))
        return fail(where + ".byteStride is " + std::to_string(*stride) +
                    "; the specification allows multiples of 4 from 4 to 252");
    }
  }
  for (const char* kind : {"accessors", "images"}) {
    const nlohmann::json* list = array(kind);
    if (!list) continue;
    for (std::size_t i = 0; i < list->size(); ++i) {
      const nlohmann::json& item = (*list)[i];
      const std::string where = element(kind, i);
      if (!item.is_object()) return fail(where + " is not an object; fix or re-export the file");
      if (item.contains("bufferView")) {
        auto view = json_count(item, "bufferView", 0, where, "name one of the file's bufferViews");
        if (!view) return fail(view.error().message);
        if (*view >= views)
          return fail(where + ".bufferView is " + std::to_string(*view) + " but the file has " +
                      std::to_string(views) + " bufferViews; fix the index");
      }
      if (std::string_view(kind) == "accessors") {
        auto offset = json_count(item, "byteOffset", 0, where, "give an offset in bytes >= 0");
        if (!offset) return fail(offset.error().message);
        auto count = json_count(item, "count", 0, where, "give the number of elements (>= 1)");
        if (!count) return fail(count.error().message);
        if (*count == 0) return fail(where + ".count is 0; the specification requires at least 1 element");
      }
    }
  }
  return {};
}

}  // namespace

Result<ImportedScene> import_gltf(World& world, const std::filesystem::path& path, const ImportOptions& options) {
  const std::string file = path.string();
  std::error_code ec;
  const auto status = std::filesystem::status(path, ec);
  if (std::filesystem::is_directory(status))
    return make_error(ErrorCode::InvalidInput, file + ": is a folder, not a glTF file; give the .gltf or .glb inside it");
  if (!std::filesystem::is_regular_file(status))
    return make_error(ErrorCode::NotFound, file + ": file not found (looked for " +
                                               std::filesystem::absolute(path, ec).string() + "); check the path");

  // Sniff the container: binary glTF starts with the magic "glTF".
  std::ifstream stream(path, std::ios::binary);
  char magic[4] = {};
  stream.read(magic, 4);
  if (!stream && stream.gcount() == 0)
    return make_error(ErrorCode::Io, path.string() + ": could not be read");
  const bool binary = stream.gcount() == 4 && std::memcmp(magic, "glTF", 4) == 0;

  // The JSON text: the whole file, or a binary glTF's first chunk (version 2 only).
  std::string json_text;
  std::optional<std::uint64_t> glb_binary_bytes;  // the bytes a .glb's binary chunk holds
  if (binary) {
    std::uint32_t header[2] = {}, chunk[2] = {};  // version, length; chunk length, type
    stream.read(reinterpret_cast<char*>(header), sizeof header);
    stream.read(reinterpret_cast<char*>(chunk), sizeof chunk);
    if (!stream) return make_error(ErrorCode::InvalidInput, path.string() + ": the binary glTF header is truncated");
    if (header[0] != 2)
      return make_error(ErrorCode::Unsupported, path.string() + ": binary glTF version " + std::to_string(header[0]) +
                                                     " is not supported; re-export as glTF 2.0");
    if (chunk[1] != 0x4E4F534Au || chunk[0] > std::filesystem::file_size(path, ec))
      return make_error(ErrorCode::InvalidInput, path.string() + ": the first chunk is not a JSON chunk of a length "
                                                                 "the file holds; the file is damaged");
    json_text.resize(chunk[0]);
    stream.read(json_text.data(), static_cast<std::streamsize>(json_text.size()));
    if (!stream) return make_error(ErrorCode::InvalidInput, path.string() + ": the JSON chunk is truncated");
    // The binary chunk, when there is one: 8 header bytes after the JSON chunk (padded to 4).
    stream.seekg(static_cast<std::streamoff>(20 + ((std::uint64_t{chunk[0]} + 3) & ~std::uint64_t{3})));
    std::uint32_t bin[2] = {};
    stream.read(reinterpret_cast<char*>(bin), sizeof bin);
    if (stream && bin[1] == 0x004E4942u) {
      const std::uint64_t start = 28 + ((std::uint64_t{chunk[0]} + 3) & ~std::uint64_t{3});
      const std::uint64_t size = std::filesystem::file_size(path, ec);
      glb_binary_bytes = std::min<std::uint64_t>(bin[0], size > start ? size - start : 0);
    }
    stream.clear();
  } else {
    stream.seekg(0);
    std::stringstream text;
    text << stream.rdbuf();
    json_text = text.str();
  }
  if (const int depth = json_depth(json_text, kMaxJsonDepth); depth > kMaxJsonDepth)
    return make_error(ErrorCode::InvalidInput, path.string() + ": JSON nested more than " +
                                                   std::to_string(kMaxJsonDepth) +
                                                   " levels deep; the file is malformed (a glTF needs fewer than 20)");

  // The structural pre-check, before tinygltf decodes anything (see check_structure). The parsed
  // JSON stays for the PENUMBRA_lighting declarations, which tinygltf's values would not keep whole
  // (it drops empty objects, so `"AOFieldReceiver": {}` would vanish).
  nlohmann::json json;
  try {
    json = nlohmann::json::parse(json_text);
  } catch (const nlohmann::json::exception& e) {
    return make_error(ErrorCode::InvalidInput, file + ": not valid JSON (" + e.what() + "); fix or re-export the file");
  }
  PENUMBRA_TRY(check_structure(json, file, path, glb_binary_bytes));
  stream.close();

  tinygltf::TinyGLTF loader;
  if (!options.load_textures) loader.SetImageLoader(skip_image_decoding, nullptr);
  tinygltf::Model model;
  std::string err, warn;
  bool loaded = false;
  try {
    loaded = binary ? loader.LoadBinaryFromFile(&model, &err, &warn, path.string())
                    : loader.LoadASCIIFromFile(&model, &err, &warn, path.string());
  } catch (const std::exception& e) {
    err = e.what();
  }
  if (!loaded) {
    while (!err.empty() && (err.back() == '\n' || err.back() == ' ')) err.pop_back();
    return make_error(ErrorCode::InvalidInput, file + ": tinygltf could not parse it: " + err);
  }

  Importer importer(world, model, json, file, options);
  if (!warn.empty()) log(LogLevel::Warning, file + ": tinygltf: " + warn);
  Result<ImportedScene> result = Error{};
  try {
    result = importer.run();
  } catch (const std::bad_alloc&) {
    result = make_error(ErrorCode::OutOfBudget, file + ": ran out of memory while importing");
  }
  if (!result) importer.roll_back();
  return result;
}

Result<LoadedScene> load_scene(World& world, std::string_view spec) {
  constexpr std::string_view kPrefix = "builtin:";
  if (spec.substr(0, kPrefix.size()) == kPrefix) return load_builtin(world, spec.substr(kPrefix.size()));
  auto imported = import_gltf(world, std::filesystem::path(spec));
  if (!imported) return imported.error();
  LoadedScene scene;
  scene.name = std::filesystem::path(spec).filename().string();
  scene.root = imported->root;
  for (Entity e : imported->nodes)
    if (e && world.has<Camera>(e)) {
      scene.camera = e;
      break;
    }
  scene.mesh_entities = imported->mesh_entities;
  scene.triangles = imported->triangles;
  scene.dropped_degenerate = imported->dropped_degenerate;
  scene.warnings = std::move(imported->warnings);
  return scene;
}

}  // namespace penumbra
