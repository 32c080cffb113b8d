// `penumbra bench pose-ao`: skinned pose-AO (P5, Kontkanen & Aila 2006) against ray-traced AO of
// held-out poses, on CesiumMan (../shared/assets, skipped with a note when absent), the
// courtyard's walker and the production-shaped humanoid (builtin:humanoid: 65 joints, body and
// gear meshes traced together, a one-frame clip, so its pose space comes from the joints' roles;
// its walk, delivered apart, gives its clip poses).
//
// Per character: one set of reference poses (random, each joint independently within the pose
// space of the default settings, pose_space(), then 16 frames of each clip) is traced once, in
// batches, so that the bake time of the first N poses is measured; the clustered local models
// (the default, up to 8 per joint set) and the thesis' linear model (1 cluster) are fitted to the
// first N random poses plus the clip frames for each N (up to 8000); at the high preset's N
// (1000), the cluster count, locality and lambda are swept (locality and lambda on the linear
// model). Held-out poses:
// random poses of another seed and clip frames between the training frames, traced with more
// rays (their binomial standard error per vertex, averaged, is ref_stderr). Baselines from the
// same bake: bind-pose AO and the AO averaged over the reference poses. Models are evaluated as
// stored (16-bit coefficients, after a chunk round trip). ns_per_vertex: pose parameters +
// evaluate_pose_ao per frame on one thread, over the vertices (the best of many blocks of 10
// frames, each frame another random pose, so that the blends near cluster boundaries are paid as
// often as poses fall there). clusters: the most any joint set of the model uses (the fit chooses
// per set, up to the count asked for). lambda: the strongest ridge the fit tries (it takes lambda,
// a tenth or a hundredth of it for the character, by validation).
// Goals (issue 19), judged at the largest N, the ratios at the preset's N printed beside: the
// default model's RMSE <= 0.5x the better baseline on random and on clip poses alike, on CesiumMan
// and the humanoid, never worse than bind-pose AO; <= 5 ns per vertex on both (the walker's cost
// is printed beside it). The ratios are judged on the RMSE against the
// converged AO, sqrt(RMSE^2 - the references' mean variance), and printed beside the raw ones.
// A note per character says where the default model's random-pose error lies (error_by_part).
#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <functional>
#include <memory>
#include <numeric>
#include <string>
#include <vector>

#include "bench.h"
#include "penumbra/core/jobs.h"
#include "penumbra/core/memory.h"
#include "penumbra/ecs/transform.h"
#include "penumbra/pose_ao/joint_roles.h"
#include "penumbra/pose_ao/pose_ao_baker.h"
#include "penumbra/scene/animation.h"
#include "penumbra/scene/builtin.h"
#include "penumbra/import/gltf.h"
#include "checkout_paths.h"

namespace penumbra::bench {
namespace {

double seconds_since(std::chrono::steady_clock::time_point t) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t).count();
}

struct Character {
  std::string name;
  std::unique_ptr<World> world = std::make_unique<World>();
  Entity mesh;
};

Result<Character> load_character(const std::string& name, const std::string& spec) {
  Character c;
  c.name = name;
  auto loaded = load_scene(*c.world, spec);
  if (!loaded) return loaded.error();
  update_world_transforms(*c.world);
  update_skin_poses(*c.world);
  // The skinned mesh with the most vertices.
  std::size_t most = 0;
  for (Entity e : c.world->view<Skin, Mesh>().sorted_entities()) {
    const auto& data = c.world->get<Mesh>(e).data;
    if (data && data->positions.size() > most && data->joints.size() == data->positions.size()) {
      most = data->positions.size();
      c.mesh = e;
    }
  }
  if (!c.mesh) return make_error(ErrorCode::InvalidInput, spec + ": no skinned mesh");
  return c;
}

