// `penumbra bench ao-field`: ambient-occlusion fields (P2) against ray-traced AO of the caster
// alone, for casters of several shapes, in both representations (the radial fit of Kontkanen &
// Laine 2005 per cube resolution, radial sample count and supersampling; the 3D grid of Malmer et
// al. 2007 per grid size); bake seconds, bytes per caster and ns per receiver evaluation; and the
// combination of two and three casters (the multiplicative rule and the cap-overlap rule) against
// the ray-traced AO of their union.
//
// Receivers (per shape, the same for every field of that shape): free-space points at random
// directions and distances 0.3..3 bounding radii from the field centre (points inside the caster's
// solid are dropped: a ray from them first hits a back face), split into inside / outside the
// convex hull by the field's hull distance; and "ground" points on the plane the caster rests on
// (normal +Y) within 2 bounding radii. Free-space normals are random over the hemisphere facing
// the field centre. Reference: 1 - ambient_occlusion() of the caster alone. Goal: mean
// absolute error <= 0.03 outside the hull for 16x16 on the convex shapes; <= 50 ns per receiver
// per caster.
//
// Evaluation cost, one thread, best of five passes over the shape's receivers: eval_ns through
// accumulate_open (the system's batch path; AVX2 for the radial fit where the CPU has it) and
// scalar_ns one receiver at a time (evaluate_local). Beside them, in the same run, a fixed
// baseline: the closed-form cap occlusion (cap_occlusion, double precision) on as many inputs,
// whose cost does not depend on this module's evaluation code; the notes give the ratios.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <memory>
#include <numbers>
#include <string>
#include <tuple>
#include <vector>

#include <glm/geometric.hpp>
#include <glm/gtc/matrix_transform.hpp>

#include "bench.h"
#include "penumbra/ao_field/ao_field_baker.h"
#include "penumbra/bake/integrators.h"
#include "penumbra/bake/ray_scene.h"
#include "penumbra/core/jobs.h"
#include "penumbra/core/memory.h"
#include "penumbra/core/random.h"
#include "penumbra/core/sampling.h"
#include "penumbra/ecs/transform.h"
#include "penumbra/scene/mesh.h"

namespace penumbra::bench {
namespace {

double seconds_since(std::chrono::steady_clock::time_point t) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t).count();
}

// ns per item of `pass` (which handles `items` items): the best of five passes of `sweeps` calls.
template <class Fn>
double best_ns(std::size_t items, int sweeps, Fn&& pass) {
  double best = 1e30;
  for (int k = 0; k < 5; ++k) {
    const auto t = std::chrono::steady_clock::now();
    for (int rep = 0; rep < sweeps; ++rep) pass();
    best = std::min(best, seconds_since(t) * 1e9 / (double(sweeps) * double(items)));
  }
  return best;
}

// Appends `part` translated by `offset` to `mesh`.
void append(MeshData& mesh, const MeshData& part, glm::vec3 offset) {
  const auto base = static_cast<std::uint32_t>(mesh.positions.size());
  for (const glm::vec3& p : part.positions) mesh.positions.push_back(p + offset);
  for (const glm::vec3& n : part.normals) mesh.normals.push_back(n);
  for (std::uint32_t i : part.indices) mesh.indices.push_back(base + i);
}

// A concave chair: seat, four legs and a back, resting on y = 0.
MeshData make_chair() {
  MeshData chair;
  chair.name = "chair";
  append(chair, make_box({0.25f, 0.025f, 0.25f}), {0.0f, 0.45f, 0.0f});
  for (float x : {-0.22f, 0.22f})
    for (float z : {-0.22f, 0.22f}) append(chair, make_box({0.025f, 0.21f, 0.025f}), {x, 0.21f, z});
  append(chair, make_box({0.25f, 0.25f, 0.025f}), {0.0f, 0.725f, -0.225f});
  compute_bounds(chair);
  return chair;
}

struct Shape {
  const char* name;
  MeshData mesh;
  bool convex;
};

std::vector<Shape> shapes() {
  std::vector<Shape> out;
  out.push_back({"box", make_box({0.5f, 0.5f, 0.5f}), true});
  out.push_back({"sphere", make_icosphere(0.5f, 3), true});
  out.push_back({"plank", make_box({1.0f, 0.025f, 0.2f}), true});
  out.push_back({"chair", make_chair(), false});
  return out;
}

struct Receiver {
  SurfacePoint point;
  double reference = 0.0;  // ray-traced occlusion
  double stderr_ = 0.0;
  int region = 0;          // 0 outside the hull, 1 inside, 2 ground
};

