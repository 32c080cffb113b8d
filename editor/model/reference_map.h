// The lit view against the offline reference of the same frame, as an error heat map
// (error_map.h): the reference (offline/offline_renderer.h, mode Reference: converged, with each
// pixel's standard error) renders on a worker thread from a snapshot of the World taken at start
// (the geometry as posed now, the lights, the surface textures); each cell of a coarse grid over
// the view compares the mean luminance of the real-time image's pixels in it with the reference's.
// Unlike the probe grid's map (probe_grid_views.h) it judges the whole real-time path: rect lights'
// shadows from their centre, the grid's resolution, the ambient image at half resolution, the
// composition of the techniques.
#pragma once

#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include <glm/vec3.hpp>

#include "background_job.h"
#include "error_map.h"
#include "penumbra/ecs/world.h"
#include "penumbra/offline/offline_renderer.h"
#include "penumbra/render/renderer.h"

namespace penumbra::editor {

struct ReferenceMapRequest {
  CameraView camera;
  std::uint32_t columns = 48, rows = 27;  // cells over the view
  std::uint32_t cell_pixels = 4;          // pixels per cell side, in both images
  std::uint32_t spp = 64;                 // the reference's paths per pixel: its noise falls as 1 / sqrt(spp)
  std::uint64_t seed = 1;
  unsigned threads = 0;                   // 0: one per hardware thread
  std::uint32_t width() const { return columns * cell_pixels; }
  std::uint32_t height() const { return rows * cell_pixels; }
};

// The map of `tested` (linear radiance, row-major from the top-left: the real-time lit view read
// back as float) against `reference` (the offline reference of the same camera), both
// request.width() x height(). A cell compares the pixels the reference covers; one whose reference
// luminance is 0 has no value. InvalidArgument when a size does not match, the reference has no
// standard error or no cell has a value. O(pixels).
Result<ErrorMap> compare_with_reference(std::span<const glm::vec3> tested, const OfflineImage& reference,
                                        const ReferenceMapRequest& request);

// One line for the status bar and scripts: the error with the reference's noise taken out and the
// luminance ratio (the bias), or that the error is within the noise; the cells and the time.
std::string describe_reference_map(const ErrorMap& map);

// The reference on a worker thread, then compare_with_reference (running, take and cancel as
// BackgroundJob's).
class ReferenceMapJob : public BackgroundJob<ErrorMap> {
 public:
  // Snapshots the World (a RayScene of everything as posed now, its lights, its textures) and
  // starts the reference. `tested`: the real-time lit view of request.camera at the request's
  // size. InvalidArgument when one is running, a size does not match or spp < 2. Cost of the
  // reference: about width x height x spp paths.
  Status start(World& world, std::vector<glm::vec3> tested, const ReferenceMapRequest& request);
};

}  // namespace penumbra::editor