// Reference AO of the held-out poses.
struct HeldOut {
  std::vector<std::vector<float>> features, ao;  // per pose
  std::vector<bool> walk;                        // a clip frame (else random)
  std::vector<double> variance;                  // per pose, the mean over vertices of stderr^2
  double stderr_mean = 0.0;
  // The RMSE against the converged AO (the reference's own variance taken out, which it adds to
  // every error's square) of e over the set `which` (as errors()).
  double net(double rmse, int which) const {
    double v = 0.0;
    std::size_t n = 0;
    for (std::size_t p = 0; p < variance.size(); ++p)
      if (which == 0 || (which == 2) == walk[p]) {
        v += variance[p];
        ++n;
      }
    return std::sqrt(std::max(0.0, rmse * rmse - v / double(std::max<std::size_t>(n, 1))));
  }
};

struct Errors {
  double rmse = 0, mae = 0, max = 0;
};
Errors errors(const HeldOut& h, const std::function<void(const std::vector<float>&, std::vector<float>&)>& predict,
              int which) {  // which: 0 all, 1 random, 2 clip frames
  Errors e;
  std::size_t n = 0;
  std::vector<float> out;
  for (std::size_t p = 0; p < h.ao.size(); ++p) {
    if ((which == 1 && h.walk[p]) || (which == 2 && !h.walk[p])) continue;
    out.assign(h.ao[p].size(), 0.0f);
    predict(h.features[p], out);
    for (std::size_t v = 0; v < out.size(); ++v) {
      const double d = std::abs(double(out[v]) - h.ao[p][v]);
      e.rmse += d * d;
      e.mae += d;
      e.max = std::max(e.max, d);
      ++n;
    }
  }
  e.rmse = std::sqrt(e.rmse / double(std::max<std::size_t>(n, 1)));
  e.mae /= double(std::max<std::size_t>(n, 1));
  return e;
}

// Where a model's error on the random held-out poses lies, as a note: the vertex-poses whose
// reference is fully occluded (AO below kEnclosed: the vertex lies inside another part of the
// character, which the pose pushed through it; hidden itself, it still shades the visible part of
// its triangles, so the goal counts it), their share of the model's squared error and the
// model's ratio to the better baseline without them; then the body parts (vertices by their
// heaviest skinning joint) and the joints' roles of the largest shares, each with the model's RMSE
// over the pose average's there.
constexpr float kEnclosed = 0.02f;
std::string error_by_part(const HeldOut& h, const PoseAOData& d, const MeshData& mesh, const PoseRig& rig) {
  const std::size_t V = d.vertex_count, J = rig.joint_count();
  std::vector<std::size_t> part(V, 0);
  for (std::size_t v = 0; v < V; ++v) {
    float most = -1.0f;
    for (int c = 0; c < 4; ++c)
      if (mesh.weights[v][c] > most && mesh.joints[v][c] < J) {
        most = mesh.weights[v][c];
        part[v] = mesh.joints[v][c];
      }
  }
  std::vector<double> model(J, 0.0), average(J, 0.0);
  double enclosed = 0.0, open_model = 0.0, open_mean = 0.0, open_bind = 0.0, total = 0.0;
  std::size_t enclosed_count = 0, count = 0;
  std::vector<float> out(V);
  for (std::size_t p = 0; p < h.ao.size(); ++p) {
    if (h.walk[p]) continue;
    evaluate_pose_ao(d, h.features[p], out);
    for (std::size_t v = 0; v < V; ++v) {
      const double y = h.ao[p][v], e = (double(out[v]) - y) * (double(out[v]) - y);
      const double m = (double(d.mean_ao[v]) - y) * (double(d.mean_ao[v]) - y);
      model[part[v]] += e;
      average[part[v]] += m;
      total += e;
      ++count;
      if (h.ao[p][v] < kEnclosed) {
        enclosed += e;
        ++enclosed_count;
      } else {
        open_model += e;
        open_mean += m;
        open_bind += (double(d.bind_ao[v]) - y) * (double(d.bind_ao[v]) - y);
      }
    }
  }
  // The largest shares of the squared error, `shown` of them, over the groups named `name(i)`.
  const auto largest = [&](const std::vector<double>& error, const std::vector<double>& baseline, std::size_t shown,
                           auto name) {
    std::vector<std::size_t> order(error.size());
    std::iota(order.begin(), order.end(), std::size_t{0});
    std::sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return error[a] > error[b]; });
    std::string list;
    for (std::size_t i = 0; i < std::min(shown, order.size()) && error[order[i]] > 0.0; ++i)
      list += (list.empty() ? "" : ", ") + name(order[i]) + " " + fmt(100.0 * error[order[i]] / total, 2) + " % (" +
              fmt(std::sqrt(error[order[i]] / std::max(baseline[order[i]], 1e-30)), 2) + ")";
    return list;
  };
  // The same by the joints' roles (joint_roles.h), where their names give them.
  std::vector<JointRole> roles(J);
  for (std::size_t j = 0; j < J; ++j) roles[j] = joint_role(rig.names[j]);
  assign_chain_roles(rig.parents, roles);
  const std::size_t role_count = static_cast<std::size_t>(JointRole::End) + 1;
  std::vector<double> role_model(role_count, 0.0), role_average(role_count, 0.0);
  for (std::size_t j = 0; j < J; ++j) {
    role_model[static_cast<std::size_t>(roles[j])] += model[j];
    role_average[static_cast<std::size_t>(roles[j])] += average[j];
  }
  const std::string parts = largest(model, average, 6, [&](std::size_t j) {
    return rig.names[j].empty() ? "joint " + std::to_string(j) : rig.names[j];
  });
  const std::string by_role = largest(role_model, role_average, 4, [](std::size_t r) {
    return std::string(to_string(static_cast<JointRole>(r)));
  });
  return fmt(100.0 * double(enclosed_count) / double(std::max<std::size_t>(count, 1)), 2) +
         " % of the vertex-poses are fully occluded in the reference (AO < " + fmt(kEnclosed) +
         ": inside another part of the character) and hold " + fmt(100.0 * enclosed / std::max(total, 1e-30), 3) +
         " % of the clustered model's squared error; without them its RMSE is " +
         fmt(std::sqrt(open_model / std::max(std::min(open_mean, open_bind), 1e-30)), 3) +
         "x the better baseline's (references' noise included); largest shares by body part (model / pose "
         "average RMSE there): " + parts + "; by the joints' roles: " + by_role;
}

