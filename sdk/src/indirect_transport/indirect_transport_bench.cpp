// `penumbra bench indirect-transport`: the error / precompute / size / update trade of wavelet
// radiance transport on the built-in maze, against the SDK's path tracer and a dense baseline.
//
// Reference: at every covered leaf texel, the indirect irradiance of the lantern (irradiance() with
// content Indirect in reference mode: unbiased paths, Russian roulette), averaged over random points
// of the texel, with its standard error; for three positions of the lantern along its path.
// Error: relative RMSE over every texel, channel and position, sqrt(sum (E - R)^2 / sum R^2);
// ref_stderr is the reference's own relative standard error, sqrt(sum sigma^2 / sum R^2), and
// rel_rmse_net = sqrt(max(0, rel_rmse^2 - ref_stderr^2)) the error against the converged light.
// Methods: `hierarchical` (the baker, swept over refinement threshold, finest level and bounce
// tolerance) and `dense` (every leaf-to-leaf link with the same estimator, projected onto the same
// Haar bases, truncated to a fraction of the coefficient count of the hierarchical T at the
// default threshold at that level (direct_coefficients: the count kept), then the same Neumann
// series): the approach the paper improves on. precompute_s: wall time of the bake (hierarchical)
// or of the dense operator; operator_s: wall time of the operator alone (links, T, series; the
// bake's patches and bounce probes left out; hierarchical: the median of three), the same work
// for both methods; bytes: the global
// operator; peak_bytes: the largest operator held during the bake (dense: its matrix).
// update_ms: direct light at the texels plus the sparse product after a light move (median).
// Equal error: the dense truncation with the fewest coefficients that is at least as accurate as
// the hierarchical run at the default settings. drop_threshold: the series' (IndirectTransport).
// Method `bounce probes` (the probes' spacing in the threshold column, metres): the probes' light
// at free points of the maze, where moving objects stand (1.0-1.8 m high, no surface within
// 0.3 m along the axes), with each of the six axis normals, against irradiance() there (content
// Indirect, reference mode); bytes are the probes', update_ms their share of the update.
#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "bench.h"
#include "penumbra/bake/integrators.h"
#include "penumbra/bake/ray_scene.h"
#include "penumbra/bakers.h"
#include "penumbra/core/random.h"
#include "penumbra/ecs/transform.h"
#include "penumbra/indirect_transport/indirect_transport_baker.h"
#include "penumbra/indirect_transport/indirect_transport_system.h"
#include "penumbra/runtime.h"
#include "penumbra/scene/builtin.h"
#include "penumbra/scene/components.h"

