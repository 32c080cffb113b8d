// `penumbra bench probe-grid`: the irradiance probe grid's error against the brute-force reference,
// point sampling against the supersampling of Kontkanen & Laine 2006 and against the least-squares
// fit of the same samples (fitted mode), over spacings, samples per node and SH orders, on
// builtin:courtyard and builtin:cornell.
//
// Receivers: random points of the grid's box in the domain of interest (at most 10% of 64 rays
// from the point hit back faces) with random normals; reference E(x, n) = irradiance() in
// reference mode (all bounces). Leak receivers: courtyard points within one spacing of the thin
// wall, on either side; on the Cornell box, points within one spacing of the bounds of its two
// closed blocks (outside them: the paper's case, nodes inside solid geometry), in the same column.
// Face receivers (Cornell): points on the blocks' side faces, static geometry, found by rays from
// the leak receivers' shell towards a block, with the faces' normals; the guarded indirect grids
// are evaluated there as a moving receiver and as a static one (ProbeReceiver, probe_grid.h), whose
// lookup also drops the nodes in the solid under the face.
// Noise target: the fitted+guard indirect grids baked again with the medium and high presets'
// noise targets (IrradianceProbeGrid::noise, 2 % and 1 %), their error and bake time beside the
// grid without one.
// Errors are relative to the mean reference irradiance. An L1 row reuses the
// L2 bake truncated to its first four coefficients (same bake time; only the stored bytes differ).
// Goals: at the same spacing, leak RMSE <= 0.5 x point with bake time <= 1.5 x point; the
// notes give supersampled/point and fitted/point, and fitted/supersampled overall RMSE (goal <= 1).
// Every mode is baked without and with the leak guard (probe_grid.h; rows "MODE+guard"). The
// notes compare modes at the same runtime (plain: the paper's comparison; guarded: ours) and the
// guarded modes against plain point sampling, the classic irradiance volume a studio has today.
// Those rows bake lighting = all (the whole irradiance). The rows with lighting =
// indirect bake grids of the light that reflected at least once, at every spacing and the
// largest sample count, against the indirect reference at the same receivers (integrators.h); their
// errors are relative to the mean total irradiance, so they read as the error of a renderer that
// draws direct light exactly and adds the grid (the SDK renderer's sum), beside the all rows.
//
// Grid placement: the courtyard's wall (z = -2) lies exactly on a node plane of the default box at
// both spacings, one placement among many. The leak study bakes the three modes again with the
// box translated by kPlacements sub-cell offsets (stratified in z, the wall's normal; spread in x;
// y keeps the box's floor 5 cm above the ground) and reports the ratios for the aligned box and
// pooled over the offsets (RMS of the per-placement leak RMSEs, summed bake times). Next to them,
// the one-dimensional model of the leak: a unit step at offset a (cells) from a node, receivers
// uniform within one cell of it, reconstructed by hats. Point sampling (exact node values, 0 for a
// node inside the wall), the tent averages, and the best node values for the leak window itself
// (least squares over it: no choice of node values does better with a trilinear runtime).

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <map>
#include <string>
#include <tuple>
#include <vector>

#include <glm/geometric.hpp>

#include "bench.h"
#include "penumbra/bake/integrators.h"
#include "penumbra/bake/ray_scene.h"
#include "penumbra/core/jobs.h"
#include "penumbra/core/memory.h"
#include "penumbra/core/random.h"
#include "penumbra/core/sampling.h"
#include "penumbra/ecs/transform.h"
#include "penumbra/probe_grid/probe_grid_baker.h"
#include "penumbra/scene/builtin.h"

