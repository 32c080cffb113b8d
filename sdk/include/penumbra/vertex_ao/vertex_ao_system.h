// The runtime half of vertex AO: its module descriptor. It has no per-frame system: attaching a
// VXAO chunk gives each baked entity its VertexAO (scene/components.h; added, or replaced with
// World::patch), which the renderer reads by change tick. Attach fails with NotFound naming the
// key when the entity is gone or its mesh has another vertex count (re-bake the scene).
#pragma once

#include "penumbra/lighting/module.h"
#include "penumbra/vertex_ao/vertex_ao.h"

namespace penumbra {

const LightingModule& vertex_ao_module();

}  // namespace penumbra