RayScene scene_of(std::span<const MeshData* const> meshes, std::span<const glm::mat4> where, World& w) {
  for (std::size_t i = 0; i < meshes.size(); ++i) {
    const Entity e = w.create();
    w.add<Mesh>(e, Mesh{std::make_shared<const MeshData>(*meshes[i])});
    w.add<WorldTransform>(e, WorldTransform{where[i]});
    w.add<Static>(e);
  }
  auto s = RayScene::build(w);
  return std::move(*s);
}

struct Errors {
  double rmse = 0.0, mae = 0.0, max = 0.0, ref_stderr = 0.0;
  std::size_t count = 0;
};

Errors errors(const std::vector<Receiver>& rs, const std::vector<double>& values, int region) {
  Errors e;
  double sq = 0.0;
  for (std::size_t i = 0; i < rs.size(); ++i) {
    if (rs[i].region != region) continue;
    const double d = std::abs(values[i] - rs[i].reference);
    sq += d * d;
    e.mae += d;
    e.max = std::max(e.max, d);
    e.ref_stderr += rs[i].stderr_;
    ++e.count;
  }
  if (e.count == 0) return e;
  e.rmse = std::sqrt(sq / double(e.count));
  e.mae /= double(e.count);
  e.ref_stderr /= double(e.count);
  return e;
}

const char* kRegion[] = {"outside", "inside", "ground"};

