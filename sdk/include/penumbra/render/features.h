// The render features of the SDK's lighting modules (penumbra::render).
#pragma once

#include "penumbra/render/feature.h"

namespace penumbra {

// One of each lighting module's render feature (render/feature.h), in the order of the module
// list (sdk/src/runtime/modules.inc): the probe grid's (a source), the AO fields' (an occluder).
// Cost: allocation only; Renderer::create initialises them.
RenderFeatures standard_render_features();

}  // namespace penumbra
