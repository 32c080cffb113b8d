// `penumbra bench rays`: throughput of the AO integrator against raw Embree.
//
// One procedural scene of >= 1M triangles (a displaced terrain and a field of spheres). In the same
// run, over the same receiver points, ray counts, random streams and thread pool, it measures
// (a) a raw loop that generates cosine-weighted rays and calls rtcOccluded16 on a plain Embree
// scene of the same triangles, and (b) penumbra::ambient_occlusion on a RayScene of that World.
// Goal: (b) reaches at least 80% of (a)'s rays per second.
#include <embree3/rtcore.h>

#include <chrono>
#include <cmath>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include <glm/geometric.hpp>
#include <glm/gtc/matrix_transform.hpp>

#include "bench.h"
#include "penumbra/bake/integrators.h"
#include "penumbra/bake/ray_scene.h"
#include "penumbra/core/jobs.h"
#include "penumbra/core/memory.h"
#include "penumbra/core/random.h"
#include "penumbra/core/sampling.h"
#include "penumbra/ecs/transform.h"
#include "penumbra/scene/components.h"
#include "penumbra/scene/mesh.h"

namespace penumbra::bench {
namespace {

constexpr float kTerrainSize = 100.0f;  // metres, centred at the origin
constexpr int kTerrainCells = 512;      // per side: 2 x 512^2 = 524,288 triangles
constexpr int kSpheres = 100;           // icospheres of 5,120 triangles: 512,000 triangles
constexpr float kMaxDistance = 2.0f;    // AO radius, metres
constexpr std::uint32_t kRaysPerPoint = 64;

float terrain_height(float x, float z) {
  return 2.0f * std::sin(0.11f * x) * std::cos(0.09f * z) + 0.4f * std::sin(0.7f * x + 0.3f * z) +
         0.15f * std::cos(2.3f * z - 1.1f * x);
}

glm::vec3 terrain_normal(float x, float z) {
  const float h = 1e-3f;
  const float dx = (terrain_height(x + h, z) - terrain_height(x - h, z)) / (2.0f * h);
  const float dz = (terrain_height(x, z + h) - terrain_height(x, z - h)) / (2.0f * h);
  return glm::normalize(glm::vec3(-dx, 1.0f, -dz));
}

MeshData make_terrain() {
  MeshData mesh;
  mesh.name = "terrain";
  const int n = kTerrainCells;
  for (int j = 0; j <= n; ++j) {
    for (int i = 0; i <= n; ++i) {
      const float x = kTerrainSize * (float(i) / float(n) - 0.5f), z = kTerrainSize * (float(j) / float(n) - 0.5f);
      mesh.positions.push_back({x, terrain_height(x, z), z});
    }
  }
  const auto at = [n](int i, int j) { return static_cast<std::uint32_t>(j * (n + 1) + i); };
  for (int j = 0; j < n; ++j) {
    for (int i = 0; i < n; ++i) {
      // Counter-clockwise seen from above (+Y).
      mesh.indices.insert(mesh.indices.end(), {at(i, j), at(i, j + 1), at(i + 1, j)});
      mesh.indices.insert(mesh.indices.end(), {at(i + 1, j), at(i, j + 1), at(i + 1, j + 1)});
    }
  }
  compute_bounds(mesh);
  return mesh;
}

struct Scene {
  World world;
  std::vector<glm::vec3> positions;  // all triangles in world space, for the raw Embree scene
  std::vector<std::uint32_t> indices;
  std::vector<SurfacePoint> points;  // receivers on the terrain
};

void add_static(Scene& s, std::shared_ptr<const MeshData> mesh, const glm::mat4& m) {
  Entity e = s.world.create();
  s.world.add<Mesh>(e, Mesh{mesh});
  s.world.add<WorldTransform>(e, WorldTransform{m});
  s.world.add<Static>(e);
  const auto base = static_cast<std::uint32_t>(s.positions.size());
  for (glm::vec3 p : mesh->positions) s.positions.push_back(glm::vec3(m * glm::vec4(p, 1.0f)));
  for (std::uint32_t i : mesh->indices) s.indices.push_back(base + i);
}

std::unique_ptr<Scene> make_scene(std::size_t point_count) {
  auto s = std::make_unique<Scene>();
  add_static(*s, std::make_shared<const MeshData>(make_terrain()), glm::mat4(1.0f));
  auto sphere = std::make_shared<const MeshData>(make_icosphere(1.0f, 4));
  Rng rng = Rng::stream(2024, 0);
  for (int k = 0; k < kSpheres; ++k) {
    const float x = (rng.next_float() - 0.5f) * 0.9f * kTerrainSize, z = (rng.next_float() - 0.5f) * 0.9f * kTerrainSize;
    const float r = 0.5f + 1.5f * rng.next_float();
    const glm::mat4 m = glm::scale(glm::translate(glm::mat4(1.0f), {x, terrain_height(x, z) + 0.5f * r, z}), glm::vec3(r));
    add_static(*s, sphere, m);
  }
  // Receivers at terrain vertices (exactly on the triangulated surface), away from the border.
  const auto grid = [&rng] {
    const auto cell = static_cast<int>(rng.next_float() * 0.9f * kTerrainCells) + kTerrainCells / 20;
    return kTerrainSize * (float(cell) / float(kTerrainCells) - 0.5f);
  };
  for (std::size_t i = 0; i < point_count; ++i) {
    const float x = grid(), z = grid();
    s->points.push_back({{x, terrain_height(x, z), z}, terrain_normal(x, z)});
  }
  return s;
}

// A plain Embree scene of the same triangles: the "raw" side of the comparison.
struct RawEmbree {
  RTCDevice device = nullptr;
  RTCScene scene = nullptr;
  RawEmbree(const Scene& s, unsigned threads) {
    const std::string config = threads > 0 ? "threads=" + std::to_string(threads) : "";
    device = rtcNewDevice(config.c_str());
    scene = rtcNewScene(device);
    RTCGeometry g = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_TRIANGLE);
    auto* v = static_cast<float*>(rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3,
                                                          3 * sizeof(float), s.positions.size() + 1));
    auto* ix = static_cast<unsigned*>(rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3,
                                                              3 * sizeof(unsigned), s.indices.size() / 3));
    for (std::size_t i = 0; i < s.positions.size(); ++i) {
      v[3 * i] = s.positions[i].x; v[3 * i + 1] = s.positions[i].y; v[3 * i + 2] = s.positions[i].z;
    }
    for (std::size_t i = 0; i < s.indices.size(); ++i) ix[i] = s.indices[i];
    rtcCommitGeometry(g);
    rtcAttachGeometry(scene, g);
    rtcReleaseGeometry(g);
    rtcSetSceneBuildQuality(scene, RTC_BUILD_QUALITY_MEDIUM);
    rtcCommitScene(scene);
  }
  ~RawEmbree() {
    rtcReleaseScene(scene);
    rtcReleaseDevice(device);
  }
  RawEmbree(const RawEmbree&) = delete;
  RawEmbree& operator=(const RawEmbree&) = delete;

  // The same rays as ambient_occlusion(): stream i, origin offset 2e-5 |x|max + 1e-5 along n,
  // cosine-weighted directions; 16 at a time straight into rtcOccluded16. Returns unoccluded rays.
  std::uint32_t trace_point(const SurfacePoint& p, std::uint64_t seed, std::size_t i) const {
    Rng rng = Rng::stream(seed, i);
    glm::vec3 t, b;
    orthonormal_basis(p.normal, t, b);
    const float m = std::max({std::fabs(p.position.x), std::fabs(p.position.y), std::fabs(p.position.z)});
    const glm::vec3 o = p.position + (2e-5f * m + 1e-5f) * p.normal;
    RTCIntersectContext context;
    rtcInitIntersectContext(&context);
    std::uint32_t open = 0;
    for (std::uint32_t first = 0; first < kRaysPerPoint; first += 16) {
      alignas(64) RTCRay16 packet;
      alignas(64) int valid[16];
      for (int k = 0; k < 16; ++k) {
        const float u0 = rng.next_float(), u1 = rng.next_float();
        const glm::vec3 d = cosine_hemisphere({u0, u1});
        const glm::vec3 w = d.x * t + d.y * b + d.z * p.normal;
        valid[k] = -1;
        packet.org_x[k] = o.x; packet.org_y[k] = o.y; packet.org_z[k] = o.z;
        packet.dir_x[k] = w.x; packet.dir_y[k] = w.y; packet.dir_z[k] = w.z;
        packet.tnear[k] = 0.0f;
        packet.tfar[k] = kMaxDistance;
        packet.time[k] = 0.0f;
        packet.mask[k] = 0xFFFFFFFFu;
        packet.id[k] = static_cast<unsigned>(k);
        packet.flags[k] = 0;
      }
      rtcOccluded16(valid, scene, &context, &packet);
      for (int k = 0; k < 16; ++k) open += packet.tfar[k] >= 0.0f ? 1u : 0u;
    }
    return open;
  }
};

