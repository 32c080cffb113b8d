// The probe-grid render feature (render/feature.h): a source. The baked IrradianceProbeGrids
// (at most PENUMBRA_PROBE_MAX_GRIDS = 4, the highest priorities; more are logged once and left
// out) are packed into one atlas of 3D textures, and a full-screen pass adds their irradiance,
// evaluated with the leak guard's lookup and blended as probe_grid_weights()
// (probe_grid_system.h) does on the CPU, to the ambient image. Views: "validity" (the blended
// validity, red 0 to green 1; blue without a grid) and "irradiance" (E(x, n) in W/m^2, exposed
// and tone mapped). A grid baked with lighting = all holds direct light too, which the renderer
// then counts twice (logged once per grid). Counters: "probe-grid.grids" (in the pass),
// "probe-grid.bytes_uploaded" (by the last sync).
#pragma once

#include <memory>

#include "penumbra/render/feature.h"

namespace penumbra {

std::unique_ptr<RenderFeature> make_probe_grid_render_feature();

}  // namespace penumbra
