// The indirect-transport render feature (render/feature.h): a source. The first baked
// IndirectTransport's patches, its bounce probes and its IndirectLightmap go to storage buffers; a
// full-screen pass adds the DynamicLights' bounce light to the ambient image, on top of the probe
// grid's (which leaves DynamicLights out): the lightmap's indirect irradiance
// on the surfaces the patches cover (sample_indirect_irradiance's lookup, in GLSL), the bounce
// probes' elsewhere (sample_bounce_probes': moving objects, characters, other static meshes). Each
// sync writes only the texels whose value changed since the last, and the probes (six values each)
// when the lightmap was updated. Views: "lightmap" (the bounce light as the pass adds it, in W/m^2,
// exposed and tone mapped), "patches" (each patch in its own colour over its texel grid: the patch
// hierarchy's leaves) and "bounce-probes" (the probes' irradiance on every surface). Counters:
// "indirect-transport.patches", "indirect-transport.texels_uploaded" (by the last sync).
#pragma once

#include <memory>

#include "penumbra/render/feature.h"

namespace penumbra {

std::unique_ptr<RenderFeature> make_indirect_transport_render_feature();

}  // namespace penumbra