Result<Report> run_rays_bench(const Options& options) {
  const std::size_t point_count = options.quick ? 4096 : 32768;
  const double min_time = options.quick ? 0.1 : 0.5;
  ThreadPool pool(options.threads);
  const unsigned threads = pool.concurrency();

  const auto t0 = std::chrono::steady_clock::now();
  const std::unique_ptr<Scene> s = make_scene(point_count);
  const auto t1 = std::chrono::steady_clock::now();
  auto scene = RayScene::build(s->world, RaySceneOptions{.build_threads = threads});
  if (!scene) return scene.error();
  const auto t2 = std::chrono::steady_clock::now();
  RawEmbree raw(*s, threads);
  const auto t3 = std::chrono::steady_clock::now();
  const std::size_t triangles = scene->triangle_count();
  const auto ms = [](auto a, auto b) { return std::chrono::duration<double, std::milli>(b - a).count(); };

  const double rays_per_iteration = double(point_count) * kRaysPerPoint;
  std::vector<AoEstimate> out(point_count);
  std::vector<std::uint32_t> raw_open(point_count);
  Status failure;
  const std::vector<Case> cases = {
      {"raw_rtcOccluded16",
       [&](benchmark::State& state) {
         JobContext jobs(&pool);
         for (auto _ : state) {
           Status st = jobs.parallel_for(point_count, 16, [&](std::size_t begin, std::size_t end) {
             for (std::size_t i = begin; i < end; ++i) raw_open[i] = raw.trace_point(s->points[i], 7, i);
           });
           if (!st.ok()) failure = st;
         }
         state.SetItemsProcessed(static_cast<std::int64_t>(state.iterations()) *
                                 static_cast<std::int64_t>(rays_per_iteration));
       }},
      {"ao_integrator",
       [&](benchmark::State& state) {
         JobContext jobs(&pool);
         // Independent rays, the raw loop's: both sides trace the same rays.
         const AoSettings settings{kMaxDistance, kRaysPerPoint, 7, AoSampling::Independent};
         for (auto _ : state) {
           Status st = ambient_occlusion(*scene, s->points, settings, out, jobs);
           if (!st.ok()) failure = st;
         }
         state.SetItemsProcessed(static_cast<std::int64_t>(state.iterations()) *
                                 static_cast<std::int64_t>(rays_per_iteration));
       }},
  };
  const std::vector<Measurement> measured = run_cases(cases, min_time, options.quick ? 1 : 3);
  if (!failure.ok()) return failure.error();
  for (const Measurement& m : measured) {
    if (m.items_per_second <= 0.0) {
      return make_error(ErrorCode::Internal, "bench rays: case " + m.name +
                                                 " produced no measurement; rerun, and report it if it persists");
    }
  }
  const double raw_rate = measured[0].items_per_second, ao_rate = measured[1].items_per_second;
  const double ratio = ao_rate / raw_rate;

  // Both sides traced the same rays: their AO must agree (up to the two BVHs' rounding).
  double raw_mean = 0.0, ao_mean = 0.0;
  for (std::size_t i = 0; i < point_count; ++i) {
    raw_mean += double(raw_open[i]) / kRaysPerPoint;
    ao_mean += out[i].value;
  }
  raw_mean /= double(point_count);
  ao_mean /= double(point_count);

  Report report;
  report.columns = {"case", "triangles", "threads", "mrays_per_s", "ratio_to_raw"};
  report.rows.push_back({"raw_rtcOccluded16", std::to_string(triangles), std::to_string(threads),
                         fmt(raw_rate * 1e-6), "1"});
  report.rows.push_back({"ao_integrator", std::to_string(triangles), std::to_string(threads),
                         fmt(ao_rate * 1e-6), fmt(ratio, 3)});
  report.notes.push_back("AO integrator: " + fmt(100.0 * ratio, 3) + "% of raw rtcOccluded16 (goal >= 80%): " +
                         (ratio >= 0.8 ? "PASS" : "FAIL"));
  report.notes.push_back(std::to_string(point_count) + " points x " + std::to_string(kRaysPerPoint) +
                         " cosine rays, max distance " + fmt(kMaxDistance) + " m; mean AO raw " + fmt(raw_mean, 5) +
                         ", integrator " + fmt(ao_mean, 5));
  report.notes.push_back("scene " + fmt(ms(t0, t1), 3) + " ms to generate; RayScene build " + fmt(ms(t1, t2), 3) +
                         " ms (" + format_bytes(scene->bvh_bytes()) + " held by Embree), raw Embree build " +
                         fmt(ms(t2, t3), 3) + " ms");
  report.plot.title = "AO rays per second, " + std::to_string(triangles) + " triangles";
  report.plot.x_label = "threads";
  report.plot.y_label = "Mrays/s";
  report.plot.x_column = 2;
  report.plot.y_column = 3;
  report.plot.series_column = 0;
  return report;
}

