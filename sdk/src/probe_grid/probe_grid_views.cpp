// The probe grid's error heat map against the reference (probe_grid_views.h).
#include "probe_grid_views.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>

#include <glm/gtc/matrix_inverse.hpp>

#include "penumbra/bake/ray_scene.h"
#include "penumbra/core/colour.h"
#include "penumbra/core/random.h"
#include "penumbra/ecs/transform.h"
#include "penumbra/probe_grid/probe_grid.h"

namespace penumbra::editor {

namespace {

struct GridRef {
  std::shared_ptr<const ProbeGridData> data;
  int priority = 0;
};

// What the computation reads, detached from the World.
struct Scene {
  RayScene rays;
  std::vector<WorldLight> lights;
  std::vector<GridRef> grids;  // by descending priority, then entity index
};

Result<Scene> gather(World& world) {
  std::vector<GridRef> grids;
  for (Entity e : world.view<IrradianceProbeGrid>().sorted_entities()) {
    const IrradianceProbeGrid& g = world.get<IrradianceProbeGrid>(e);
    if (g.data) grids.push_back({g.data, g.priority});
  }
  if (grids.empty())
    return make_error(ErrorCode::InvalidArgument, "error map: no probe grid is baked yet; bake the probe grid first");
  std::stable_sort(grids.begin(), grids.end(), [](const GridRef& a, const GridRef& b) { return a.priority > b.priority; });
  RaySceneOptions options;
  options.include_dynamic = false;  // the bake's view of the scene
  auto rays = RayScene::build(world, options);
  if (!rays) return rays.error();
  return Scene{std::move(*rays), baked_lights(world), std::move(grids)};
}

Result<ErrorMap> compute(const Scene& scene, const ErrorMapRequest& request, JobContext& jobs) {
  const auto start = std::chrono::steady_clock::now();
  ErrorMap map;
  map.columns = std::max(request.columns, 1u);
  map.rows = std::max(request.rows, 1u);
  const std::size_t cells = std::size_t{map.columns} * map.rows;
  map.relative_error.assign(cells, std::numeric_limits<float>::quiet_NaN());
  map.relative_noise.assign(cells, std::numeric_limits<float>::quiet_NaN());
  std::vector<float>& noise = map.relative_noise;
  std::vector<float> tested(cells, 0.0f), reference(cells, 0.0f);  // luminances of the cells with a value
  IrradianceSettings settings = request.reference;
  settings.reference = true;
  settings.samples = std::max(settings.samples, 2u);
  const glm::mat4 clip_to_world = glm::inverse(request.camera.projection * request.camera.view);
  jobs.set_stage_count(1);
  jobs.begin_stage("error map", cells);
  Status s = jobs.parallel_for(cells, 16, [&](std::size_t begin, std::size_t end) {
    for (std::size_t i = begin; i < end; ++i) {
      // The primary ray through the cell centre (Vulkan clip space: y down, depth 0..1).
      const float u = (static_cast<float>(i % map.columns) + 0.5f) / static_cast<float>(map.columns);
      const float v = (static_cast<float>(i / map.columns) + 0.5f) / static_cast<float>(map.rows);
      const glm::vec4 far = clip_to_world * glm::vec4(2.0f * u - 1.0f, 2.0f * v - 1.0f, 1.0f, 1.0f);
      Ray ray;
      ray.origin = request.camera.position;
      ray.direction = glm::vec3(far) / far.w - ray.origin;
      Hit hit;
      if (!scene.rays.intersect(ray, hit) || hit.back_face) continue;
      const glm::vec3 x = ray.origin + hit.t * ray.direction;
      const glm::vec3 n = hit.normal;
      // The grid the renderer would use at x.
      const ProbeGridData* grid = nullptr;
      for (const GridRef& g : scene.grids) {
        const glm::vec3 p(g.data->layout.world_to_grid * glm::vec4(x, 1.0f));
        if (glm::all(glm::greaterThanEqual(p, glm::vec3(0.0f))) && glm::all(glm::lessThanEqual(p, glm::vec3(1.0f)))) {
          grid = g.data.get();
          break;
        }
      }
      if (grid == nullptr) continue;
      // The reference of what the grid stores (all light, or the indirect part).
      IrradianceSettings matching = settings;
      matching.content = grid->lighting;
      Rng rng = Rng::stream(settings.seed, i);
      const Estimate ref = irradiance(scene.rays, scene.lights, x, n, matching, rng);
      const float e_ref = luminance(ref.value);
      if (!(e_ref > 1e-6f)) continue;  // unlit: a relative error means nothing there
      const float e_probe = luminance(evaluate(*grid, x, n, ProbeReceiver::Static));  // the bake's static geometry
      map.relative_error[i] = std::abs(e_probe - e_ref) / e_ref;
      noise[i] = luminance(ref.std_error) / e_ref;
      tested[i] = e_probe;
      reference[i] = e_ref;
    }
  });
  if (!s) return s.error();
  double tested_sum = 0.0, reference_sum = 0.0;  // in cell order: the same at any thread count
  for (std::size_t i = 0; i < cells; ++i) {
    tested_sum += tested[i];
    reference_sum += reference[i];
  }
  summarise_error_map(map, tested_sum, reference_sum);
  map.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return map;
}

}  // namespace

Result<ErrorMap> compute_error_map(World& world, const ErrorMapRequest& request, JobContext& jobs) {
  auto scene = gather(world);
  if (!scene) return scene.error();
  return compute(*scene, request, jobs);
}

Status ErrorMapJob::start(World& world, const ErrorMapRequest& request) {
  if (running()) return make_error(ErrorCode::InvalidArgument, "error map: one is being computed; wait for it");
  auto scene = gather(world);
  if (!scene) return scene.error();
  auto shared = std::make_shared<Scene>(std::move(*scene));
  return BackgroundJob::start("error map", request.threads,
                              [shared, request](JobContext& jobs) { return compute(*shared, request, jobs); });
}

}  // namespace penumbra::editor