Result<Report> run(const Options& options) {
  ThreadPool pool(options.threads);
  JobContext jobs(&pool);
  const bool quick = options.quick;
  const std::vector<std::size_t> pose_counts = quick ? std::vector<std::size_t>{50, 100, 250}
                                                     : std::vector<std::size_t>{50, 100, 250, 500, 1000, 2000, 4000, 8000};
  // The settings are swept, and the goal's ratios also printed, at the high preset's count.
  const std::size_t preset_poses = quick ? 250 : SkinnedPoseAO::preset(Preset::High).reference_poses;
  const std::vector<std::uint32_t> localities = quick ? std::vector<std::uint32_t>{1, 2, 4} : std::vector<std::uint32_t>{0, 1, 2, 3, 4};
  const std::vector<float> lambdas = quick ? std::vector<float>{1e-4f, 1e-2f} : std::vector<float>{0.0f, 1e-4f, 1e-2f, 1e-1f};
  const std::uint32_t rays = quick ? 32 : 64, ref_rays = quick ? 128 : 512;
  const std::size_t held_random = quick ? 6 : 24, held_walk = quick ? 6 : 16;
  constexpr std::uint32_t kClipFrames = 16;
  const SkinnedPoseAO defaults;  // locality 4, up to 8 clusters, lambda 1e-3, margin 0.25
  const std::vector<std::uint32_t> cluster_counts = quick ? std::vector<std::uint32_t>{1, 4} : std::vector<std::uint32_t>{1, 2, 4, 8, 16};

  std::vector<std::pair<std::string, std::string>> specs;
  const std::string cesium = std::string(checkout::kSharedDir) + "/assets/CesiumMan.glb";
  Report report;
  if (std::filesystem::exists(cesium)) specs.emplace_back("CesiumMan", cesium);
  else report.notes.push_back("CesiumMan: " + cesium + " not found; its rows and goal are skipped");
  specs.emplace_back("walker", "builtin:courtyard");
  specs.emplace_back("humanoid", "builtin:humanoid");

  report.columns = {"character", "method", "poses", "locality", "clusters", "lambda", "bake_s", "bytes_per_vertex",
                    "ns_per_vertex", "rmse", "mae", "max_err", "ref_stderr", "curve"};
  report.plot = {"pose-AO: held-out RMSE against reference poses", "reference poses (random + 16 frames per clip)",
                 "RMSE of AO on held-out poses", 2, 9, 13, true, false, false};
  const auto verdict = [](bool pass) { return std::string(pass ? "PASS" : "FAIL"); };
  std::vector<std::string> goals;         // per character of the goal (CesiumMan, the humanoid)
  std::vector<std::string> preset_goals;  // the same ratios at the preset's pose count
  bool goals_pass = true;
  double worst_ns = 0.0;   // over the goal's characters (CesiumMan, the humanoid)
  std::string other_ns;    // the others' (the walker)

  for (const auto& entry : specs) {
    const auto& name = entry.first;  // not a structured binding: the lambdas below capture it
    const auto& spec = entry.second;
    auto c = load_character(name, spec);
    if (!c) return c.error();
    World& world = *c->world;
    const auto mesh = world.get<Mesh>(c->mesh).data;
    // The humanoid's file carries a one-frame clip; its walk comes apart, as a studio's animations
    // do (add_builtin_humanoid_walk), and gives its clip poses. Its random poses stay in the
    // ranges of its joints' roles (what a bake of the file alone samples).
    SkinnedPoseAO space_settings = defaults;
    if (name == "humanoid") {
      if (!add_builtin_humanoid_walk(world, world.view<Animator>().sorted_entities().front()))
        return make_error(ErrorCode::Internal, "humanoid: the walk found no joint to drive");
      space_settings.pose_source = SkinnedPoseAO::PoseSource::Roles;
    }
    auto rig = make_pose_rig(world, c->mesh, name);
    if (!rig) return rig.error();
    auto tracer = PoseAOTracer::create(mesh, rig->joint_count(), name, character_occluders(world, c->mesh));
    if (!tracer) return tracer.error();
    const std::size_t V = mesh->positions.size();
    const std::vector<JointRange> ranges = pose_space(*rig, space_settings).ranges;

    // Training: random poses in batches (timed), then the clip frames.
    PoseAOTraining tr;
    tr.vertex_count = V;
    tr.joint_count = rig->joint_count();
    tr.bind_ao.resize(V);
    auto t0 = std::chrono::steady_clock::now();
    PENUMBRA_TRY(tracer->trace(std::vector<glm::mat4>(rig->joint_count(), glm::mat4(1.0f)), rays, 1, jobs, tr.bind_ao));
    const double bind_s = seconds_since(t0);
    double trace_s = bind_s;
    std::vector<double> trace_seconds;  // time of the first pose_counts[i] random poses + bind
    for (std::size_t n : pose_counts) {
      t0 = std::chrono::steady_clock::now();
      for (std::size_t p = tr.poses(); p < n; ++p)
        PENUMBRA_TRY(tr.add_pose(*tracer, *rig, random_pose(*rig, ranges, 1, p), rays, 1, jobs));
      trace_s += seconds_since(t0);
      trace_seconds.push_back(trace_s);
    }
    PoseAOTraining clips;  // the clip frames, appended to each subset
    clips.vertex_count = V;
    clips.joint_count = rig->joint_count();
    t0 = std::chrono::steady_clock::now();
    for (std::size_t ci = 0; ci < rig->clips.size(); ++ci)
      for (std::uint32_t k = 0; k < kClipFrames; ++k)
        PENUMBRA_TRY(clips.add_pose(*tracer, *rig,
                                    clip_pose(*rig, ci, rig->clips[ci]->duration * (float(k) + 0.5f) / float(kClipFrames)),
                                    rays, 1, jobs));
    const double clip_s = seconds_since(t0);
    const auto subset = [&](std::size_t n) {
      PoseAOTraining s;
      s.vertex_count = V;
      s.joint_count = tr.joint_count;
      s.bind_ao = tr.bind_ao;
      const std::size_t F = tr.joint_count * kPoseFeaturesPerJoint;
      s.features.assign(tr.features.begin(), tr.features.begin() + std::ptrdiff_t(n * F));
      s.ao.assign(tr.ao.begin(), tr.ao.begin() + std::ptrdiff_t(n * V));
      s.features.insert(s.features.end(), clips.features.begin(), clips.features.end());
      s.ao.insert(s.ao.end(), clips.ao.begin(), clips.ao.end());
      return s;
    };

    // Held-out poses: random (another seed) and clip frames at the training frames' edges.
    HeldOut held;
    std::vector<float> se(V), ao(V), f;
    double se_sum = 0.0;
    const auto add_held = [&](const Pose& pose, bool walk) -> Status {
      const std::vector<glm::mat4> m = skinning_matrices(*rig, pose);
      PENUMBRA_TRY(tracer->trace(m, ref_rays, 1000, jobs, ao, se));
      pose_features(rig->parents, m, f);
      held.features.push_back(f);
      held.ao.push_back(ao);
      held.walk.push_back(walk);
      double variance = 0.0;
      for (float s : se) {
        se_sum += s;
        variance += double(s) * s;
      }
      held.variance.push_back(variance / double(V));
      return {};
    };
    for (std::size_t p = 0; p < held_random; ++p) PENUMBRA_TRY(add_held(random_pose(*rig, ranges, 2024, p), false));
    for (std::size_t ci = 0; ci < rig->clips.size(); ++ci)
      for (std::size_t k = 0; k < held_walk; ++k)
        PENUMBRA_TRY(add_held(clip_pose(*rig, ci, rig->clips[ci]->duration * float(k) / float(held_walk)), true));
    held.stderr_mean = se_sum / double(held.ao.size() * V);

    const auto row = [&](const std::string& method, std::size_t poses, std::string locality, std::string clusters,
                         std::string lambda, double bake_s, double bytes, double ns, const Errors& e,
                         const std::string& curve) {
      report.rows.push_back({name, method, std::to_string(poses), std::move(locality), std::move(clusters),
                             std::move(lambda), fmt(bake_s), fmt(bytes), fmt(ns), fmt(e.rmse), fmt(e.mae), fmt(e.max),
                             fmt(held.stderr_mean), curve});
    };
    const Errors bind_err = errors(held, [&](const std::vector<float>&, std::vector<float>& out) { out = tr.bind_ao; }, 0);

    // Fit, store as halves, evaluate; returns the stored model's errors.
    struct Fit {
      PoseAOData data;
      double fit_s = 0;
    };
    const auto fit = [&](std::size_t n, std::uint32_t locality, std::uint32_t clusters, float lambda) -> Result<Fit> {
      SkinnedPoseAO s = defaults;
      s.locality = locality;
      s.clusters = clusters;
      s.lambda = lambda;
      s.rays_per_vertex = rays;
      const PoseAOTraining sub = subset(n);
      const auto start = std::chrono::steady_clock::now();
      auto data = fit_pose_ao(sub, *rig, *mesh, s, 0, jobs, nullptr, name);
      if (!data) return data.error();
      const double fit_s = seconds_since(start);
      auto stored = read_pose_ao_chunk(write_pose_ao_chunk(*data));
      if (!stored) return stored.error();
      return Fit{std::move(*stored), fit_s};
    };
    const auto predict = [](const PoseAOData& d) {
      return [&d](const std::vector<float>& features, std::vector<float>& out) { evaluate_pose_ao(d, features, out); };
    };
    std::vector<std::vector<glm::mat4>> frames;  // ten random poses, one per frame of a block
    for (std::uint64_t i = 0; i < 10; ++i) frames.push_back(skinning_matrices(*rig, random_pose(*rig, ranges, 5, i)));
    const auto measure_ns = [&](const PoseAOData& d, Isa isa = Isa::Best) {
      std::vector<float> out(V), features = held.features.front();
      // The best of many short timed blocks (10 frames each, ~0.1 ms): the machine is shared, and
      // a block that another process preempts only reads slower, so the minimum is the cost of a
      // frame that has the core to itself.
      double best = 1e300;
      for (int block = 0; block < (quick ? 300 : 2000); ++block) {
        const auto start = std::chrono::steady_clock::now();
        for (const auto& m : frames) {
          pose_features(d.joint_parents, m, features);
          evaluate_pose_ao(d, features, out, isa);
          benchmark::DoNotOptimize(out.data());
        }
        best = std::min(best, seconds_since(start) * 1e9 / 10.0);
      }
      return best / double(V);
    };

    for (std::size_t i = 0; i < pose_counts.size(); ++i) {
      const std::size_t n = pose_counts[i];
      const std::size_t total = n + clips.poses();
      const double bake_base = trace_seconds[i] + clip_s;
      // The default model (clustered), the thesis' linear model, and the baselines of these poses.
      auto main = fit(n, defaults.locality, defaults.clusters, defaults.lambda);
      if (!main) return main.error();
      auto linear = fit(n, defaults.locality, 1, defaults.lambda);
      if (!linear) return linear.error();
      const PoseAOData& d = main->data;
      const PoseAOData& dl = linear->data;
      const Errors clustered_err = errors(held, predict(d), 0);
      const double default_ns = measure_ns(d);
      if (i + 1 == pose_counts.size()) {
        if (name == "CesiumMan" || name == "humanoid")
          worst_ns = std::max(worst_ns, default_ns);
        else
          other_ns += (other_ns.empty() ? "" : ", ") + name + " " + fmt(default_ns, 3);
        report.notes.push_back(name + ": the default model's portable loop (CPUs without AVX2, FMA and F16C) " +
                               fmt(measure_ns(d, Isa::Portable), 3) + " ns per vertex against " +
                               fmt(default_ns, 3) + " for the wide one");
      }
      // Errors of a baseline (AO that ignores the pose) on held-out set `which` (0 all, 1 random, 2 clip).
      const auto baseline_errors = [&](const std::vector<float>& baseline, int which) {
        return errors(held, [&](const std::vector<float>&, std::vector<float>& o) { o = baseline; }, which);
      };
      const Errors mean = baseline_errors(d.mean_ao, 0);
      row("clustered", total, std::to_string(d.locality), std::to_string(d.clusters), fmt(defaults.lambda),
          bake_base + main->fit_s, d.bytes_per_vertex(), default_ns, clustered_err,
          name + " clustered");
      row("linear", total, std::to_string(dl.locality), "1", fmt(defaults.lambda), bake_base + linear->fit_s,
          dl.bytes_per_vertex(), measure_ns(dl), errors(held, predict(dl), 0), name + " linear");
      row("mean", total, "-", "-", "-", bake_base, 2.0, 0.0, mean, name + " pose average");
      row("bind", total, "-", "-", "-", bind_s, 2.0, 0.0, bind_err, name + " bind pose");

      // Per held-out set (1 random, 2 clip): the default model's errors and the baselines'.
      const Errors c_r = errors(held, predict(d), 1), c_w = errors(held, predict(d), 2);
      const Errors mean_r = baseline_errors(d.mean_ao, 1), mean_w = baseline_errors(d.mean_ao, 2);
      const Errors bind_r = baseline_errors(tr.bind_ao, 1), bind_w = baseline_errors(tr.bind_ao, 2);
      if (name == "CesiumMan" || name == "humanoid") {
        // The goal: each held-out set against its own better baseline, and never worse than
        // bind-pose AO, judged on the errors against the converged AO (the references' noise adds
        // its variance to the square of the model's error and of the baseline's alike, which pulls
        // the ratio towards 1); judged at the largest pose count, printed at the preset's too.
        const double net_random = held.net(c_r.rmse, 1) / std::min(held.net(mean_r.rmse, 1), held.net(bind_r.rmse, 1));
        const double net_clip = held.net(c_w.rmse, 2) / std::min(held.net(mean_w.rmse, 2), held.net(bind_w.rmse, 2));
        const bool no_worse = c_r.rmse <= bind_r.rmse && c_w.rmse <= bind_w.rmse;
        const std::string ratios =
            name + " at " + std::to_string(total) + " poses: random " + fmt(net_random, 3) + " (" +
            fmt(c_r.rmse / std::min(mean_r.rmse, bind_r.rmse), 3) + " with the references' noise), clip " +
            fmt(net_clip, 3) + " (" + fmt(c_w.rmse / std::min(mean_w.rmse, bind_w.rmse), 3) + ")" +
            (no_worse ? "" : ", worse than bind-pose AO");
        if (i + 1 == pose_counts.size()) {
          goals_pass = goals_pass && net_random <= 0.5 && net_clip <= 0.5 && no_worse;
          goals.push_back(ratios);
        } else if (n == preset_poses) {
          preset_goals.push_back(ratios);
        }
      }

      if (i + 1 == pose_counts.size()) {
        // Notes at the largest pose count.
        const Errors l_r = errors(held, predict(dl), 1), l_w = errors(held, predict(dl), 2);
        const double better_r = std::min(mean_r.rmse, bind_r.rmse), better_w = std::min(mean_w.rmse, bind_w.rmse);
        std::size_t clustered_vertices = 0;
        for (const PoseAOGroup& g : d.groups) clustered_vertices += g.cluster_count > 1 ? g.count : 0;
        report.notes.push_back(
            name + " (" + std::to_string(V) + " vertices, " + std::to_string(rig->joint_count()) + " joints), " +
            std::to_string(total) + " poses: held-out RMSE random/clip: clustered " + fmt(c_r.rmse, 3) + "/" +
            fmt(c_w.rmse, 3) + " (" + std::to_string(clustered_vertices) + " vertices in joint sets of 2-" +
            std::to_string(d.clusters) + " clusters, ridge strength " + fmt(d.lambda, 2) + "), linear " +
            fmt(l_r.rmse, 3) + "/" + fmt(l_w.rmse, 3) + " (strength " + fmt(dl.lambda, 2) + ")" +
            ", pose average " + fmt(mean_r.rmse, 3) + "/" + fmt(mean_w.rmse, 3) + ", bind pose " + fmt(bind_r.rmse, 3) +
            "/" + fmt(bind_w.rmse, 3) + "; against the better baseline: clustered " + fmt(c_r.rmse / better_r, 3) + "/" +
            fmt(c_w.rmse / better_w, 3) + ", linear " + fmt(l_r.rmse / better_r, 3) + "/" + fmt(l_w.rmse / better_w, 3) +
            " (reference standard error " + fmt(held.stderr_mean, 2) + ")");
        report.notes.push_back(name + ", random held-out poses: " + error_by_part(held, d, *mesh, *rig));
        // Motion along the clips at 60 frames per second: each vertex's AO change from one frame to
        // the next, by the models and by tracing (ref_rays / 2 rays, the scramble fixed per vertex
        // so noise barely moves between frames): the largest and the 99.9th percentile change, and
        // the RMS difference between a model's change and the traced one (how well it follows the
        // motion; a jump at a cluster boundary that the AO does not make would show here).
        if (!rig->clips.empty()) {
          struct Motion {
            std::vector<float> previous, current;
            std::vector<double> changes;
          };
          Motion traced_ao, clustered_ao, linear_ao;
          double follow_clustered = 0.0, follow_linear = 0.0;
          std::vector<float> features;
          for (std::size_t ci = 0; ci < rig->clips.size(); ++ci) {
            const int clip_frames = std::max(2, static_cast<int>(rig->clips[ci]->duration * 60.0f));
            for (int k = 0; k < clip_frames; ++k) {
              const std::vector<glm::mat4> m = skinning_matrices(*rig, clip_pose(*rig, ci, float(k) / 60.0f));
              for (Motion* motion : {&traced_ao, &clustered_ao, &linear_ao}) motion->current.resize(V);
              PENUMBRA_TRY(tracer->trace(m, ref_rays / 2, 7, jobs, traced_ao.current));
              pose_features(rig->parents, m, features);
              evaluate_pose_ao(d, features, clustered_ao.current);
              evaluate_pose_ao(dl, features, linear_ao.current);
              if (k > 0)
                for (std::size_t v = 0; v < V; ++v) {
                  const double t = double(traced_ao.current[v]) - traced_ao.previous[v];
                  const double cl = double(clustered_ao.current[v]) - clustered_ao.previous[v];
                  const double li = double(linear_ao.current[v]) - linear_ao.previous[v];
                  traced_ao.changes.push_back(std::abs(t));
                  clustered_ao.changes.push_back(std::abs(cl));
                  linear_ao.changes.push_back(std::abs(li));
                  follow_clustered += (cl - t) * (cl - t);
                  follow_linear += (li - t) * (li - t);
                }
              for (Motion* motion : {&traced_ao, &clustered_ao, &linear_ao})
                std::swap(motion->previous, motion->current);
            }
          }
          const auto stats = [](std::vector<double>& changes) {
            std::sort(changes.begin(), changes.end());
            return fmt(changes.back(), 3) + " (99.9 %: " + fmt(changes[changes.size() * 999 / 1000], 3) + ")";
          };
          const double changes = static_cast<double>(traced_ao.changes.size());
          report.notes.push_back(name + ": AO change of a vertex between frames 1/60 s apart along the clips, the largest: "
                                        "traced " + stats(traced_ao.changes) + ", clustered " +
                                 stats(clustered_ao.changes) + ", linear " + stats(linear_ao.changes) +
                                 "; RMS of the model's change minus the traced: "
                                 "clustered " + fmt(std::sqrt(follow_clustered / changes), 3) + ", linear " +
                                 fmt(std::sqrt(follow_linear / changes), 3));
        }
      }
      if (n == preset_poses) {
        // Sweeps at the preset's pose count: the cluster count (locality 4), then locality and
        // lambda of the linear model.
        for (std::uint32_t clusters : cluster_counts) {
          if (clusters == 1 || clusters == defaults.clusters) continue;
          auto sweep = fit(n, defaults.locality, clusters, defaults.lambda);
          if (!sweep) return sweep.error();
          row("clustered", total, std::to_string(sweep->data.locality), std::to_string(sweep->data.clusters),
              fmt(defaults.lambda), bake_base + sweep->fit_s, sweep->data.bytes_per_vertex(),
              measure_ns(sweep->data), errors(held, predict(sweep->data), 0),
              name + " clusters at " + std::to_string(total) + " poses");
        }
        for (std::uint32_t k : localities)
          for (float lambda : lambdas) {
            if (k == defaults.locality && lambda == defaults.lambda) continue;
            auto sweep = fit(n, k, 1, lambda);
            if (!sweep) return sweep.error();
            row("linear", total, std::to_string(sweep->data.locality), "1", fmt(lambda), bake_base + sweep->fit_s,
                sweep->data.bytes_per_vertex(), measure_ns(sweep->data), errors(held, predict(sweep->data), 0),
                name + " sweeps at " + std::to_string(total) + " poses");
          }
      }
    }
  }

  const auto joined = [](const std::vector<std::string>& list) {
    std::string all;
    for (const std::string& g : list) all += (all.empty() ? "" : "; ") + g;
    return all;
  };
  if (!goals.empty())
    report.notes.push_back("goal: held-out RMSE against the converged AO, clustered (locality 4, up to 8 clusters, "
                           "lambda 1e-3) / the better baseline of each set: " +
                           joined(goals) + " (<= 0.5 and never worse than bind-pose AO: " + verdict(goals_pass) +
                           ")" + (preset_goals.empty() ? "" : "; at the high preset's count: " + joined(preset_goals)));
  report.notes.push_back("goal: per-frame CPU cost on CesiumMan and the humanoid " + fmt(worst_ns, 3) +
                         " ns per vertex at worst, on one thread, locality 4, up to 8 clusters (<= 5: " +
                         verdict(worst_ns <= 5.0) + ")" + (other_ns.empty() ? "" : "; not judged: " + other_ns));
  return report;
}

}  // namespace

PENUMBRA_BENCH("pose-ao", "skinned pose-AO: held-out error vs ray-traced AO against bind-pose and pose-averaged AO, "
               "by reference poses, locality and lambda; bake s, bytes and ns per vertex", run);

}  // namespace penumbra::bench