namespace penumbra::bench {
namespace {

struct SceneCase {
  const char* name;
  Aabb box;                     // the grid's box (the domain the receivers are drawn from)
  std::vector<float> spacings;  // full sweep; quick uses the first
  bool thin_wall;               // courtyard: leak receivers near the thin wall
  std::vector<Aabb> solids;     // cornell: leak receivers near these closed blocks (their bounds)
};

// The courtyard's free-standing thin wall (builtin_scenes.cpp): x in [1, 5], y in [0, 2.5], z = -2 +- 0.025.
constexpr float kWallX0 = 1.0f, kWallX1 = 5.0f, kWallTop = 2.5f, kWallZ = -2.0f, kWallHalf = 0.025f;

struct Receivers {
  std::vector<SurfacePoint> points;
  std::vector<Estimate> reference;
  double mean = 0.0;        // mean reference irradiance (channel average)
  double mean_stderr = 0.0; // mean reference standard error (channel average)
};

bool in_domain(const RayScene& scene, glm::vec3 x, Rng& rng) {
  int back = 0;
  const int rays = 64;
  for (int i = 0; i < rays; ++i) {
    Hit h;
    if (scene.intersect(Ray{x, 0.0f, uniform_sphere({rng.next_float(), rng.next_float()}), 1e30f}, h) &&
        h.back_face && !h.material.double_sided)
      ++back;
  }
  return back <= rays / 10;
}

// The reference irradiance of `content` at the receivers' points, and its means.
Status compute_reference(const RayScene& scene, std::span<const WorldLight> lights, std::uint32_t ref_samples,
                         std::uint64_t seed, LightingContent content, Receivers& r, JobContext& jobs) {
  IrradianceSettings s;
  s.reference = true;
  s.samples = ref_samples;
  s.seed = seed;
  s.content = content;
  r.reference.assign(r.points.size(), Estimate{});
  r.mean = r.mean_stderr = 0.0;
  PENUMBRA_TRY(irradiance(scene, lights, r.points, s, r.reference, jobs));
  for (const Estimate& e : r.reference) {
    r.mean += (e.value.x + e.value.y + e.value.z) / 3.0;
    r.mean_stderr += (e.std_error.x + e.std_error.y + e.std_error.z) / 3.0;
  }
  r.mean /= double(std::max<std::size_t>(1, r.points.size()));
  r.mean_stderr /= double(std::max<std::size_t>(1, r.points.size()));
  return {};
}

// Random in-domain receivers drawn by `draw`, with random normals, and their reference irradiance.
template <class Draw>
Result<Receivers> make_receivers(const RayScene& scene, std::span<const WorldLight> lights, std::size_t count,
                                 std::uint32_t ref_samples, std::uint64_t seed, Draw draw, JobContext& jobs) {
  Receivers r;
  Rng rng = Rng::stream(seed, 0);
  for (std::size_t tries = 0; r.points.size() < count && tries < 50 * count; ++tries) {
    const glm::vec3 x = draw(rng);
    if (!in_domain(scene, x, rng)) continue;
    r.points.push_back({x, uniform_sphere({rng.next_float(), rng.next_float()})});
  }
  PENUMBRA_TRY(compute_reference(scene, lights, ref_samples, seed, LightingContent::All, r, jobs));
  return r;
}

// Points on the side faces (normal within 60 degrees of horizontal) of the blocks bounded by
// `solids`: each from a random in-domain point within `h` of a block's bounds (and in `box`),
// the first hit of a ray towards a random point of those bounds, kept when it is a front face
// inside them. Their normals are the faces'.
Receivers face_receivers(const RayScene& scene, std::span<const Aabb> solids, const Aabb& box, float h,
                         std::size_t count, std::uint64_t seed) {
  Receivers r;
  Rng rng = Rng::stream(seed, 0);
  const auto uniform = [&](glm::vec3 lo, glm::vec3 hi) {
    return lo + (hi - lo) * glm::vec3(rng.next_float(), rng.next_float(), rng.next_float());
  };
  for (std::size_t tries = 0; r.points.size() < count && tries < 50 * count; ++tries) {
    const Aabb& b = solids[std::min(solids.size() - 1, std::size_t(rng.next_float() * float(solids.size())))];
    const glm::vec3 from = uniform(glm::max(b.min - h, box.min), glm::min(b.max + h, box.max));
    if (!in_domain(scene, from, rng)) continue;
    const glm::vec3 dir = glm::normalize(uniform(b.min, b.max) - from);
    Hit hit;
    if (!scene.intersect(Ray{from, 0.0f, dir, 1e30f}, hit) || hit.back_face) continue;
    const glm::vec3 x = from + hit.t * dir;
    if (std::abs(hit.normal.y) > 0.5f || glm::any(glm::lessThan(x, b.min - 1e-3f)) ||
        glm::any(glm::greaterThan(x, b.max + 1e-3f)))
      continue;
    r.points.push_back({x, hit.normal});
  }
  return r;
}

struct Errors {
  double rmse = 0.0, mae = 0.0, max = 0.0;  // relative to the mean reference
  double ratio = 0.0;                       // mean grid irradiance / mean reference
};

// `norm`: the irradiance the errors are relative to (0: the receivers' mean reference).
Errors errors(const ProbeGridData& d, const Receivers& r, double norm = 0.0,
              ProbeReceiver kind = ProbeReceiver::Moving) {
  Errors e;
  double sq = 0.0, abs_sum = 0.0, grid_sum = 0.0;
  for (std::size_t i = 0; i < r.points.size(); ++i) {
    const glm::vec3 value = evaluate(d, r.points[i].position, r.points[i].normal, kind);
    const glm::vec3 diff = value - r.reference[i].value;
    grid_sum += (double(value.x) + value.y + value.z) / 3.0;
    for (int c = 0; c < 3; ++c) {
      const double v = std::abs(double(diff[c]));
      sq += v * v;
      abs_sum += v;
      e.max = std::max(e.max, v);
    }
  }
  const double n = 3.0 * double(std::max<std::size_t>(1, r.points.size()));
  const double mean = norm > 0.0 ? norm : r.mean > 0.0 ? r.mean : 1.0;
  e.rmse = std::sqrt(sq / n) / mean;
  e.mae = abs_sum / n / mean;
  e.max /= mean;
  e.ratio = r.mean > 0.0 ? grid_sum / double(std::max<std::size_t>(1, r.points.size())) / r.mean : 0.0;
  return e;
}

// The L1 view of an L2 bake: the first four coefficients of every node.
ProbeGridData truncate_to_l1(const ProbeGridData& d) {
  ProbeGridData out = d;
  out.sh_order = ProbeShOrder::L1;
  out.coefficients.clear();
  for (std::size_t n = 0; n < d.node_count(); ++n)
    for (int c = 0; c < kSHCoefficientsL1; ++c) out.coefficients.push_back(d.coefficients[n * kSHCoefficientsL2 + static_cast<std::size_t>(c)]);
  return out;
}

double seconds_since(std::chrono::steady_clock::time_point t) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t).count();
}

