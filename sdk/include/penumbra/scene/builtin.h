// Built-in scenes, built procedurally so the repository needs no asset files (load_scene in
// gltf.h loads either a built-in scene or a glTF file).
//
//   cornell    the Cornell Box (Cornell University Program of Computer Graphics measurements),
//              metres, open at the front (-Z), one Light{Rect} under the ceiling, a Camera at
//              the published position; 30 triangles.
//   courtyard  a 20 x 20 m open courtyard: ground, two perimeter walls, a free-standing 5 cm
//              thin wall (open on both sides: light leaks through it in a naive probe grid),
//              pillars, an arch, crates (movable: not Static), a sun (Directional) and a point
//              light, a camera, and a procedural skinned character (8 joints) with a looping
//              walk clip on an Animator; about 2,000 triangles.
//   furnace    a closed inward-facing icosphere of radius kFurnaceRadius with albedo
//              kFurnaceAlbedo and emitted radiance kFurnaceRadiance: at every interior point and
//              for every normal the irradiance is pi * Le / (1 - rho) (all bounces), i.e.
//              kFurnaceIrradiance; 5,120 triangles.
//   maze       a 12 x 8 x 2.5 m room of large quads cut into corridors by a red, a green and a blue
//              wall, with a point light ("lantern") that an Animator carries along a path through
//              the corridors and back every 12 s, and a camera; 30 triangles. The indirect
//              transport's scene (moving local light, planar receivers).
//   humanoid   a character as the common pipelines export it (add_builtin_humanoid below): no
//              light, no camera, no ground.
// All static geometry carries the Static tag. Thread safety: each call mutates its World only.
#pragma once

#include <cstddef>
#include <numbers>
#include <string>
#include <string_view>
#include <vector>

#include "penumbra/core/result.h"
#include "penumbra/ecs/transform.h"
#include "penumbra/ecs/world.h"

namespace penumbra {

// The furnace's closed form (grey: the same value in R, G and B).
inline constexpr float kFurnaceRadius = 1.0f;    // metres
inline constexpr float kFurnaceAlbedo = 0.5f;    // rho, Lambertian reflectance
inline constexpr float kFurnaceRadiance = 1.0f;  // Le, emitted radiance W/(m^2 sr)
// E = pi * Le * (1 + rho + rho^2 + ...) = pi * Le / (1 - rho).
inline constexpr float kFurnaceIrradiance =
    std::numbers::pi_v<float> * kFurnaceRadiance / (1.0f - kFurnaceAlbedo);

// What a loaded scene consists of.
struct LoadedScene {
  std::string name;                 // built-in name or the file name
  Entity root;                      // parent of everything the scene created
  Entity camera;                    // the scene's first camera; null if it has none
  std::size_t mesh_entities = 0;    // entities with a Mesh
  std::size_t triangles = 0;
  std::size_t dropped_degenerate = 0;  // glTF only
  std::vector<std::string> warnings;   // glTF only
};
using BuiltinScene = LoadedScene;

// Names accepted by load_builtin ("cornell", "courtyard", "furnace", "maze", "humanoid").
std::vector<std::string> builtin_scene_names();

// Builds the named scene into `world`. NotFound (listing the valid names) for an unknown name.
// Cost: milliseconds (the largest scene has a few thousand triangles).
Result<LoadedScene> load_builtin(World& world, std::string_view name);

// The courtyard's walker, for games and tests that need more characters: an entity named `name`
// with `transform` under `parent` (null: a root entity), 8 joint entities, a skinned mesh child
// "character_mesh" (822 vertices, 1.83 m tall; the limbs swing in the YZ plane, walking in
// place) and an Animator looping its 1.2 s walk clip (not Static). Returns the character's
// entity. Cost: microseconds.
Entity add_builtin_character(World& world, Entity parent, const Transform& transform,
                             std::string_view name = "character");

// A character shaped like the production rigs studios ship, for tests and benches that must not
// depend on third-party files: an entity named `name` with `transform` under `parent`, an
// "Armature" child scaled by 0.01 holding 65 joints named as Mixamo exports name them
// ("mixamorig:Hips" ... "mixamorig:LeftHandPinky4", "mixamorig:RightToe_End": spine, head, arms
// with five three-segment fingers, legs), in a T-pose 1.82 m tall facing +Z, and two skinned
// meshes with the same skin: "body" (tubes along the bones, about 8,000 vertices) and "gear"
// (shoulder pads, knee pads, a belt that occlude the body). One clip, "Take 001", two keys 0.067
// s apart that turn no joint more than 0.005 rad, on an Animator on the character. Returns the
// character's entity. Cost: about a millisecond.
Entity add_builtin_humanoid(World& world, Entity parent, const Transform& transform,
                            std::string_view name = "humanoid");

// Appends to the Animator of `humanoid` (from add_builtin_humanoid) a walk cycle, as an animation
// library delivers it apart from the character (the way import_animations adds a walk.glb): clip
// "Walk", 1 s, keys every 1/8 s: the arms lowered 1.2 rad from the T-pose and swinging +-0.35
// rad, elbows bent 0.3-0.6 rad, thighs swinging +-0.45 rad, knees bent 0.05-0.65 rad, the spine
// turning against the hips by 0.1 rad. Returns false (adding nothing) when `humanoid` has no
// Animator or its first clip targets no joint of those names. Cost: microseconds.
bool add_builtin_humanoid_walk(World& world, Entity humanoid);

}  // namespace penumbra