// `penumbra bench ao-noise`: the AO integrator's noise against its ray count, Sobol' (the
// default) against independent rays, on receivers of the same scene. Reference per point: 4096
// independent rays (its own standard error is reported and subtracted from the mean square). Goal:
// Sobol' reaches the noise of independent rays at 256 per point with at most half of them.
Result<Report> run_ao_noise_bench(const Options& options) {
  const std::size_t point_count = options.quick ? 1024 : 8192;
  constexpr std::uint32_t kReferenceRays = 4096;
  ThreadPool pool(options.threads);
  const std::unique_ptr<Scene> s = make_scene(point_count);
  auto scene = RayScene::build(s->world, RaySceneOptions{.build_threads = pool.concurrency()});
  if (!scene) return scene.error();
  JobContext jobs(&pool);
  std::vector<AoEstimate> reference(point_count), out(point_count);
  PENUMBRA_TRY(ambient_occlusion(*scene, s->points, AoSettings{kMaxDistance, kReferenceRays, 99, AoSampling::Independent},
                                 reference, jobs));
  double reference_var = 0.0;  // the reference's own mean squared standard error
  for (const AoEstimate& r : reference) reference_var += double(r.std_error) * r.std_error / double(point_count);

  Report report;
  report.columns = {"sampling", "rays", "rms_error", "mean_error_bar", "ms"};
  // RMS error per (sampling, rays), the reference's variance removed.
  std::map<std::pair<int, std::uint32_t>, double> rms;
  const std::vector<std::uint32_t> counts = {16, 32, 64, 128, 256};
  for (const AoSampling sampling : {AoSampling::Independent, AoSampling::Sobol}) {
    for (const std::uint32_t rays : counts) {
      const auto t0 = std::chrono::steady_clock::now();
      PENUMBRA_TRY(ambient_occlusion(*scene, s->points, AoSettings{kMaxDistance, rays, 7, sampling}, out, jobs));
      const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
      double ms_error = 0.0, ms_bar = 0.0;
      for (std::size_t i = 0; i < point_count; ++i) {
        const double e = double(out[i].value) - double(reference[i].value);
        ms_error += e * e / double(point_count);
        ms_bar += double(out[i].std_error) * out[i].std_error / double(point_count);
      }
      const double r = std::sqrt(std::max(ms_error - reference_var, 0.0));
      rms[{static_cast<int>(sampling), rays}] = r;
      report.rows.push_back({sampling == AoSampling::Sobol ? "sobol" : "independent", std::to_string(rays), fmt(r, 4),
                             fmt(std::sqrt(ms_bar), 4), fmt(ms, 3)});
    }
  }
  // Rays Sobol' needs for the noise of 256 independent rays: log-log interpolation between counts.
  const double target = rms[{static_cast<int>(AoSampling::Independent), 256}];
  double needed = 0.0;
  for (std::size_t k = 0; k + 1 < counts.size() && needed == 0.0; ++k) {
    const double a = rms[{static_cast<int>(AoSampling::Sobol), counts[k]}];
    const double b = rms[{static_cast<int>(AoSampling::Sobol), counts[k + 1]}];
    if (k == 0 && a <= target) needed = counts[0];
    else if (a > target && b <= target)
      needed = counts[k] * std::pow(double(counts[k + 1]) / counts[k], std::log(a / target) / std::log(a / b));
  }
  const double ratio = needed > 0.0 ? needed / 256.0 : 0.0;
  report.notes.push_back("reference: " + std::to_string(kReferenceRays) + " independent rays per point, RMS standard error " +
                         fmt(std::sqrt(reference_var), 4) + " (removed from the errors above); " +
                         std::to_string(point_count) + " receivers, max distance " + fmt(kMaxDistance) + " m");
  report.notes.push_back("goal: Sobol' reaches the noise of 256 independent rays (" + fmt(target, 4) + ") with at most " +
                         "half the rays: " + (needed > 0.0 ? fmt(needed, 3) + " rays, " + fmt(ratio, 3) + "x" :
                                                             std::string("not within 256 rays")) +
                         ": " + (needed > 0.0 && ratio <= 0.5 ? "PASS" : "FAIL"));
  report.plot.title = "AO noise against rays per point";
  report.plot.x_label = "rays per point";
  report.plot.y_label = "RMS error";
  report.plot.x_column = 1;
  report.plot.y_column = 2;
  report.plot.series_column = 0;
  report.plot.log_x = true;
  report.plot.log_y = true;
  return report;
}

}  // namespace
}  // namespace penumbra::bench

PENUMBRA_BENCH("ao-noise", "AO integrator noise against rays per point: Sobol' against independent rays",
               penumbra::bench::run_ao_noise_bench);
PENUMBRA_BENCH("rays", "AO integrator rays/s on a 1M-triangle scene against raw rtcOccluded16",
               penumbra::bench::run_rays_bench);
