// The indirect-transport render feature (render/feature.h): a source. The first baked
// IndirectTransport's patches and its IndirectLightmap go to two storage buffers; a full-screen
// pass adds the lightmap's indirect irradiance (sample_indirect_irradiance's lookup, in GLSL) to
// the ambient image of the surfaces the patches cover, which therefore get the moving lights'
// bounce light on top of the probe grid's fixed lights (the probe grid leaves DynamicLights out).
// Each sync writes only the texels whose value changed since the last. Views: "lightmap" (E_ind in
// W/m^2, exposed and tone mapped) and "patches" (each patch in its own colour over its texel grid:
// the patch hierarchy's leaves). Counters: "indirect-transport.patches",
// "indirect-transport.texels_uploaded" (by the last sync).
#pragma once

#include <memory>

#include "penumbra/render/feature.h"

namespace penumbra {

std::unique_ptr<RenderFeature> make_indirect_transport_render_feature();

}  // namespace penumbra
