// glTF 2.0 import (.gltf with external or base64 buffers, .glb) into a World, through tinygltf.
//
// What becomes what:
//   node                -> entity with Transform, Name and Parent/Children (ecs set_parent)
//   mesh primitive      -> child entity of the node with Mesh + Material (+ Skin if the node has one)
//   material            -> Material (baseColorFactor/Texture, emissiveFactor x
//                          KHR_materials_emissive_strength, doubleSided)
//   texture image       -> Texture (RGBA8, decoded by tinygltf through stb) with average_linear
//   skin                -> Skin on each primitive entity of the skinned node (a skin no node of the
//                          scene uses is not read)
//   animations          -> one AnimationClip each, shared by one Animator on the root entity (a
//                          channel whose node is not in the scene is skipped with a warning)
//   KHR_lights_punctual -> Light;  camera (perspective) -> Camera
//   PENUMBRA_lighting   -> AuthoredLighting on the node's entity (apply_authored_lighting, runtime.h)
// Each node's entity also gets GltfNode (its index in the file), which save_gltf writes back to.
// Everything tinygltf does not check is validated here: accessor ranges against buffer views and
// buffers, component types, index ranges, finite values, joint indices against the skin, weight
// sums, node and skin references, animation key times. Degenerate triangles are dropped and
// counted. Errors name the file and the element, e.g. "scene.gltf: accessors[1]: ...".
#pragma once

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "penumbra/core/result.h"
#include "penumbra/ecs/transform.h"
#include "penumbra/ecs/world.h"
#include "penumbra/scene/builtin.h"
#include "penumbra/scene/components.h"

namespace penumbra {

struct ImportOptions {
  // Tag every non-skinned, non-animated mesh entity Static (the bakers put those in the static BVH).
  bool mark_static = true;
  // Degenerate-triangle threshold, relative to the mesh's squared bounding-box diagonal.
  float degenerate_epsilon = 1e-9f;
  // Decode base colour textures (off: materials keep only their factors).
  bool load_textures = true;
};

struct ImportedScene {
  Entity root;                 // parent of the scene's root nodes; holds the Animator if any
  std::vector<Entity> nodes;   // entity of glTF node i (null for nodes not in the scene)
  std::size_t mesh_entities = 0;        // entities with a Mesh (one per primitive)
  std::size_t triangles = 0;            // after dropping degenerate ones
  std::size_t dropped_degenerate = 0;   // degenerate triangles removed
  std::size_t materials = 0, textures = 0, skins = 0, animations = 0, lights = 0, cameras = 0;
  std::vector<std::string> warnings;    // non-fatal findings (also sent to the log)
};

// Imports `path` into `world`. Cost: linear in the file size (plus texture decoding).
// Thread safety: mutates `world`; do not call concurrently on the same World.
// On error nothing is left in the world (entities created so far are destroyed).
// Error codes: NotFound (file or external buffer missing), InvalidInput (malformed file or data),
// Unsupported (a required extension or feature Penumbra does not handle), Io (unreadable file).
Result<ImportedScene> import_gltf(World& world, const std::filesystem::path& path,
                                  const ImportOptions& options = {});

// Rewrites the glTF file `source` as `out` with `edits` applied and everything else kept as read
// (meshes, buffers, images, animations, extras, other extensions; a node's transform is rewritten,
// as translation/rotation/scale, and a light's settings, only where they differ from the file's
// beyond float rounding): a .gltf stays JSON with the same
// buffer, image and environment-map URIs (relative ones resolve against out's folder: save next
// to the source, or copy its external files), a .glb keeps its binary chunk byte for byte. `out` has the source's
// extension; it is written atomically (core/file.h), so it may be `source` itself. extensionsUsed
// lists PENUMBRA_lighting exactly when some node declares it. Removed nodes are unlinked from
// their parents and the scenes (a file without scenes gets one listing its parentless nodes);
// added nodes are appended, under their parent or in the default scene's root list, a light as a
// new KHR_lights_punctual light (extensionsUsed then lists it). Errors: the source's own (NotFound,
// InvalidInput, naming the file), InvalidArgument (another extension for out, a node index outside
// the file, an added node's parent added after it, a light edit for a node without a light or of a
// rect light, a non-finite transform), InvalidInput (a node, scene, light or extensions entry that
// is not an object), Io. Cost: linear in the file's size.
Status save_gltf(const std::filesystem::path& source, const std::filesystem::path& out, const GltfEdits& edits);

// What import_animations added.
struct ImportedAnimations {
  std::size_t clips = 0;               // clips added: those of which some channel found its node
  std::size_t channels = 0;            // channels retargeted
  std::size_t unmatched_channels = 0;  // channels on nodes the scene has no node of that name for
  Entity animator;                     // the Animator the clips were appended to
  std::vector<std::string> warnings;   // the dropped channels' nodes, named
};

// Adds the animations of the glTF file `path` (clips delivered apart from the character, e.g.
// walk.glb from an animation library) to `world`, retargeted by node name: a channel on a node
// named N drives the entity of `world` named N, else the one whose name matches without its
// namespace prefix ("rig:Hips" and "mixamorig:Hips" match "Hips"). The retarget assumes the
// same skeleton (the same bind pose, units and proportions): keys are applied as they are.
// Channels whose node finds no match are dropped, counted and named in `warnings`. The clips are
// appended to the Animator whose clips already drive the first matched node, else to a new
// Animator on that node's hierarchy root; the pose-AO bake samples every clip that drives a
// skin's joints (pose_ao_baker.h). Errors name the file: the importer's, InvalidInput when the
// file has no animations or none of its channels drives a node of `world` (naming the nodes).
// Cost: one import of the file without textures.
Result<ImportedAnimations> import_animations(World& world, const std::filesystem::path& path);

// "builtin:NAME" loads a built-in scene (builtin.h); anything else is a path to a .gltf or .glb
// file (import_gltf with default options).
Result<LoadedScene> load_scene(World& world, std::string_view spec);

}  // namespace penumbra