Result<Report> run_ao_field_bench(const Options& options) {
  ThreadPool pool(options.threads);
  JobContext jobs(&pool);
  const bool quick = options.quick;
  const std::size_t free_count = quick ? 300 : 1500, ground_count = quick ? 150 : 500;
  const std::uint32_t ref_rays = quick ? 1024 : 4096;
  const std::vector<std::uint32_t> resolutions = quick ? std::vector<std::uint32_t>{8, 16} : std::vector<std::uint32_t>{8, 16, 32};
  const std::vector<std::uint32_t> radii_counts = quick ? std::vector<std::uint32_t>{16} : std::vector<std::uint32_t>{16, 32};
  const std::vector<std::uint32_t> grid_sizes = quick ? std::vector<std::uint32_t>{16, 32} : std::vector<std::uint32_t>{16, 32, 48};
  const std::uint32_t rays = quick ? 128 : 256;

  Report report;
  report.columns = {"shape", "representation", "resolution", "radii", "supersample", "region", "bake_s", "bytes",
                    "eval_ns", "scalar_ns", "rmse", "mae", "max_err", "ref_stderr", "receivers"};
  double worst_convex_16 = 0.0, worst_eval_ns = 0.0, worst_scalar_ns = 0.0, worst_grid_ns = 0.0;
  // Per shape and region, the best MAE of each representation and its bytes (where each wins).
  struct Best {
    double mae = 1e30;
    std::uint64_t bytes = 0;
    std::string what;
  };
  std::vector<std::string> wins;
  // Supersampling: outside-hull MAE at 16x16 with 1x1 and 2x2 directions per texel, per shape.
  std::vector<std::string> filtered;
  // The fixed baseline: the closed-form cap occlusion on random inputs, one thread.
  std::vector<glm::vec2> cap_inputs;
  {
    Rng rng = Rng::stream(17, 0);
    for (int i = 0; i < 512; ++i)
      cap_inputs.emplace_back(4.0f * std::numbers::pi_v<float> * rng.next_float(), 2.0f * rng.next_float() - 1.0f);
  }
  const auto baseline_ns = [&] {
    volatile float sink = 0.0f;
    return best_ns(cap_inputs.size(), 20, [&] {
      for (const glm::vec2& c : cap_inputs) sink = sink + cap_occlusion(c.x, c.y);
    });
  };
  double baseline_lo = 1e30, baseline_hi = 0.0;

  for (Shape& shape : shapes()) {
    // A first field gives the centre, radius and hull used to place the receivers.
    AOFieldCaster probe_settings;
    probe_settings.resolution = 8;
    probe_settings.radial_samples = 4;
    probe_settings.rays_per_sample = 16;
    MemoryBudget budget;
    auto probe = bake_ao_field(probe_settings, shape.mesh, 1, jobs, budget, shape.name);
    if (!probe) return probe.error();
    const glm::vec3 c = probe->centre;
    const float R = probe->bounding_radius;
    World w;
    const MeshData* one[] = {&shape.mesh};
    const glm::mat4 id[] = {glm::mat4(1.0f)};
    const RayScene scene = scene_of(one, id, w);

    std::vector<Receiver> receivers;
    Rng rng = Rng::stream(11, 0);
    while (receivers.size() < free_count) {
      const glm::vec3 d = uniform_sphere({rng.next_float(), rng.next_float()});
      const float r = R * (0.3f + 2.7f * rng.next_float());
      const glm::vec3 x = c + r * d;
      Hit h;
      if (scene.intersect(Ray{x, 0.0f, glm::vec3(0.267f, 0.534f, 0.802f), 1e30f}, h) && h.back_face) continue;
      Receiver rc;
      rc.point = {x, glm::normalize(to_world(-d, cosine_hemisphere({rng.next_float(), rng.next_float()})))};
      rc.region = r >= hull_distance(*probe, d) ? 0 : 1;
      receivers.push_back(rc);
    }
    const float floor_y = shape.mesh.bounds.min.y;
    for (std::size_t i = 0; i < ground_count; ++i) {
      const glm::vec2 disk = concentric_disk({rng.next_float(), rng.next_float()}) * 2.0f * R;
      const glm::vec3 x(c.x + disk.x, floor_y, c.z + disk.y);
      Hit h;
      if (scene.intersect(Ray{x + glm::vec3(0, 1e-4f, 0), 0.0f, glm::vec3(0, 1, 0), 1e30f}, h) && h.back_face) continue;
      Receiver rc;
      rc.point = {x, glm::vec3(0, 1, 0)};
      rc.region = 2;
      receivers.push_back(rc);
    }
    std::vector<SurfacePoint> points;
    for (const Receiver& r : receivers) points.push_back(r.point);
    std::vector<AoEstimate> ref(points.size());
    AoSettings ao;
    ao.rays = ref_rays;
    ao.seed = 5;
    PENUMBRA_TRY(ambient_occlusion(scene, points, ao, ref, jobs));
    for (std::size_t i = 0; i < receivers.size(); ++i) {
      receivers[i].reference = 1.0 - double(ref[i].value);
      receivers[i].stderr_ = ref[i].std_error;
    }

    // The fields of this shape: radial fits (2x2 supersampled; at 16x16 also 1x1) and grids.
    std::vector<AOFieldCaster> settings;
    for (std::uint32_t res : resolutions)
      for (std::uint32_t radii : radii_counts)
        for (std::uint32_t sub : {1u, 2u}) {
          if (sub == 1 && (res != 16 || radii != radii_counts.front())) continue;
          AOFieldCaster caster;
          caster.resolution = res;
          caster.radial_samples = radii;
          caster.rays_per_sample = rays;
          caster.supersample = sub;
          settings.push_back(caster);
        }
    for (std::uint32_t size : grid_sizes) {
      AOFieldCaster caster;
      caster.representation = AOFieldRepresentation::Grid;
      caster.grid_size = size;
      caster.rays_per_sample = rays;
      settings.push_back(caster);
    }
    std::vector<glm::vec3> xs, ns;
    for (const SurfacePoint& p : points) {
      xs.push_back(p.position);
      ns.push_back(p.normal);
    }
    Best best[2][3];
    double ss_mae[2] = {0.0, 0.0};
    for (const AOFieldCaster& caster : settings) {
      const bool grid = caster.representation == AOFieldRepresentation::Grid;
      const auto t0 = std::chrono::steady_clock::now();
      auto field = bake_ao_field(caster, shape.mesh, 7, jobs, budget, shape.name);
      if (!field) return field.error();
      const double bake_s = seconds_since(t0);
      std::vector<float> open(points.size(), 1.0f);
      accumulate_open(*field, glm::mat4(1.0f), xs, ns, open);
      std::vector<double> values(receivers.size());
      for (std::size_t i = 0; i < receivers.size(); ++i) values[i] = 1.0 - double(open[i]);
      // ns per receiver: the batch, then one at a time, then the fixed baseline.
      const double eval_ns = best_ns(points.size(), 20, [&] {
        std::fill(open.begin(), open.end(), 1.0f);
        accumulate_open(*field, glm::mat4(1.0f), xs, ns, open);
      });
      volatile float sink = 0.0f;
      const double scalar_ns = best_ns(points.size(), 20, [&] {
        for (const SurfacePoint& p : points) sink = sink + evaluate_local(*field, p.position, p.normal);
      });
      const double base = baseline_ns();
      baseline_lo = std::min(baseline_lo, base);
      baseline_hi = std::max(baseline_hi, base);
      if (grid) {
        worst_grid_ns = std::max(worst_grid_ns, eval_ns);
      } else {
        worst_eval_ns = std::max(worst_eval_ns, eval_ns);
        worst_scalar_ns = std::max(worst_scalar_ns, scalar_ns);
      }
      const std::string label = grid ? std::to_string(caster.grid_size) + "^3"
                                     : std::to_string(caster.resolution) + "x" + std::to_string(caster.resolution) +
                                           " (" + std::to_string(caster.radial_samples) + " radii)";
      for (int region = 0; region < 3; ++region) {
        const Errors e = errors(receivers, values, region);
        if (e.count == 0) continue;
        if (!grid && caster.resolution == 16 && caster.supersample == 2 && region == 0 && shape.convex)
          worst_convex_16 = std::max(worst_convex_16, e.mae);
        if (!grid && caster.resolution == 16 && region == 0 && caster.radial_samples == radii_counts.front())
          ss_mae[caster.supersample - 1] = e.mae;
        Best& b = best[grid ? 1 : 0][region];
        if (e.mae < b.mae && (grid || caster.supersample == 2)) b = {e.mae, field->bytes(), label};
        report.rows.push_back({shape.name, to_string(caster.representation),
                               std::to_string(grid ? caster.grid_size : caster.resolution),
                               grid ? "" : std::to_string(caster.radial_samples),
                               grid ? "" : std::to_string(caster.supersample), kRegion[region], fmt(bake_s),
                               std::to_string(field->bytes()), fmt(eval_ns), fmt(scalar_ns), fmt(e.rmse), fmt(e.mae),
                               fmt(e.max), fmt(e.ref_stderr), std::to_string(e.count)});
      }
    }
    for (int region = 0; region < 3; ++region) {
      if (best[0][region].bytes == 0) continue;
      const Best& r = best[0][region];
      const Best& g = best[1][region];
      wins.push_back(std::string(shape.name) + " " + kRegion[region] + ": " +
                     (g.mae < r.mae ? "grid wins" : "radial fit wins") + " (best radial " + r.what + " MAE " +
                     fmt(r.mae, 3) + " in " + format_bytes(r.bytes) + "; best grid " + g.what + " MAE " +
                     fmt(g.mae, 3) + " in " + format_bytes(g.bytes) + ")");
    }
    filtered.push_back(std::string(shape.name) + " " + fmt(ss_mae[0], 3) + " -> " + fmt(ss_mae[1], 3));
  }

  // Combination: unit crates apart (on both sides of the receivers), in a row and stacked (seen in
  // similar directions), receivers on the ground around them (normal +Y); the multiplicative rule
  // and the cap-overlap rule (combine_caps) against the ray-traced AO of the union.
  {
    AOFieldCaster caster;
    caster.resolution = 16;
    caster.radial_samples = 16;
    caster.rays_per_sample = rays;
    MemoryBudget budget;
    const MeshData crate = make_box({0.5f, 0.5f, 0.5f});
    auto field = bake_ao_field(caster, crate, 7, jobs, budget, "crate");
    if (!field) return field.error();
    struct Layout {
      const char* name;
      std::vector<glm::vec3> spots;
    };
    const std::vector<Layout> layouts = {
        {"2 crates apart", {{-0.8f, 0.5f, 0.0f}, {0.8f, 0.5f, 0.0f}}},
        {"3 crates apart", {{-0.8f, 0.5f, 0.0f}, {0.8f, 0.5f, 0.0f}, {0.0f, 0.5f, -0.9f}}},
        {"2 crates in a row", {{-0.8f, 0.5f, 0.0f}, {-1.9f, 0.5f, 0.0f}}},
        {"3 crates in a row", {{-0.8f, 0.5f, 0.0f}, {-1.9f, 0.5f, 0.0f}, {-3.0f, 0.5f, 0.0f}}},
        {"2 crates stacked", {{-0.8f, 0.5f, 0.0f}, {-0.8f, 1.5f, 0.0f}}},
    };
    for (std::size_t li = 0; li < layouts.size(); ++li) {
      const Layout& layout = layouts[li];
      const std::size_t n = layout.spots.size();
      std::vector<const MeshData*> meshes(n, &crate);
      std::vector<glm::mat4> where;
      for (const glm::vec3& spot : layout.spots) where.push_back(glm::translate(glm::mat4(1.0f), spot));
      World w;
      const RayScene scene = scene_of(meshes, where, w);
      std::vector<SurfacePoint> points;
      Rng rng = Rng::stream(13, li);
      while (points.size() < (quick ? 200u : 800u)) {
        const glm::vec3 x(-1.5f + 3.0f * rng.next_float(), 0.0f, -1.5f + 2.5f * rng.next_float());
        Hit h;
        if (scene.intersect(Ray{x + glm::vec3(0, 1e-4f, 0), 0.0f, glm::vec3(0, 1, 0), 1e30f}, h)) continue;  // under a crate
        points.push_back({x, glm::vec3(0, 1, 0)});
      }
      std::vector<AoEstimate> ref(points.size());
      AoSettings ao;
      ao.rays = ref_rays;
      ao.seed = 9;
      PENUMBRA_TRY(ambient_occlusion(scene, points, ao, ref, jobs));
      std::vector<Receiver> rs(points.size());
      std::vector<double> multiplicative(points.size()), overlap(points.size());
      double bias_mul = 0.0, bias_cap = 0.0;
      for (std::size_t i = 0; i < points.size(); ++i) {
        std::vector<float> each;
        std::vector<AOFieldCap> caps;
        for (const glm::mat4& m : where) {
          caps.push_back(evaluate_cap(*field, m, points[i].position, points[i].normal));
          each.push_back(caps.back().occlusion);
        }
        multiplicative[i] = combine_occlusion(each);
        overlap[i] = combine_caps(caps);
        rs[i] = {points[i], 1.0 - double(ref[i].value), ref[i].std_error, 2};
        bias_mul += multiplicative[i] - rs[i].reference;
        bias_cap += overlap[i] - rs[i].reference;
      }
      std::string note = std::string(layout.name) + ": mean signed error (positive: darker than the union)";
      for (const auto& [rule, values, bias] : {std::tuple{"multiplicative", &multiplicative, bias_mul},
                                               std::tuple{"cap-overlap", &overlap, bias_cap}}) {
        const Errors e = errors(rs, *values, 2);
        report.rows.push_back({layout.name, rule, "16", "16", "2", "ground", "", std::to_string(n * field->bytes()), "",
                               "", fmt(e.rmse), fmt(e.mae), fmt(e.max), fmt(e.ref_stderr), std::to_string(e.count)});
        note += std::string(" ") + rule + " " + fmt(bias / double(points.size()), 3) + " (MAE " + fmt(e.mae, 3) + ")";
      }
      report.notes.push_back(note);
    }
  }

  const auto verdict = [](bool pass) { return std::string(pass ? "PASS" : "FAIL"); };
  report.notes.push_back("worst outside-hull MAE at 16x16 on the convex shapes " + fmt(worst_convex_16, 3) +
                         " (goal <= 0.03: " + verdict(worst_convex_16 <= 0.03) + ")");
  report.notes.push_back("slowest radial-fit evaluation (accumulate_open, one thread) " + fmt(worst_eval_ns, 3) +
                         " ns per receiver per caster (goal <= 50: " + verdict(worst_eval_ns <= 50.0) +
                         "); one at a time " + fmt(worst_scalar_ns, 3) + " ns; grid " + fmt(worst_grid_ns, 3) + " ns");
  report.notes.push_back("fixed baseline, closed-form cap occlusion in double: " + fmt(baseline_lo, 3) + ".." +
                         fmt(baseline_hi, 3) + " ns per call in this run; radial-fit batch / baseline = " +
                         fmt(worst_eval_ns / baseline_lo, 3) + ", one at a time / baseline = " +
                         fmt(worst_scalar_ns / baseline_lo, 3));
  for (const std::string& w : wins) report.notes.push_back(w);
  std::string ss = "filtered down (supersample 1x1 -> 2x2, same rays), outside-hull MAE at 16x16:";
  for (const std::string& f : filtered) ss += " " + f + ";";
  report.notes.push_back(ss);
  report.plot.title = "ao field: MAE against bytes per caster (every shape, region and representation)";
  report.plot.x_label = "bytes per caster";
  report.plot.y_label = "mean absolute AO error";
  report.plot.x_column = 7;
  report.plot.y_column = 11;
  report.plot.series_column = 1;
  report.plot.log_x = true;
  report.plot.points_only = true;
  return report;
}

}  // namespace

PENUMBRA_BENCH("ao-field", "ambient occlusion fields: error vs ray-traced AO by shape/resolution/radii, bake time, "
               "bytes, ns per evaluation, multi-caster combination", run_ao_field_bench);

}  // namespace penumbra::bench
