// The lit view against the offline reference (reference_map.h).
#include "reference_map.h"

#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <memory>

#include "penumbra/bake/integrators.h"
#include "penumbra/bake/ray_scene.h"
#include "penumbra/core/colour.h"
#include "penumbra/offline/surface_textures.h"

namespace penumbra::editor {
namespace {

// What the reference reads, detached from the World.
struct Snapshot {
  RayScene rays;
  std::vector<WorldLight> lights;
  SurfaceTextures textures;
};

}  // namespace

Result<ErrorMap> compare_with_reference(std::span<const glm::vec3> tested, const OfflineImage& reference,
                                        const ReferenceMapRequest& request) {
  const std::size_t w = request.width(), h = request.height(), pixels = w * h;
  if (w == 0 || h == 0 || tested.size() != pixels || reference.width != w || reference.height != h ||
      reference.lit.size() != pixels || reference.covered.size() != pixels)
    return make_error(ErrorCode::InvalidArgument, "reference map: the images are not both " + std::to_string(w) +
                                                      " x " + std::to_string(h));
  if (reference.lit_std_error.size() != pixels)
    return make_error(ErrorCode::InvalidArgument, "reference map: the reference has no standard error; render it "
                                                  "in mode reference");
  ErrorMap map;
  map.columns = request.columns;
  map.rows = request.rows;
  const std::size_t cells = std::size_t{map.columns} * map.rows;
  map.relative_error.assign(cells, std::numeric_limits<float>::quiet_NaN());
  map.relative_noise.assign(cells, std::numeric_limits<float>::quiet_NaN());
  double tested_sum = 0.0, reference_sum = 0.0;
  const std::size_t k = request.cell_pixels;
  for (std::size_t cell = 0; cell < cells; ++cell) {
    const std::size_t cx = cell % map.columns, cy = cell / map.columns;
    double t = 0.0, r = 0.0, variance = 0.0;
    std::size_t n = 0;
    for (std::size_t y = cy * k; y < (cy + 1) * k; ++y)
      for (std::size_t x = cx * k; x < (cx + 1) * k; ++x) {
        const std::size_t i = y * w + x;
        if (!reference.covered[i]) continue;
        t += luminance(tested[i]);
        r += luminance(reference.lit[i]);
        const double s = luminance(reference.lit_std_error[i]);
        variance += s * s;
        ++n;
      }
    if (n == 0 || !(r > 0.0) || !std::isfinite(t)) continue;
    // Means over the cell's covered pixels; the reference mean's standard error is sqrt(sum s^2) / n.
    map.relative_error[cell] = static_cast<float>(std::abs(t - r) / r);
    map.relative_noise[cell] = static_cast<float>(std::sqrt(variance) / r);
    tested_sum += t;
    reference_sum += r;
  }
  summarise_error_map(map, tested_sum, reference_sum);
  if (map.cells == 0)
    return make_error(ErrorCode::InvalidArgument, "reference map: no cell of the view sees a lit surface; point the "
                                                  "camera at the scene (or give it light)");
  return map;
}

std::string describe_reference_map(const ErrorMap& m) {
  char line[320];
  if (m.above_noise())
    std::snprintf(line, sizeof line,
                  "lit view against the offline reference: %.1f%% off per cell (mean |E_rt - E_ref| / E_ref %.1f%%, "
                  "the reference's noise %.1f%% taken out), luminance %.3fx the reference's, %u cells, %.1f s",
                  100.0 * m.noise_corrected_rms, 100.0 * m.mean, 100.0 * m.reference_noise, m.ratio, m.cells, m.seconds);
  else
    std::snprintf(line, sizeof line,
                  "lit view against the offline reference: within the reference's noise (%.1f%%; mean |E_rt - E_ref| "
                  "/ E_ref %.1f%%), luminance %.3fx the reference's, %u cells, %.1f s: raise its paths to see more",
                  100.0 * m.reference_noise, 100.0 * m.mean, m.ratio, m.cells, m.seconds);
  return line;
}

Status ReferenceMapJob::start(World& world, std::vector<glm::vec3> tested, const ReferenceMapRequest& request) {
  if (running()) return make_error(ErrorCode::InvalidArgument, "reference map: one is being computed; wait for it");
  if (tested.size() != std::size_t{request.width()} * request.height() || tested.empty())
    return make_error(ErrorCode::InvalidArgument, "reference map: the real-time image is not " +
                                                      std::to_string(request.width()) + " x " +
                                                      std::to_string(request.height()));
  if (request.spp < 2)
    return make_error(ErrorCode::InvalidArgument, "reference map: the reference needs at least 2 paths per pixel");
  RaySceneOptions options;
  options.include_dynamic = true;  // the frame as posed now, as the real-time image shows it
  auto rays = RayScene::build(world, options);
  if (!rays) return rays.error();
  auto snapshot = std::make_shared<Snapshot>(Snapshot{std::move(*rays), gather_lights(world), SurfaceTextures::gather(world)});
  auto image = std::make_shared<const std::vector<glm::vec3>>(std::move(tested));
  return BackgroundJob::start("reference map", request.threads, [snapshot, image, request](JobContext& jobs) -> Result<ErrorMap> {
    const auto start = std::chrono::steady_clock::now();
    OfflineSettings settings;
    settings.mode = OfflineMode::Reference;
    settings.width = request.width();
    settings.height = request.height();
    settings.spp = request.spp;
    settings.seed = request.seed;
    auto reference = render_offline(snapshot->rays, snapshot->lights, request.camera, settings, jobs, &snapshot->textures);
    if (!reference) return make_error(reference.error().code, "reference map: " + reference.error().message);
    auto map = compare_with_reference(*image, *reference, request);
    if (map) map->seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    return map;
  });
}

}  // namespace penumbra::editor
