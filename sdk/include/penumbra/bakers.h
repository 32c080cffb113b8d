// What a bake tool calls: every lighting module's baker (penumbra::bakers; links Embree).
#pragma once

#include "penumbra/ecs/world.h"

namespace penumbra {

// Registers every module's baker (sdk/src/runtime/modules.inc) with world.resource<BakerRegistry>()
// (penumbra/bake/baker.h), in the modules' order. The runtime (register_lighting) is separate.
void register_bakers(World& world);

}  // namespace penumbra
