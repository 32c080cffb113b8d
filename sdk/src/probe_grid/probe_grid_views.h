// The error heat map of the probe grid against the reference, on demand: for a coarse grid of
// cells over the view, the surface seen through each cell centre gets the probe grid's irradiance
// E_probe(x, n) (the highest-priority baked grid covering x, as the renderer picks it) and the
// brute-force reference E_ref(x, n) (path-traced, all bounces; bake/integrators.h), and the cell
// shows |E_probe - E_ref| / E_ref in luminance. It runs on a worker thread like a bake.
#pragma once

#include <cstdint>

#include "penumbra/bake/integrators.h"
#include "penumbra/core/jobs.h"
#include "penumbra/ecs/world.h"
#include "penumbra/render/renderer.h"
#include "background_job.h"
#include "error_map.h"

namespace penumbra::editor {

struct ErrorMapRequest {
  CameraView camera;
  std::uint32_t columns = 64, rows = 36;  // cells over the view
  IrradianceSettings reference;           // reference = true and content = the grid's lighting are forced
  unsigned threads = 0;                   // 0: one per hardware thread
};

// Computes the map synchronously. InvalidArgument when no grid has baked data; Cancelled when the
// host cancels. Cell i draws from Rng::stream(reference.seed, i): the same map at any thread count.
// Cost: columns x rows x reference.samples paths.
Result<ErrorMap> compute_error_map(World& world, const ErrorMapRequest& request, JobContext& jobs);

// compute_error_map on a worker thread over what it needs from the World (a RayScene of the
// static geometry, the lights, the grids' data), so the World stays free for the main thread
// (running, take and cancel as BackgroundJob's).
class ErrorMapJob : public BackgroundJob<ErrorMap> {
 public:
  // Errors as compute_error_map's, or InvalidArgument when one is running.
  Status start(World& world, const ErrorMapRequest& request);
};

}  // namespace penumbra::editor