namespace penumbra::bench {
namespace {

using Clock = std::chrono::steady_clock;
double seconds_since(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

// The maze with its default lighting components, transforms current.
Result<Entity> maze(World& world) {
  register_lighting(world);
  register_bakers(world);
  PENUMBRA_TRY(load_builtin(world, "maze"));
  world.update(0.0);
  PENUMBRA_TRY(add_default_lighting(world, Preset::Medium, false));
  for (Entity e : world.view<DynamicLight>().sorted_entities()) {
    world.remove<Animator>(e);  // the bench places the lantern itself
    return e;
  }
  return make_error(ErrorCode::NotFound, "indirect-transport bench: the maze has no dynamic light");
}

Entity transport_entity(World& world) {
  for (Entity e : world.view<IndirectTransport>().sorted_entities()) return e;
  return Entity::null();
}

struct Reference {
  std::vector<std::vector<glm::vec3>> value, variance;  // per light position, per leaf
};

// Path-traced indirect irradiance at every covered leaf for each light position.
Result<Reference> reference(World& world, Entity lantern, const std::vector<glm::vec3>& positions,
                            const TransportData& layout, std::uint32_t samples, JobContext& jobs) {
  Reference ref;
  for (const glm::vec3& position : positions) {
    world.patch<Transform>(lantern).translation = position;
    update_world_transforms(world);
    auto rays = RayScene::build(world);
    if (!rays) return rays.error();
    const std::vector<WorldLight> lights = gather_lights(world);
    std::vector<glm::vec3> value(layout.leaf_count(), glm::vec3(0.0f)), variance(layout.leaf_count(), glm::vec3(0.0f));
    IrradianceSettings s;
    s.samples = samples;
    s.content = LightingContent::Indirect;
    s.reference = true;
    jobs.begin_stage("reference", layout.patches.size());
    PENUMBRA_TRY(jobs.parallel_for(layout.patches.size(), 1, [&](std::size_t begin, std::size_t end) {
      for (std::size_t pi = begin; pi < end; ++pi) {
        const TransportPatch& p = layout.patches[pi];
        for (std::uint32_t k = 0; k < p.leaves(); ++k) {
          if (!(p.coverage[k] > 0.0f)) continue;
          Rng rng = Rng::stream(17, p.first + k);
          glm::dvec3 sum(0.0), square(0.0);
          const float inv = 1.0f / float(p.side());
          std::uint32_t taken = 0;
          for (std::uint32_t n = 0; n < samples; ++n) {
            const float u = (float(k % p.side()) + rng.next_float()) * inv, v = (float(k / p.side()) + rng.next_float()) * inv;
            const glm::vec3 x = p.origin + u * p.edge_u + v * p.edge_v + 1e-4f * p.normal;
            const glm::dvec3 e = glm::dvec3(irradiance_sample(*rays, lights, x, p.normal, s, rng));
            sum += e;
            square += e * e;
            ++taken;
          }
          const glm::dvec3 mean = sum / double(taken);
          value[p.first + k] = glm::vec3(mean);
          variance[p.first + k] = glm::vec3((square / double(taken) - mean * mean) / double(taken - 1));
        }
        jobs.advance(1);
      }
    }));
    ref.value.push_back(std::move(value));
    ref.variance.push_back(std::move(variance));
  }
  return ref;
}

struct Error {
  double rel_rmse = 0.0, ref_stderr = 0.0;
};

Error error_against(World& world, Entity lantern, const std::vector<glm::vec3>& positions, const TransportData& data,
                    const Reference& ref) {
  double diff = 0.0, norm = 0.0, var = 0.0;
  std::vector<glm::vec3> direct(data.leaf_count()), indirect(data.leaf_count());
  const TransportOccluders occluders = TransportOccluders::build(world);
  for (std::size_t i = 0; i < positions.size(); ++i) {
    world.patch<Transform>(lantern).translation = positions[i];
    update_world_transforms(world);
    auto lights = dynamic_lights(world);
    if (!lights) continue;
    direct_irradiance(data, *lights, &occluders, direct);
    apply_transport(data, direct, indirect);
    for (const TransportPatch& p : data.patches)
      for (std::uint32_t k = 0; k < p.leaves(); ++k) {
        if (!(p.coverage[k] > 0.0f)) continue;
        const glm::dvec3 d = glm::dvec3(indirect[p.first + k]) - glm::dvec3(ref.value[i][p.first + k]);
        diff += glm::dot(d, d);
        norm += glm::dot(glm::dvec3(ref.value[i][p.first + k]), glm::dvec3(ref.value[i][p.first + k]));
        var += double(ref.variance[i][p.first + k].x + ref.variance[i][p.first + k].y + ref.variance[i][p.first + k].z);
      }
  }
  return {std::sqrt(diff / norm), std::sqrt(var / norm)};
}

double net(const Error& e) { return std::sqrt(std::max(0.0, e.rel_rmse * e.rel_rmse - e.ref_stderr * e.ref_stderr)); }

// Free points of the maze (see the header), from a fixed seed, within the patches' bounds.
std::vector<glm::vec3> free_points(const RayScene& rays, const TransportData& data, std::size_t count) {
  glm::vec3 lo(std::numeric_limits<float>::max()), hi(-std::numeric_limits<float>::max());
  for (const TransportPatch& p : data.patches)
    for (const glm::vec3 c : {p.origin, p.origin + p.edge_u, p.origin + p.edge_v, p.origin + p.edge_u + p.edge_v}) {
      lo = glm::min(lo, c);
      hi = glm::max(hi, c);
    }
  std::vector<glm::vec3> out;
  Rng rng = Rng::stream(23, count);
  for (std::size_t tries = 0; out.size() < count && tries < 100 * count; ++tries) {
    const glm::vec3 x(glm::mix(lo.x, hi.x, rng.next_float()), 1.0f + 0.8f * rng.next_float(),
                      glm::mix(lo.z, hi.z, rng.next_float()));
    bool clear = true;
    for (int a = 0; a < 6 && clear; ++a) {
      glm::vec3 d(0.0f);
      d[a / 2] = a % 2 == 0 ? 1.0f : -1.0f;
      clear = !rays.occluded(Ray{x, 0.0f, d, 0.3f});
    }
    if (clear) out.push_back(x);
  }
  return out;
}

// The probes' error at `points` x six normals x the light positions, against irradiance() there
// through `rays`, the static geometry the probes model.
Result<Error> probe_error(World& world, Entity lantern, const std::vector<glm::vec3>& positions,
                          const TransportData& data, const RayScene& rays, const std::vector<glm::vec3>& points,
                          std::uint32_t samples, JobContext& jobs) {
  double diff = 0.0, norm = 0.0, var = 0.0;
  std::vector<glm::vec3> direct(data.leaf_count()), indirect(data.leaf_count()), cubes(6 * data.probes.nodes());
  const TransportOccluders occluders = TransportOccluders::build(world);
  for (const glm::vec3& position : positions) {
    world.patch<Transform>(lantern).translation = position;
    update_world_transforms(world);
    auto lights = dynamic_lights(world);
    if (!lights) return lights.error();
    direct_irradiance(data, *lights, &occluders, direct);
    apply_transport(data, direct, indirect);
    bounce_probe_irradiance(data, direct, indirect, cubes);
    const std::vector<WorldLight> world_lights = gather_lights(world);
    IrradianceSettings s;
    s.samples = samples;
    s.content = LightingContent::Indirect;
    s.reference = true;
    std::vector<Estimate> ref(6 * points.size());
    PENUMBRA_TRY(jobs.parallel_for(ref.size(), 6, [&](std::size_t begin, std::size_t end) {
      for (std::size_t k = begin; k < end; ++k) {
        glm::vec3 n(0.0f);
        n[int(k % 6) / 2] = k % 2 == 0 ? 1.0f : -1.0f;
        Rng rng = Rng::stream(29, k);
        ref[k] = irradiance(rays, world_lights, points[k / 6], n, s, rng);
      }
    }));
    for (std::size_t k = 0; k < ref.size(); ++k) {
      glm::vec3 n(0.0f);
      n[int(k % 6) / 2] = k % 2 == 0 ? 1.0f : -1.0f;
      const glm::dvec3 r(ref[k].value), se(ref[k].std_error);
      const glm::dvec3 d = glm::dvec3(sample_bounce_probes(data.probes, cubes, points[k / 6], n)) - r;
      diff += glm::dot(d, d);
      norm += glm::dot(r, r);
      var += glm::dot(se, se);
    }
  }
  if (!(norm > 0.0)) return make_error(ErrorCode::Internal, "indirect-transport bench: no bounce light at the free points");
  return Error{std::sqrt(diff / norm), std::sqrt(var / norm)};
}

// Median milliseconds of one update after a move, the lantern stepping along between positions:
// the whole update, and its three parts (direct light at the texels; analysis, product, synthesis;
// the bounce probes).
struct UpdateTimes {
  double total = -1.0, direct = 0.0, transport = 0.0, probes = 0.0;
};
UpdateTimes update_ms(World& world, Entity lantern, const std::vector<glm::vec3>& positions, const TransportData& data) {
  std::vector<double> total, direct, transport, probes;
  const TransportOccluders occluders = TransportOccluders::build(world);
  std::vector<glm::vec3> e_direct(data.leaf_count()), e_indirect(data.leaf_count()), cubes(6 * data.probes.nodes());
  for (int k = 0; k < 41; ++k) {
    world.patch<Transform>(lantern).translation = positions[std::size_t(k) % positions.size()] +
                                                  glm::vec3(0.01f * float(k), 0.0f, 0.0f);
    update_world_transforms(world);
    auto t = Clock::now();
    auto updated = update_indirect_transport(world);
    total.push_back(1e3 * seconds_since(t));
    if (!updated || !*updated) return {};
    auto lights = dynamic_lights(world);
    if (!lights) return {};
    t = Clock::now();
    direct_irradiance(data, *lights, &occluders, e_direct);
    direct.push_back(1e3 * seconds_since(t));
    t = Clock::now();
    apply_transport(data, e_direct, e_indirect);
    transport.push_back(1e3 * seconds_since(t));
    t = Clock::now();
    bounce_probe_irradiance(data, e_direct, e_indirect, cubes);
    probes.push_back(1e3 * seconds_since(t));
  }
  const auto median = [](std::vector<double>& v) {
    std::sort(v.begin(), v.end());
    return v[v.size() / 2];
  };
  return {median(total), median(direct), median(transport), median(probes)};
}

// The hierarchical operator by the baker's own steps (each receiver patch's links, T, the Neumann
// series) through `rays`, timed as the dense baseline is: the bake's other work (the patches, the
// bounce probes, the chunk) left out. The median of three runs: a few seconds of work on a shared
// machine, where the dense baseline's half a minute averages its noise out.
struct OperatorRun {
  SparseTransport global;
  double seconds = 0.0;
};
Result<OperatorRun> hierarchical_operator(const RayScene& rays, const std::vector<TransportPatch>& patches,
                                          const IndirectTransport& t, std::uint64_t seed, JobContext& jobs) {
  OperatorRun out;
  std::array<double, 3> seconds{};
  for (double& s : seconds) {
    const auto start = Clock::now();
    std::vector<std::vector<TransportLink>> links(patches.size());
    std::vector<std::uint64_t> traced(patches.size(), 0);
    PENUMBRA_TRY(jobs.parallel_for(patches.size(), 1, [&](std::size_t begin, std::size_t end) {
      for (std::size_t r = begin; r < end; ++r)
        links[r] = refine_receiver(rays, patches, static_cast<std::uint32_t>(r), t.refinement_threshold, seed, traced[r]);
    }));
    const SparseTransport direct = direct_operator(patches, links, jobs);
    links.clear();
    auto series = neumann_series(direct, t.bounce_tolerance, t.max_bounces, t.drop_threshold, 0, jobs);
    if (!series) return series.error();
    s = seconds_since(start);
    out.global = std::move(series->global);
  }
  std::sort(seconds.begin(), seconds.end());
  out.seconds = seconds[1];
  return out;
}

Result<Report> run(const Options& options) {
  Report report;
  report.columns = {"scene", "method", "threshold", "finest_level", "bounce_tolerance", "bounces", "links",
                    "coefficients", "precompute_s", "bytes", "peak_bytes", "update_ms", "rel_rmse", "ref_stderr",
                    "rel_rmse_net", "series", "operator_s", "direct_coefficients", "drop_threshold"};
  ThreadPool pool(options.threads);
  JobContext jobs(&pool);
  World world;
  auto lantern = maze(world);
  if (!lantern) return lantern.error();
  const Entity owner = transport_entity(world);
  const std::vector<glm::vec3> positions =
      options.quick ? std::vector<glm::vec3>{{2.0f, 1.6f, 2.0f}}
                    : std::vector<glm::vec3>{{2.0f, 1.6f, 2.0f}, {6.0f, 1.6f, 6.8f}, {10.0f, 1.6f, 1.5f}};
  const std::uint32_t ref_samples = options.quick ? 48 : 256;
  const std::vector<std::uint32_t> levels = options.quick ? std::vector<std::uint32_t>{2} : std::vector<std::uint32_t>{2, 3};
  const std::vector<float> thresholds = options.quick ? std::vector<float>{0.02f, 0.002f}
                                                      : std::vector<float>{0.02f, 0.01f, 0.004f, 0.002f, 0.001f};
  const IndirectTransport defaults = IndirectTransport::preset(Preset::Medium);
  double default_net = -1.0, default_update = -1.0;
  UpdateTimes default_split;
  struct Point {
    double net = 0.0, seconds = 0.0, bytes = 0.0;
  };
  std::uint64_t dense_keep_at_default = 0;
  auto rays = RayScene::build(world, RaySceneOptions{.include_dynamic = false});  // as the bake's
  if (!rays) return rays.error();

  for (const std::uint32_t level : levels) {
    // The texel layout of this level (thresholds do not change it) and its reference.
    world.patch<IndirectTransport>(owner).finest_level = level;
    std::vector<std::string> warnings;
    auto layout_patches = build_transport_patches(world, world.get<IndirectTransport>(owner), warnings);
    if (!layout_patches) return layout_patches.error();
    TransportData layout;
    layout.patches = std::move(*layout_patches);
    auto ref = reference(world, *lantern, positions, layout, ref_samples, jobs);
    if (!ref) return ref.error();
    Point at_default;  // the hierarchical run at the default settings
    // Every threshold at the default tolerance and drop threshold; at the default level (full run)
    // also the default threshold with other tolerances and a third of the drop threshold.
    struct Run {
      float threshold, tolerance, drop;
    };
    std::vector<Run> runs;
    for (const float threshold : thresholds) {
      runs.push_back({threshold, defaults.bounce_tolerance, defaults.drop_threshold});
      if (options.quick || level != defaults.finest_level || threshold != defaults.refinement_threshold) continue;
      runs.push_back({threshold, 1e-1f, defaults.drop_threshold});
      runs.push_back({threshold, 1e-2f, defaults.drop_threshold});
      runs.push_back({threshold, defaults.bounce_tolerance, defaults.drop_threshold / 3.0f});
    }
    for (const Run& run : runs) {
      const bool is_default = run.threshold == defaults.refinement_threshold &&
                              run.tolerance == defaults.bounce_tolerance && run.drop == defaults.drop_threshold;
      IndirectTransport& t = world.patch<IndirectTransport>(owner);
      t.refinement_threshold = run.threshold;
      t.bounce_tolerance = run.tolerance;
      t.drop_threshold = run.drop;
      t.data.reset();
      const auto start = Clock::now();
      BakeSettings settings;
      settings.seed = 3;
      auto baked = bake_world(world, {"indirect-transport"}, settings, jobs);
      const double seconds = seconds_since(start);
      if (!baked) return baked.error();
      const std::shared_ptr<const TransportData> data = world.get<IndirectTransport>(owner).data;
      if (!data) return make_error(ErrorCode::Internal, "indirect-transport bench: the bake attached nothing");
      const Error e = error_against(world, *lantern, positions, *data, *ref);
      const UpdateTimes times = update_ms(world, *lantern, positions, *data);
      const double bytes = double(data->global.bytes());
      auto op = hierarchical_operator(*rays, layout.patches, t, settings.seed, jobs);
      if (!op) return op.error();
      if (op->global.nonzeros() != data->global.nonzeros() || op->global.row != data->global.row)
        return make_error(ErrorCode::Internal, "indirect-transport bench: the timed operator differs from the bake's");
      report.rows.push_back({"maze", "hierarchical", fmt(run.threshold), std::to_string(level), fmt(run.tolerance),
                             std::to_string(data->terms), std::to_string(data->links),
                             std::to_string(data->global.nonzeros()), fmt(seconds), fmt(bytes), fmt(bytes),
                             fmt(times.total), fmt(e.rel_rmse), fmt(e.ref_stderr), fmt(net(e)),
                             "hierarchical L" + std::to_string(level), fmt(op->seconds),
                             std::to_string(data->direct_nonzeros), fmt(run.drop)});
      if (!is_default) continue;
      at_default = {net(e), op->seconds, bytes};
      dense_keep_at_default = data->direct_nonzeros;
      if (level == defaults.finest_level) {
        default_net = net(e);
        default_update = times.total;
        default_split = times;
      }
    }
    if (dense_keep_at_default == 0 || !(at_default.seconds > 0.0))
      return make_error(ErrorCode::Internal, "indirect-transport bench: no run at the default settings");
    // The dense baseline (its matrix is leaves^2: skipped over 4 GB): every link computed once,
    // then truncated to fractions of the hierarchical T's coefficient count at the default
    // threshold (1: the same count), each truncation with its own series.
    const std::uint64_t dense_bytes = std::uint64_t{layout.leaf_count()} * layout.leaf_count() * sizeof(glm::vec3);
    if (dense_bytes > (4ull << 30)) {
      report.notes.push_back("level " + std::to_string(level) + ": no dense baseline (its matrix needs " +
                             fmt(double(dense_bytes) / 1e9, 3) + " GB)");
      continue;
    }
    const auto start = Clock::now();
    std::uint64_t dense_rays = 0;
    auto dense = dense_direct_operator(*rays, layout.patches, 3, 4ull << 30, jobs, dense_rays);
    if (!dense) return dense.error();
    const double links_seconds = seconds_since(start);
    const double peak = double(dense->bytes());
    struct DenseRun {
      double fraction;
      Point point;
    };
    std::vector<DenseRun> dense_runs;
    const std::vector<double> fractions =
        options.quick ? std::vector<double>{0.5, 1.0} : std::vector<double>{0.1, 0.15, 0.25, 0.35, 0.5, 0.7, 1.0};
    for (const double fraction : fractions) {
      const auto keep = static_cast<std::uint64_t>(fraction * double(dense_keep_at_default));
      const auto series_start = Clock::now();
      auto series = neumann_series(truncate_transport(*dense, keep), defaults.bounce_tolerance, defaults.max_bounces,
                                   defaults.drop_threshold, 0, jobs);
      if (!series) return series.error();
      const double seconds = links_seconds + seconds_since(series_start);
      TransportData d = layout;
      d.global = std::move(series->global);
      d.terms = series->terms;
      const Error e = error_against(world, *lantern, positions, d, *ref);
      report.rows.push_back({"maze", "dense", "0", std::to_string(level), fmt(defaults.bounce_tolerance),
                             std::to_string(d.terms), std::to_string(std::uint64_t{d.leaf_count()} * d.leaf_count()),
                             std::to_string(d.global.nonzeros()), fmt(seconds), fmt(double(d.global.bytes())), fmt(peak),
                             "", fmt(e.rel_rmse), fmt(e.ref_stderr), fmt(net(e)), "dense L" + std::to_string(level),
                             fmt(seconds), std::to_string(keep), fmt(defaults.drop_threshold)});
      dense_runs.push_back({fraction, {net(e), seconds, double(d.global.bytes())}});
    }
    // The default threshold's run against the dense baseline at the same coefficient count, and at
    // equal error: the cheapest truncation at least as accurate (its links' time is the same for
    // every truncation; the peak is the dense matrix either way).
    const auto same =
        std::find_if(dense_runs.begin(), dense_runs.end(), [](const DenseRun& r) { return r.fraction == 1.0; });
    report.notes.push_back("level " + std::to_string(level) + ", the same coefficient count: hierarchical " +
                           fmt(at_default.net, 3) + " against dense " + fmt(same->point.net, 3) + " (net relative RMSE)");
    // Where no truncation is as accurate, the most accurate one: reaching the hierarchical run's
    // error would take at least its links, so the ratios still hold.
    const DenseRun* equal = nullptr;
    for (const DenseRun& r : dense_runs)
      if (r.point.net <= at_default.net && (equal == nullptr || r.fraction < equal->fraction)) equal = &r;
    const bool as_accurate = equal != nullptr;
    if (!as_accurate)
      equal = &*std::min_element(dense_runs.begin(), dense_runs.end(),
                                 [](const DenseRun& x, const DenseRun& y) { return x.point.net < y.point.net; });
    const double time_ratio = equal->point.seconds / at_default.seconds, size_ratio = peak / at_default.bytes;
    report.notes.push_back(
        "level " + std::to_string(level) + ", equal error (hierarchical at the default threshold " +
        fmt(at_default.net, 3) + ", dense truncated to " + fmt(equal->fraction, 2) + "x its coefficients " +
        fmt(equal->point.net, 3) + (as_accurate ? "" : ", the most accurate truncation") + "): operator precompute " +
        fmt(at_default.seconds, 3) + " s against " + fmt(equal->point.seconds, 3) + " s (" + fmt(time_ratio, 3) +
        "x faster), " + fmt(at_default.bytes / 1e6, 3) + " MB against the dense matrix's " + fmt(peak / 1e6, 4) +
        " MB (" + fmt(size_ratio, 3) + "x smaller; its truncated operator " + fmt(equal->point.bytes / 1e6, 3) +
        " MB)" +
        (level == defaults.finest_level
             ? std::string(" (goal >= 10x both: ") + (time_ratio >= 10.0 && size_ratio >= 10.0 ? "PASS" : "FAIL") + ")"
             : " (the goal is judged at the default finest level, " + std::to_string(defaults.finest_level) + ")"));
  }
  if (default_net >= 0.0) {
    report.notes.push_back("default settings (finest level " + std::to_string(defaults.finest_level) + ", threshold " +
                           fmt(defaults.refinement_threshold) + "): net relative RMSE " + fmt(default_net, 3) +
                           " against the path tracer (" + std::to_string(ref_samples) +
                           " paths per texel; goal <= 0.05: " + (default_net <= 0.05 ? "PASS" : "FAIL") + ")");
    report.notes.push_back("update after a light move: " + fmt(default_update, 3) + " ms (median of 41, on the system's two threads; its parts on one thread: direct light " +
                           fmt(default_split.direct, 3) + " ms, transport " + fmt(default_split.transport, 3) +
                           " ms, bounce probes " + fmt(default_split.probes, 3) +
                           " ms; goal <= 5 ms on 2 cores: " + (default_update <= 5.0 ? "PASS" : "FAIL") + ")");
  }
  // The bounce probes' spacing: the default and, in the full run, twice and half of it, on the
  // medium operator (quick: draft).
  {
    IndirectTransport& t = world.patch<IndirectTransport>(owner);
    const IndirectTransport preset = IndirectTransport::preset(options.quick ? Preset::Draft : Preset::Medium);
    t.finest_level = preset.finest_level;
    t.refinement_threshold = preset.refinement_threshold;
    t.bounce_tolerance = preset.bounce_tolerance;
    t.drop_threshold = preset.drop_threshold;
    std::vector<std::string> warnings;
    auto patches = build_transport_patches(world, t, warnings);
    if (!patches) return patches.error();
    const float default_spacing = bounce_probe_grid(*patches, 0.0f).spacing;
    std::vector<glm::vec3> points;
    const std::vector<float> factors = options.quick ? std::vector<float>{1.0f} : std::vector<float>{2.0f, 1.0f, 0.5f};
    for (const float factor : factors) {
      IndirectTransport& settings_now = world.patch<IndirectTransport>(owner);
      settings_now.probe_spacing = factor == 1.0f ? 0.0f : factor * default_spacing;
      settings_now.data.reset();
      BakeSettings settings;
      settings.seed = 3;
      const auto start = Clock::now();
      auto baked = bake_world(world, {"indirect-transport"}, settings, jobs);
      const double seconds = seconds_since(start);
      if (!baked) return baked.error();
      const std::shared_ptr<const TransportData> data = world.get<IndirectTransport>(owner).data;
      const float spacing = data->probes.spacing;
      if (points.empty()) points = free_points(*rays, *data, options.quick ? 40 : 200);
      auto e = probe_error(world, *lantern, positions, *data, *rays, points, ref_samples, jobs);
      if (!e) return e.error();
      const UpdateTimes times = update_ms(world, *lantern, positions, *data);
      const double bytes = double(data->probes.bytes());
      report.rows.push_back({"maze", "bounce probes", fmt(spacing), std::to_string(data->finest_level), "", "", "",
                             std::to_string(data->probes.entries.size()), fmt(seconds), fmt(bytes), fmt(bytes),
                             fmt(times.probes), fmt(e->rel_rmse), fmt(e->ref_stderr), fmt(net(*e)), "bounce probes",
                             "", "", ""});
      if (factor == 1.0f)
        report.notes.push_back("bounce probes at the default spacing (" + fmt(spacing, 3) + " m): net relative RMSE " +
                               fmt(net(*e), 3) + " at " + std::to_string(points.size()) +
                               " free points x 6 normals against the path tracer (" + std::to_string(ref_samples) +
                               " paths each, the reference's relative error " + fmt(e->ref_stderr, 3) + ")");
    }
  }
  report.notes.push_back("glossy transport: not implemented (the baker refuses glossy = true); no glossy figures");
  report.plot = {"Indirect transport on the maze: error against operator size", "global operator bytes",
                 "relative RMSE net of the reference's noise", 9, 14, 15, true, true, true};
  return report;
}

}  // namespace

PENUMBRA_BENCH("indirect-transport",
               "wavelet radiance transport on the maze: error against the path tracer, precompute time, operator "
               "bytes and update time, hierarchical against a dense baseline",
               run);

}  // namespace penumbra::bench