// The bench's variants: a sampling mode, without or with the leak guard.
using Variant = std::pair<ProbeSampling, bool>;
constexpr std::array<Variant, 6> kVariants{{{ProbeSampling::Point, false},
                                            {ProbeSampling::Supersampled, false},
                                            {ProbeSampling::Fitted, false},
                                            {ProbeSampling::Point, true},
                                            {ProbeSampling::Supersampled, true},
                                            {ProbeSampling::Fitted, true}}};
std::string name(const Variant& v) { return std::string(to_string(v.first)) + (v.second ? "+guard" : ""); }

// Placements of the leak study: sub-cell offsets of the box in cells (z stratified, x spread).
constexpr int kPlacements = 4;
glm::vec3 placement_offset(int k) {
  const double x = 0.5 + 0.6180339887498949 * k;
  return glm::vec3(float(x - std::floor(x)), 0.0f, (float(k) + 0.5f) / float(kPlacements));
}

// The 1D step model (see the header): mean squared leak error over [a - 1, a + 1] of point
// sampling, tent averages and the window-optimal node values, for a step 0 -> 1 at a in [0, 1).
struct StepModel {
  double point = 0.0, tent = 0.0, best = 0.0;
};
StepModel step_model(double a) {
  const auto hat = [](double i, double z) { return std::max(0.0, 1.0 - std::abs(z - i)); };
  const auto step = [a](double z) { return z > a ? 1.0 : 0.0; };
  // Nodes -1..2 carry the window [a - 1, a + 1].
  constexpr int kNodes = 4;
  std::array<double, kNodes> point{}, tent{};
  for (int k = 0; k < kNodes; ++k) {
    const double i = k - 1;
    point[std::size_t(k)] = i == a ? 0.0 : step(i);
    // int B_i step / int B_i: the hat's mass right of a.
    const double d = std::clamp(a - i, -1.0, 1.0);
    tent[std::size_t(k)] = d >= 0.0 ? 0.5 * (1.0 - d) * (1.0 - d) : 1.0 - 0.5 * (1.0 + d) * (1.0 + d);
  }
  // Window-optimal: normal equations over a midpoint rule, a tiny ridge for nodes without support.
  constexpr int kQuad = 4000;
  std::array<std::array<double, kNodes + 1>, kNodes> m{};
  for (int q = 0; q < kQuad; ++q) {
    const double z = a - 1.0 + 2.0 * (q + 0.5) / kQuad;
    for (int r = 0; r < kNodes; ++r) {
      for (int c = 0; c < kNodes; ++c) m[std::size_t(r)][std::size_t(c)] += hat(r - 1, z) * hat(c - 1, z) / kQuad;
      m[std::size_t(r)][kNodes] += hat(r - 1, z) * step(z) / kQuad;
    }
  }
  for (int r = 0; r < kNodes; ++r) m[std::size_t(r)][std::size_t(r)] += 1e-12;
  for (std::size_t c = 0; c < kNodes; ++c)  // Gauss-Jordan (SPD: no pivoting needed)
    for (std::size_t r = 0; r < kNodes; ++r) {
      if (r == c) continue;
      const double f = m[r][c] / m[c][c];
      for (std::size_t k = c; k <= kNodes; ++k) m[r][k] -= f * m[c][k];
    }
  std::array<double, kNodes> best{};
  for (std::size_t r = 0; r < kNodes; ++r) best[r] = m[r][kNodes] / m[r][r];
  StepModel out;
  for (int q = 0; q < kQuad; ++q) {
    const double z = a - 1.0 + 2.0 * (q + 0.5) / kQuad;
    double p = 0.0, t = 0.0, b = 0.0;
    for (int k = 0; k < kNodes; ++k) {
      const double w = hat(k - 1, z);
      p += w * point[std::size_t(k)];
      t += w * tent[std::size_t(k)];
      b += w * best[std::size_t(k)];
    }
    out.point += (p - step(z)) * (p - step(z)) / kQuad;
    out.tent += (t - step(z)) * (t - step(z)) / kQuad;
    out.best += (b - step(z)) * (b - step(z)) / kQuad;
  }
  return out;
}

