// Scene components: what a World holds after importing a glTF file or building a built-in scene.
// Transform, WorldTransform and the parent/child hierarchy live in the ecs layer
// (penumbra/ecs/transform.h); this header adds geometry, materials, lights, cameras, skins and
// animation.
//
// Units and frames: metres, right-handed, +Y up (as glTF). Radiometric quantities are named where
// they are declared.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <variant>
#include <vector>

#include <glm/common.hpp>
#include <glm/ext/vector_uint4_sized.hpp>
#include <glm/geometric.hpp>
#include <glm/mat4x4.hpp>
#include <glm/vec2.hpp>
#include <glm/vec3.hpp>
#include <glm/vec4.hpp>

#include "penumbra/core/result.h"
#include "penumbra/ecs/transform.h"
#include "penumbra/ecs/world.h"

namespace penumbra {

struct Aabb {
  glm::vec3 min{std::numeric_limits<float>::max()};
  glm::vec3 max{-std::numeric_limits<float>::max()};
  bool empty() const { return min.x > max.x; }
  void extend(glm::vec3 p) { min = glm::min(min, p); max = glm::max(max, p); }
  glm::vec3 center() const { return 0.5f * (min + max); }
  glm::vec3 extent() const { return max - min; }
};

// Triangle mesh in the mesh's local frame, shared between entities (an asset).
// Invariants established by import and by MeshData::validate(): every attribute array is empty or
// has positions.size() entries; indices.size() is a multiple of 3 and every index is in range; all
// values are finite; no triangle has zero area (degenerate ones are dropped and counted at import).
struct MeshData {
  std::string name;
  std::vector<glm::vec3> positions;
  std::vector<glm::vec3> normals;      // unit length; computed (area-weighted) when the source has none
  std::vector<glm::vec2> uvs;          // TEXCOORD_0
  std::vector<glm::u16vec4> joints;    // JOINTS_0: indices into the entity's Skin::joints
  std::vector<glm::vec4> weights;      // WEIGHTS_0: sum to 1
  std::vector<std::uint32_t> indices;  // triangle list
  Aabb bounds;                         // of positions

  std::size_t triangle_count() const { return indices.size() / 3; }
  std::size_t bytes() const;
  // Checks the invariants above; the error names `context` (e.g. "scene.gltf: meshes[2]").
  Status validate(std::string_view context) const;
};

// The geometry of an entity: one triangle mesh with one Material (a glTF mesh with several
// primitives becomes one child entity per primitive).
struct Mesh {
  std::shared_ptr<const MeshData> data;
};

// An RGBA8 image (an asset), sRGB-encoded colour unless stated.
struct Texture {
  std::string name;
  int width = 0, height = 0;
  std::vector<std::uint8_t> rgba8;
  glm::vec3 average_linear{1.0f};  // mean linear colour, for bakers that need one albedo per material
};

// Lambertian surface with emission (glTF metallic-roughness subset that lighting uses).
struct Material {
  glm::vec4 base_color{1.0f};                       // linear RGB reflectance (albedo) and alpha
  std::shared_ptr<const Texture> base_color_texture;  // multiplies base_color; may be null
  glm::vec3 emissive{0.0f};  // emitted radiance, W/(m^2 sr) per channel (glTF emissiveFactor x KHR_materials_emissive_strength)
  bool double_sided = false;
};

// KHR_lights_punctual semantics, plus rectangular area lights for built-in scenes.
// Lights shine along the entity's local -Z (directional, spot, rect).
struct Light {
  enum class Type : std::uint8_t { Directional, Point, Spot, Rect };
  Type type = Type::Point;
  glm::vec3 color{1.0f};  // linear RGB, multiplies intensity
  // Directional: illuminance in lux (W/m^2 in our radiometric use).
  // Point, spot: luminous intensity in candela (W/sr).
  // Rect: emitted radiance in W/(m^2 sr), one-sided (towards local -Z), Lambertian.
  float intensity = 1.0f;
  float range = 0.0f;             // 0: infinite; else the KHR_lights_punctual window (d/range)^4
  float inner_cone_angle = 0.0f;  // spot, radians
  float outer_cone_angle = 0.7853981633974483f;  // spot, radians (pi/4)
  glm::vec2 size{1.0f};           // rect: width (local X) and height (local Y) in metres
};

// A light in world space, from its world matrix: its position (the rect's centre), the unit
// direction it shines along (local -Z), the rect's half-size vectors (local X and Y x size / 2).
// `valid` is false for a non-finite or singular matrix; `zero_rect` for a rect of no area. O(1).
struct LightFrame {
  glm::vec3 position{0.0f};
  glm::vec3 direction{0.0f, 0.0f, -1.0f};
  glm::vec3 half_x{0.5f, 0.0f, 0.0f}, half_y{0.0f, 0.5f, 0.0f};
  bool valid = false;
  bool zero_rect = false;
};
LightFrame light_frame(const Light& light, const glm::mat4& world);

// What a point or spot light's inverse-square irradiance is multiplied by at distance `distance`
// in unit direction `l` from the surface towards the light (`direction`: where the light shines):
// KHR_lights_punctual's recommended range window (1 - (d / range)^4)^2 (none for range 0) and, for
// a spot, the smooth cone (a squared linear ramp in cos between the outer and inner angles). O(1).
inline float punctual_window(const Light& light, glm::vec3 direction, glm::vec3 l, float distance) {
  float f = 1.0f;
  if (light.range > 0.0f) {
    const float r = distance / light.range;
    const float w = glm::clamp(1.0f - r * r * r * r, 0.0f, 1.0f);
    f *= w * w;
  }
  if (light.type == Light::Type::Spot) {
    const float cos_outer = std::cos(light.outer_cone_angle);
    const float scale = 1.0f / std::max(0.001f, std::cos(light.inner_cone_angle) - cos_outer);
    const float a = glm::clamp((glm::dot(direction, -l) - cos_outer) * scale, 0.0f, 1.0f);
    f *= a * a;
  }
  return f;
}

// An equirectangular radiance map (W/(m^2 sr) per texel and channel), +Y up as in glTF: direction d
// is at u = 0.5 + atan2(d.x, -d.z) / 2pi across the width (-Z at the centre, +X at three quarters)
// and v = acos(d.y) / pi down the height (the top row looks up). Immutable once made; share it.
struct EnvironmentMap {
  std::uint32_t width = 0, height = 0;
  std::vector<glm::vec3> texels;  // width x height, row-major from the top row
  std::uint64_t digest = 0;       // of the size and texels (what bake input hashes add)
};
// Wraps texels into a map, its digest computed. InvalidArgument naming `context` and the fix: a
// zero size, texels.size() != width x height, a side over 16384, or a texel that is negative, NaN
// or infinite (naming its x, y). O(texels).
Result<std::shared_ptr<const EnvironmentMap>> make_environment_map(std::uint32_t width, std::uint32_t height,
                                                                   std::vector<glm::vec3> texels,
                                                                   std::string_view context);
// The map's radiance toward `direction` (normalised): bilinear between texel centres, wrapping
// across the width, clamped at the poles' rows. O(1).
glm::vec3 sample_environment_map(const EnvironmentMap& map, glm::vec3 direction);

// The sky: the radiance a ray that leaves the scene sees. The World's environment is the first
// entity with one, in entity order; none: black. It lights the scene through the bakes (every
// escaping ray of the integrators, the probe grid and the offline renderer brings it), and the
// renderer draws it as the background.
struct Environment {
  // Without a map: the radiance from every direction (a constant sky colour).
  glm::vec3 radiance{0.0f};
  // The equirectangular OpenEXR file of the map as authored (in a glTF, relative to the file;
  // load_environment_map, import/environment.h, reads it into map_data); empty: no map.
  std::string map;
  // The map's texels, or null: with one, the sky toward d is map_scale x the map at d and
  // `radiance` is not used.
  std::shared_ptr<const EnvironmentMap> map_data;
  float map_scale = 1.0f;

