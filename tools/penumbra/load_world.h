// Setting up a World with every module the tools link: shared by the penumbra tool and the editor
// (library penumbra_load_world), so that a module registered here is known to both.
#pragma once

#include <string>
#include <string_view>

#include "penumbra/bake/baker.h"
#include "penumbra/core/result.h"
#include "penumbra/ecs/world.h"

namespace penumbra::cli {

// Registers every module's runtime (register_lighting) and baker (register_bakers) with `world`
// (once per World).
void register_modules(World& world);

// Loads `builtin:NAME` or a glTF path into `world`, registers every module's systems and bakers and
// runs one update so that world transforms and poses are current. Built-in scenes get every
// module's default components with the settings of `preset` (add_default_lighting).
Status load_world(World& world, std::string_view scene, Preset preset = Preset::Medium);

// For viewing a scene without any Light (a character or prop exported alone, which would render
// black): adds a directional light named "default light" (3 W/m^2, from above and in front, as the
// framing camera looks) and returns a notice that says so, naming `scene`; "" when the scene has a
// light. Only the viewers call it (render, the editor): a bake holds the lights the file declares.
std::string add_viewing_light(World& world, std::string_view scene);

// What `--sky FILE.exr` does in bake and render: the World's sky becomes the equirectangular
// OpenEXR map at `path` times `scale`, on the entity of its first Environment (or a new entity
// named "sky"). Errors name the file and the fix (load_environment_map, import/environment.h).
Status set_sky_map(World& world, const std::string& path, float scale);

}  // namespace penumbra::cli
