// The error heat map of the probe grid against the reference, on demand: for a coarse grid of
// cells over the view, the surface seen through each cell centre gets the probe grid's irradiance
// E_probe(x, n) (the highest-priority baked grid covering x, as the renderer picks it) and the
// brute-force reference E_ref(x, n) (path-traced, all bounces; bake/integrators.h), and the cell
// shows |E_probe - E_ref| / E_ref in luminance. It runs on a worker thread like a bake.
#pragma once

#include <atomic>
#include <cstdint>
#include <memory>
#include <mutex>
#include <optional>
#include <thread>
#include <vector>

#include "penumbra/bake/integrators.h"
#include "penumbra/core/jobs.h"
#include "penumbra/ecs/world.h"
#include "penumbra/render/renderer.h"

namespace penumbra::editor {

struct ErrorMapRequest {
  CameraView camera;
  std::uint32_t columns = 64, rows = 36;  // cells over the view
  IrradianceSettings reference;           // reference = true and content = the grid's lighting are forced
  unsigned threads = 0;                   // 0: one per hardware thread
};

struct ErrorMap {
  std::uint32_t columns = 0, rows = 0;
  // Row-major, row 0 at the top; NaN where the cell sees no surface or no baked grid covers it.
  std::vector<float> relative_error;
  std::vector<float> relative_noise;  // per cell: the reference's relative standard error there
  std::uint32_t cells = 0;        // cells with a value
  float mean = 0.0f;              // mean relative error over those cells
  float reference_noise = 0.0f;   // mean relative standard error of the reference (what "exact" means here)
  // The error with the reference's noise taken out: sqrt(max(0, mean(e^2) - mean(sigma^2))), e
  // each cell's relative error and sigma its relative standard error (the noise adds its variance
  // to e^2 on average).
  float noise_corrected_rms = 0.0f;
  double seconds = 0.0;
  // Whether the map shows the grid's error rather than the reference's noise: the mean error is
  // more than twice the mean noise (a noise-only map's mean |e| is about 0.8 of it). Otherwise
  // only an upper bound is known; more reference paths lower the noise as 1 / sqrt(paths).
  bool above_noise() const { return mean > 2.0f * reference_noise; }
  // Whether cell i's error exceeds twice its own noise (false for a cell without a value).
  bool cell_above_noise(std::size_t i) const { return relative_error[i] > 2.0f * relative_noise[i]; }
};

// Computes the map synchronously. InvalidArgument when no grid has baked data; Cancelled when the
// host cancels. Cell i draws from Rng::stream(reference.seed, i): the same map at any thread count.
// Cost: columns x rows x reference.samples paths.
Result<ErrorMap> compute_error_map(World& world, const ErrorMapRequest& request, JobContext& jobs);

// compute_error_map on a worker thread over what it needs from the World (a RayScene of the
// static geometry, the lights, the grids' data), so the World stays free for the main thread.
class ErrorMapJob {
 public:
  ErrorMapJob() = default;
  ~ErrorMapJob();
  ErrorMapJob(const ErrorMapJob&) = delete;
  ErrorMapJob& operator=(const ErrorMapJob&) = delete;

  // Errors as compute_error_map's, or InvalidArgument when one is running.
  Status start(World& world, const ErrorMapRequest& request);
  bool running() const;
  // The finished map (or its error) once, then nullopt.
  std::optional<Result<ErrorMap>> take();
  void cancel() {
    if (cancel_) cancel_->cancel();
  }

 private:
  std::thread worker_;
  std::unique_ptr<CancelToken> cancel_;
  std::atomic<bool> done_{false};
  mutable std::mutex mutex_;
  std::optional<Result<ErrorMap>> result_;
};

}  // namespace penumbra::editor
