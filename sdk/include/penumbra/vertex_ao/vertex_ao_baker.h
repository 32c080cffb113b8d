// The vertex-AO baker: every Static mesh's vertices, then every skinned mesh's in its bind pose
// (vertex_ao.h), VertexAoSettings::preset(bake preset), one random stream per vertex
// (bit-identical at any thread count), one VXAO chunk.
#pragma once

#include "penumbra/ecs/world.h"

namespace penumbra {

// Adds the "vertex-ao" baker to world.resource<BakerRegistry>() (penumbra/bake/baker.h).
void register_vertex_ao_baker(World& world);

}  // namespace penumbra