Result<Report> run_probe_grid_bench(const Options& options) {
  ThreadPool pool(options.threads);
  JobContext jobs(&pool);
  const bool quick = options.quick;
  const std::size_t receiver_count = quick ? 2000 : 4000;
  const std::size_t leak_count = quick ? 500 : 2000;
  const std::uint32_t ref_samples = quick ? 64 : 256;
  const std::vector<std::uint32_t> sample_counts = quick ? std::vector<std::uint32_t>{16} : std::vector<std::uint32_t>{8, 32};

  std::vector<SceneCase> scenes = {
      {"courtyard", Aabb{{-1.0f, 0.05f, -6.0f}, {7.0f, 3.05f, 2.0f}}, {1.0f, 0.5f}, true, {}},
      {"cornell", Aabb{{0.02f, 0.02f, 0.02f}, {0.54f, 0.45f, 0.54f}}, {0.13f, 0.065f}, false,
       {Aabb{{0.082f, 0.0f, 0.065f}, {0.290f, 0.165f, 0.272f}}, Aabb{{0.265f, 0.0f, 0.247f}, {0.472f, 0.330f, 0.456f}}}},
  };

  const auto verdict = [](bool pass) { return std::string(pass ? "PASS" : "FAIL"); };
  Report report;
  report.columns = {"scene", "mode", "lighting", "spacing", "samples", "sh_order", "bake_s", "bytes",
                    "rmse", "mae", "max_err", "leak_rmse", "ref_stderr"};
  // Per (scene, spacing, samples) and variant (L2): leak RMSE, overall RMSE and bake time, for the notes.
  struct ModeResult {
    double leak = 0.0, rmse = 0.0, seconds = 0.0;
  };
  std::map<std::string, std::map<Variant, ModeResult>> results;
  double eval_ns[2] = {0.0, 0.0};  // plain, guarded
  std::uint64_t bytes_per_node_l1 = 0, bytes_per_node_l2 = 0;

  for (const SceneCase& sc : scenes) {
    World world;
    auto loaded = load_builtin(world, sc.name);
    if (!loaded) return loaded.error();
    update_world_transforms(world);
    RaySceneOptions ro;
    ro.include_dynamic = false;
    auto scene = RayScene::build(world, ro);
    if (!scene) return scene.error();
    const std::vector<WorldLight> lights = baked_lights(world);

    const Aabb box = sc.box;
    auto receivers = make_receivers(*scene, lights, receiver_count, ref_samples, 101, [&](Rng& rng) {
      return box.min + box.extent() * glm::vec3(rng.next_float(), rng.next_float(), rng.next_float());
    }, jobs);
    if (!receivers) return receivers.error();

    const std::size_t spacing_count = quick ? 1 : sc.spacings.size();
    Receivers ind;  // the receivers with the indirect reference (computed at the first spacing)
    for (std::size_t si = 0; si < spacing_count; ++si) {
      const float h = sc.spacings[si];
      Receivers leak;
      if (sc.thin_wall) {
        auto l = make_receivers(*scene, lights, leak_count, ref_samples, 202 + si, [&](Rng& rng) {
          const float side = rng.next_float() < 0.5f ? -1.0f : 1.0f;
          const float d = kWallHalf + 0.01f + (h - kWallHalf - 0.01f) * rng.next_float();
          return glm::vec3(kWallX0 + (kWallX1 - kWallX0) * rng.next_float(), 0.05f + (kWallTop - 0.05f) * rng.next_float(),
                           kWallZ + side * d);
        }, jobs);
        if (!l) return l.error();
        leak = std::move(*l);
      } else if (!sc.solids.empty()) {
        // Within one spacing of a block's bounds and in the grid's box; points inside a block see
        // its back faces and are rejected with the rest of the out-of-domain points.
        auto l = make_receivers(*scene, lights, leak_count, ref_samples, 202 + si, [&](Rng& rng) {
          const Aabb& b = sc.solids[std::min(sc.solids.size() - 1, std::size_t(rng.next_float() * float(sc.solids.size())))];
          const glm::vec3 lo = glm::max(b.min - h, box.min), hi = glm::min(b.max + h, box.max);
          return lo + (hi - lo) * glm::vec3(rng.next_float(), rng.next_float(), rng.next_float());
        }, jobs);
        if (!l) return l.error();
        leak = std::move(*l);
      }
      const bool has_leak = !leak.points.empty();
      if (has_leak)
        report.notes.push_back(std::string(sc.name) + " leak receivers (h " + fmt(h) + ", " +
                               (sc.thin_wall ? "beside the thin wall" : "beside the solid blocks") + "): " +
                               std::to_string(leak.points.size()) + ", mean E " + fmt(leak.mean) +
                               " W/m^2, reference std error " + fmt(100.0 * leak.mean_stderr / leak.mean, 3) + "%");
      // One bake of the bench's grid over `box`: the data and the seconds it took.
      const auto bake = [&](const Aabb& grid_box, Variant v, std::uint32_t samples, double& seconds,
                            LightingContent lighting = LightingContent::All,
                            float noise = 0.0f) -> Result<ProbeGridData> {
        const auto [mode, guard] = v;
        IrradianceProbeGrid grid;
        grid.leak_guard = guard;
        grid.lighting = lighting;
        grid.box = grid_box;
        grid.spacing = h;
        grid.sampling = mode;
        grid.samples_per_node = samples;
        grid.rays_per_sample = 16;
        grid.bounces = kProbeAllBounces;
        grid.noise = noise;
        MemoryBudget budget;
        const auto t0 = std::chrono::steady_clock::now();
        auto data = bake_probe_grid(grid, glm::mat4(1.0f), *scene, lights, 7, jobs, budget,
                                    std::string("bench grid ") + sc.name);
        seconds = seconds_since(t0);
        return data;
      };
      for (std::uint32_t samples : sample_counts) {
        for (const Variant& mode : kVariants) {
          double bake_s = 0.0;
          auto data = bake(sc.box, mode, samples, bake_s);
          if (!data) return data.error();
          const std::string key = std::string(sc.name) + "/" + fmt(h) + "/" + std::to_string(samples);
          for (ProbeShOrder order : {ProbeShOrder::L2, ProbeShOrder::L1}) {
            const ProbeGridData d = order == ProbeShOrder::L2 ? *data : truncate_to_l1(*data);
            const Errors e = errors(d, *receivers);
            const Errors le = has_leak ? errors(d, leak) : Errors{};
            if (!mode.second) (order == ProbeShOrder::L1 ? bytes_per_node_l1 : bytes_per_node_l2) = d.bytes_per_node();
            report.rows.push_back({sc.name, name(mode), to_string(LightingContent::All), fmt(h),
                                   std::to_string(samples), to_string(order), fmt(bake_s),
                                   std::to_string(d.node_count() * d.bytes_per_node()), fmt(e.rmse), fmt(e.mae),
                                   fmt(e.max), has_leak ? fmt(le.rmse) : "",
                                   fmt(receivers->mean_stderr / receivers->mean)});
            if (order == ProbeShOrder::L2) results[key][mode] = {le.rmse, e.rmse, bake_s};
          }
          // Runtime cost per receiver: evaluate() over the receivers, best of three passes, once
          // plain and once guarded.
          double& ns = eval_ns[mode.second ? 1 : 0];
          if (ns == 0.0) {
            double best = 1e30;
            volatile float sink = 0.0f;
            for (int pass = 0; pass < 3; ++pass) {
              const auto t = std::chrono::steady_clock::now();
              for (int rep = 0; rep < 20; ++rep)
                for (const SurfacePoint& p : receivers->points) sink = sink + evaluate(*data, p.position, p.normal).x;
              best = std::min(best, seconds_since(t) * 1e9 / (20.0 * double(receivers->points.size())));
            }
            ns = best;
          }
        }
      }
      // Indirect grids (header): every spacing, largest sample count, L2, against the indirect
      // reference at the same receivers, errors relative to the mean total irradiance.
      {
        const std::uint32_t samples = sample_counts.back();
        Receivers ind_leak = leak;
        if (si == 0) {
          ind = *receivers;
          PENUMBRA_TRY(compute_reference(*scene, lights, ref_samples, 101, LightingContent::Indirect, ind, jobs));
        }
        if (has_leak)
          PENUMBRA_TRY(compute_reference(*scene, lights, ref_samples, 202 + si, LightingContent::Indirect, ind_leak,
                                         jobs));
        std::string line = std::string(sc.name) + " indirect grids (h " + fmt(h) + ", S " + std::to_string(samples) +
                           "): mean indirect E " + fmt(ind.mean) + " W/m^2 = " +
                           fmt(100.0 * ind.mean / receivers->mean, 3) +
                           "% of the total; RMSE / mean total, all grid -> direct exact + indirect grid:";
        const std::string key = std::string(sc.name) + "/" + fmt(h) + "/" + std::to_string(samples);
        Receivers faces;  // header: static receivers on the blocks' side faces
        std::string face_line;
        if (!sc.solids.empty()) {
          faces = face_receivers(*scene, sc.solids, sc.box, h, leak_count / 2, 303 + si);
          PENUMBRA_TRY(compute_reference(*scene, lights, ref_samples, 303 + si, LightingContent::Indirect, faces, jobs));
          face_line = std::string(sc.name) + " indirect grids (h " + fmt(h) + ", S " + std::to_string(samples) +
                      ") on the blocks' side faces (" + std::to_string(faces.points.size()) + " receivers, mean E " +
                      fmt(faces.mean) + " W/m^2, reference std error " +
                      fmt(100.0 * faces.mean_stderr / std::max(faces.mean, 1e-30), 3) +
                      "%), RMSE / mean E and mean ratio, evaluated as a moving receiver -> as static geometry:";
        }
        std::map<Variant, ModeResult> indirect;
        const Variant fitted_guard{ProbeSampling::Fitted, true};
        double fitted_guard_rmse = 0.0;  // of the mean indirect E, without a noise target
        for (const Variant& mode : kVariants) {
          double bake_s = 0.0;
          auto data = bake(sc.box, mode, samples, bake_s, LightingContent::Indirect);
          if (!data) return data.error();
          if (mode.second && !faces.points.empty()) {
            const Errors moving = errors(*data, faces), fixed = errors(*data, faces, 0.0, ProbeReceiver::Static);
            face_line += std::string(" ") + name(mode) + " " + fmt(moving.rmse, 3) + " (" + fmt(moving.ratio, 3) +
                         "x) -> " + fmt(fixed.rmse, 3) + " (" + fmt(fixed.ratio, 3) + "x);";
          }
          const Errors e = errors(*data, ind, receivers->mean);
          const Errors le = has_leak ? errors(*data, ind_leak, leak.mean) : Errors{};
          indirect[mode] = {le.rmse, e.rmse, bake_s};
          report.rows.push_back({sc.name, name(mode), to_string(LightingContent::Indirect), fmt(h),
                                 std::to_string(samples), to_string(ProbeShOrder::L2), fmt(bake_s),
                                 std::to_string(data->node_count() * data->bytes_per_node()), fmt(e.rmse), fmt(e.mae),
                                 fmt(e.max), has_leak ? fmt(le.rmse) : "", fmt(ind.mean_stderr / receivers->mean)});
          const double of_indirect = errors(*data, ind).rmse;
          line += std::string(" ") + name(mode) + " " + fmt(results[key][mode].rmse, 3) + " -> " + fmt(e.rmse, 3) +
                  " (" + fmt(of_indirect, 3) + " of the mean indirect E);";
          if (mode == fitted_guard) fitted_guard_rmse = of_indirect;
        }
        report.notes.push_back(line);
        if (!face_line.empty()) report.notes.push_back(face_line);
        // The noise target (header): fitted+guard again with the medium and high presets' targets.
        std::string noise_line = std::string(sc.name) + " indirect grids (h " + fmt(h) + ", S " +
                                 std::to_string(samples) + "), fitted+guard with a noise target, RMSE / mean indirect E " +
                                 "(the reference's own relative standard error " +
                                 fmt(ind.mean_stderr / std::max(ind.mean, 1e-30), 3) + "): none " +
                                 fmt(fitted_guard_rmse, 3) + " (" + fmt(indirect[fitted_guard].seconds) + " s)";
        for (const float target :
             {IrradianceProbeGrid::preset(Preset::Medium).noise, IrradianceProbeGrid::preset(Preset::High).noise}) {
          double bake_s = 0.0;
          auto data = bake(sc.box, fitted_guard, samples, bake_s, LightingContent::Indirect, target);
          if (!data) return data.error();
          const Errors e = errors(*data, ind, receivers->mean);
          const std::string label = name(fitted_guard) + " noise " + fmt(100.0 * target) + "%";
          report.rows.push_back({sc.name, label, to_string(LightingContent::Indirect), fmt(h), std::to_string(samples),
                                 to_string(ProbeShOrder::L2), fmt(bake_s),
                                 std::to_string(data->node_count() * data->bytes_per_node()), fmt(e.rmse), fmt(e.mae),
                                 fmt(e.max), has_leak ? fmt(errors(*data, ind_leak, leak.mean).rmse) : "",
                                 fmt(ind.mean_stderr / receivers->mean)});
          noise_line += "; " + fmt(100.0 * target) + " %: " + fmt(errors(*data, ind).rmse, 3) + " (" + fmt(bake_s) +
                        " s, " + fmt(data->ray_factor, 3) + "x the rays, " +
                        fmt(100.0 * double(data->refined_nodes) / double(data->node_count()), 3) + " % of nodes refined)";
        }
        report.notes.push_back(noise_line);
        // The goal's ratios on the indirect grids (the content the SDK renderer uses).
        const ModeResult point = indirect[Variant{ProbeSampling::Point, false}];
        if (has_leak && point.leak > 0.0) {
          line = std::string(sc.name) + " indirect grids (h " + fmt(h) + ", S " + std::to_string(samples) + "), " +
                 (sc.thin_wall ? "thin-wall" : "solid-block") + " leak RMSE against plain point sampling:";
          for (const Variant& mode : kVariants) {
            if (mode == Variant{ProbeSampling::Point, false}) continue;
            const double leak_ratio = indirect[mode].leak / point.leak, time = indirect[mode].seconds / point.seconds;
            line += std::string(" ") + name(mode) + " " + fmt(leak_ratio, 3) + " (goal <= 0.5: " +
                    verdict(leak_ratio <= 0.5) + "), bake time " + fmt(time, 3) + "x (goal <= 1.5: " +
                    verdict(time <= 1.5) + ");";
          }
          report.notes.push_back(line);
        }
      }
      if (!sc.thin_wall) continue;
      // The leak study over placements (header): the largest sample count, aligned box and offsets.
      const std::uint32_t samples = sample_counts.back();
      struct Pooled {
        double mse = 0.0, seconds = 0.0;
      };
      std::map<Variant, Pooled> aligned, shifted;
      for (int k = -1; k < kPlacements; ++k) {
        const glm::vec3 shift = k < 0 ? glm::vec3(0.0f) : h * placement_offset(k);
        for (const Variant& mode : kVariants) {
          double seconds = 0.0;
          auto data = bake(Aabb{sc.box.min + shift, sc.box.max + shift}, mode, samples, seconds);
          if (!data) return data.error();
          const double rmse = errors(*data, leak).rmse;
          Pooled& p = k < 0 ? aligned[mode] : shifted[mode];
          p.mse += rmse * rmse / (k < 0 ? 1.0 : double(kPlacements));
          p.seconds += seconds;
        }
      }
      StepModel model_aligned = step_model(0.0), model_shifted;
      for (int k = 0; k < kPlacements; ++k) {
        const StepModel m = step_model(double(placement_offset(k).z));
        model_shifted.point += m.point / kPlacements;
        model_shifted.tent += m.tent / kPlacements;
        model_shifted.best += m.best / kPlacements;
      }
      for (const auto& [placement, by, model] :
           {std::tuple{std::string("aligned box"), &aligned, model_aligned},
            std::tuple{std::to_string(kPlacements) + " sub-cell offsets (pooled)", &shifted, model_shifted}}) {
        const Pooled point = (*by)[Variant{ProbeSampling::Point, false}];
        std::string line = std::string(sc.name) + " leak, h " + fmt(h) + ", S " + std::to_string(samples) + ", " +
                           placement + ": leak RMSE point " + fmt(std::sqrt(point.mse), 3) + ";";
        for (const Variant& mode : kVariants) {
          if (mode == Variant{ProbeSampling::Point, false}) continue;
          const Pooled m = (*by)[mode];
          const double leak_ratio = std::sqrt(m.mse / point.mse), time = m.seconds / point.seconds;
          line += std::string(" ") + name(mode) + "/point " + fmt(leak_ratio, 3) + " (goal <= 0.5: " +
                  verdict(leak_ratio <= 0.5) + "), bake time " + fmt(time, 3) + "x (goal <= 1.5: " +
                  verdict(time <= 1.5) + ");";
        }
        line += " 1D step model: tent/point " + fmt(std::sqrt(model.tent / model.point), 3) +
                ", best possible node values/point " + fmt(std::sqrt(model.best / model.point), 3);
        report.notes.push_back(line);
      }
    }
    report.notes.push_back(std::string(sc.name) + ": " + std::to_string(receivers->points.size()) +
                           " receivers in the domain of interest, reference " + std::to_string(ref_samples) +
                           " paths each (mean E " + fmt(receivers->mean) + " W/m^2, mean std error " +
                           fmt(100.0 * receivers->mean_stderr / receivers->mean, 3) + "%)");
  }

  const auto ratio = [](double a, double b) { return b > 0.0 ? a / b : 0.0; };
  for (auto& [key, by_mode] : results) {
    const bool wall = key.rfind("courtyard/", 0) == 0;
    // Three comparisons (header): each runtime's modes against its own point sampling, and the
    // guarded modes against plain point sampling.
    for (const auto& [label, point_guard, guard] :
         {std::tuple{"plain runtime", false, false}, std::tuple{"guarded runtime", true, true},
          std::tuple{"guarded vs plain point", false, true}}) {
      const ModeResult point = by_mode[Variant{ProbeSampling::Point, point_guard}];
      const ModeResult super = by_mode[Variant{ProbeSampling::Supersampled, guard}];
      const ModeResult fitted = by_mode[Variant{ProbeSampling::Fitted, guard}];
      std::string line = key + " (scene/spacing/samples), " + label + ":";
      if (point.leak > 0.0) {
        const std::string base = point_guard ? "point+guard" : "point";
        for (const auto& [mode, m] :
             {std::pair{ProbeSampling::Supersampled, super}, std::pair{ProbeSampling::Fitted, fitted}}) {
          const double leak = ratio(m.leak, point.leak), time = ratio(m.seconds, point.seconds);
          line += std::string(" ") + name(Variant{mode, guard}) + "/" + base + " " +
                  (wall ? "thin-wall" : "solid-block") + " leak RMSE " + fmt(leak, 3) + " (" +
                  (wall ? "goal" : "the goal's bar") + " <= 0.5: " + verdict(leak <= 0.5) + "), bake time " +
                  fmt(time, 3) + "x (goal <= 1.5: " + verdict(time <= 1.5) + "), RMSE " +
                  fmt(ratio(m.rmse, point.rmse), 3) + "x;";
        }
      }
      const double overall = ratio(fitted.rmse, super.rmse);
      if (point_guard == guard)
        line += " fitted/supersampled RMSE " + fmt(overall, 3) + " (goal <= 1: " + verdict(overall <= 1.0) + ")";
      report.notes.push_back(line);
    }
  }
  report.notes.push_back("runtime: " + fmt(eval_ns[0], 3) + " ns per receiver evaluation plain, " +
                         fmt(eval_ns[1], 3) + " ns guarded (CPU evaluate, L2); " + std::to_string(bytes_per_node_l1) +
                         " B per node L1, " + std::to_string(bytes_per_node_l2) +
                         " B per node L2 (float RGB), +6 B with the leak guard");
  report.plot.title = "probe grid: irradiance RMSE against bake time";
  report.plot.x_label = "bake seconds";
  report.plot.y_label = "RMSE / mean irradiance";
  report.plot.x_column = 6;
  report.plot.y_column = 8;
  report.plot.series_column = 1;
  report.plot.log_x = true;
  report.plot.points_only = true;
  return report;
}

}  // namespace

PENUMBRA_BENCH("probe-grid", "irradiance probe grid: point vs supersampled vs fitted error, leaks, bake time, bytes",
               run_probe_grid_bench);

}  // namespace penumbra::bench