  // The radiance seen toward `direction` (normalised). O(1).
  glm::vec3 toward(glm::vec3 direction) const {
    return map_data ? map_scale * sample_environment_map(*map_data, direction) : radiance;
  }
};
// The World's environment (above): a copy of the first Environment, else a black one. O(entities
// with one).
Environment world_environment(World& world);

struct Camera {
  float yfov = 0.8f;   // radians
  float aspect = 0.0f; // as authored (glTF aspectRatio; 0: none), kept for export: views take the target's, with yfov
  float znear = 0.05f;
  float zfar = 1000.0f;
};

// Skinning: joints are entities of the hierarchy; the posed matrices are computed each frame.
struct Skin {
  std::vector<Entity> joints;
  std::vector<glm::mat4> inverse_bind;  // one per joint
};
// Written by the skinning system: joint_matrices[j] = inverse(mesh world) * joint world * inverse_bind[j].
struct SkinPose {
  std::vector<glm::mat4> joint_matrices;
};

// Per-vertex ambient occlusion of a Mesh entity, the one per-vertex AO concept: ao[v] in [0, 1]
// (1 = open) for vertex v of its MeshData, multiplied into the ambient (indirect) light by the
// renderer (the composition rule, render/renderer.h); ignored when the size does not match the
// mesh. Written by whoever computes it: a loaded vertex-AO bake (static meshes,
// vertex_ao/vertex_ao.h), PoseAOSystem every frame the pose changed (skinned meshes,
// pose_ao_system.h). Write it with World::patch: readers (the renderer's upload) redo work only
// when its change tick moved.
struct VertexAO {
  std::vector<float> ao;
  // The occluders are the static geometry (a vertex-AO bake), which every baked ambient source
  // (the probe grid) already shadows its light by: the renderer then leaves it out of their light
  // and shows it only in the "ao" view. False: moving occluders no source saw (pose-AO).
  bool static_occluders = false;
};

// Animation clips (an asset): keyframe channels targeting entities' Transforms.
struct AnimationChannel {
  enum class Path : std::uint8_t { Translation, Rotation, Scale };
  enum class Interpolation : std::uint8_t { Linear, Step, CubicSpline };
  std::uint32_t target = 0;          // index into AnimationClip::targets
  Path path = Path::Translation;
  Interpolation interpolation = Interpolation::Linear;
  std::vector<float> times;          // strictly increasing seconds
  std::vector<glm::vec4> values;     // xyz (translation, scale) or quaternion xyzw; CubicSpline: in-tangent, value, out-tangent per key
};
struct AnimationClip {
  std::string name;
  float duration = 0.0f;
  std::vector<Entity> targets;
  std::vector<AnimationChannel> channels;
};
// Plays one clip of a set on the entities the clips target.
struct Animator {
  std::shared_ptr<const std::vector<AnimationClip>> clips;
  std::uint32_t clip = 0;
  float time = 0.0f;   // seconds into the clip
  float speed = 1.0f;
  bool loop = true;
  bool playing = true;
};

// On a Light: its bounce light comes from the indirect transport (indirect_transport/), whose
// lightmap holds it per texel on the static surfaces. A light that `moves` (a lantern, a torch,
// headlights) is followed at runtime through the transport operator; one that does not (a window,
// a ceiling panel) has its bounce baked into the lightmap, its Light and place among the bake's
// inputs, and a transport whose lights are all fixed keeps no operator. Bakes of fixed lighting
// (the probe grid) leave it out. Directional lights are not local lights: the transport ignores
// them.
struct DynamicLight {
  bool enabled = true;
  bool moves = true;
};

// Tag: the entity and its geometry never move (baked into the static BVH).
struct Static {};

// Name from the source file (glTF node name) or the built-in scene.
struct Name {
  std::string value;
};
// A node name without the namespace prefix exporters add by rig or file ("mixamorig:Hips" and
// "Armature|Hips" -> "Hips"); the name itself when it has none. O(length).
inline std::string_view name_without_namespace(std::string_view name) {
  const auto cut = name.find_last_of(":|");
  return cut == std::string_view::npos ? name : name.substr(cut + 1);
}

// Lighting components a glTF node declares (its PENUMBRA_lighting extension), as the file gives
// them: the importer reads them without knowing the lighting modules, and apply_authored_lighting
// (penumbra/runtime.h) turns them into components by the modules' field lists, then removes this.
// Values keep their JSON shape: true/false, a number, a string (an enum value's name), an array.
using AuthoredValue = std::variant<bool, double, std::string, std::vector<double>>;
struct AuthoredComponent {
  std::string type;    // a component's name, e.g. "IrradianceProbeGrid"
  std::string preset;  // "draft", "medium", "high" or empty: the preset the fields start from
  std::vector<std::pair<std::string, AuthoredValue>> fields;  // by field name
};
struct AuthoredLighting {
  std::string source;  // "FILE: nodes[3] 'hall'": where error messages point
  std::vector<AuthoredComponent> components;
  std::vector<Entity> meshes;  // the node's mesh entities (one per primitive), for per-mesh components
};

// The glTF node an entity was imported from (import_gltf adds it): its index in the file's `nodes`.
struct GltfNode {
  std::uint32_t index = 0;
};

// On the root entity import_gltf makes for a file: the nodes it imported (those of the scene), so
// that writing the World back can tell which of them were deleted since.
struct GltfScene {
  std::vector<std::uint32_t> nodes;
};
// On an entity made as a copy of glTF node `node` (an editor's duplicate): written back as a new
// node with that node's mesh, skin and camera.
struct GltfNodeCopy {
  std::uint32_t node = 0;
};

// What save_gltf (import/gltf.h) changes in one node of the file; what is left empty is kept as read.
struct GltfNodeEdit {
  std::uint32_t node = 0;              // index into the file's nodes
  std::optional<Transform> transform;  // written as translation/rotation/scale when it changed
  std::optional<Light> light;          // the node's KHR_lights_punctual light (not a Rect)
  // Its PENUMBRA_lighting components (runtime.h: authored_components) and sky ("environment");
  // with neither, the extension is removed.
  std::vector<AuthoredComponent> lighting;
  std::optional<Environment> environment;
};

// A node save_gltf adds: an entity the file does not have (created, or a copy of node copy_of).
struct GltfNewNode {
  std::string name;
  std::optional<std::uint32_t> parent;        // a node of the file, or
  std::optional<std::uint32_t> added_parent;  // an earlier entry of GltfEdits::added; neither: a root of the scene
  std::optional<std::uint32_t> copy_of;       // a node of the file whose mesh, skin and camera it takes
  Transform transform;
  std::optional<Light> light;                 // a new KHR_lights_punctual light (not a Rect)
  std::vector<AuthoredComponent> lighting;
  std::optional<Environment> environment;
};

// Everything save_gltf writes: edits of the file's nodes, nodes to add, and nodes to take out of
// the scene (unlinked from their parent and the scenes' root lists; they stay in the file's node
// array, so no index in it changes).
struct GltfEdits {
  std::vector<GltfNodeEdit> nodes;
  std::vector<GltfNewNode> added;
  std::vector<std::uint32_t> removed;
};

}  // namespace penumbra
