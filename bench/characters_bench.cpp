// `penumbra bench characters`: what animated characters cost the runtime systems per frame, with
// 1, 10 and 50 of them walking circles in the courtyard (the sample game courtyard_walk's load),
// for the built-in walker and, when ../shared/assets holds it, CesiumMan. The worlds are stepped
// in turn, frame by frame, so that the counts are measured side by side under the same load; the
// time is each system's own (World::systems()), summed over the systems per frame.
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "bench.h"
#include "penumbra/bakers.h"
#include "penumbra/bake/baker.h"
#include "penumbra/core/jobs.h"
#include "penumbra/ecs/transform.h"
#include "penumbra/import/gltf.h"
#include "penumbra/pose_ao/pose_ao_system.h"
#include "penumbra/runtime.h"
#include "penumbra/scene/builtin.h"
#include "penumbra/scene/components.h"
#include "penumbra/scene/entity_key.h"
#include "checkout_paths.h"

namespace penumbra::bench {
namespace {


struct Crowd {
  std::unique_ptr<World> world = std::make_unique<World>();
  std::vector<Entity> roots;
  std::map<std::string, double> ms;  // per system, summed over the measured frames
  int frames = 0;
};

// The courtyard without its walker, with `count` characters of `model` (empty: the built-in one)
// on a ring of circles; everything but pose-AO baked at draft; pose-AO taken from `shared` (the
// first crowd's player) or baked here when it is null.
Result<Crowd> make_crowd(const std::string& model, int count, const Crowd* shared) {
  Crowd c;
  World& w = *c.world;
  register_lighting(w);
  register_bakers(w);
  if (auto scene = load_builtin(w, "courtyard"); !scene) return scene.error();
  w.view<const Name, const Animator>().each([&](Entity e, const Name& n, const Animator&) {
    if (n.value == "character") c.roots.push_back(e);
  });
  for (Entity e : c.roots) destroy_hierarchy(w, e);
  c.roots.clear();
  for (int i = 0; i < count; ++i) {
    Transform at;
    at.translation = glm::vec3(-6.0f + 1.5f * static_cast<float>(i % 10), 0.0f, -2.0f + 1.5f * static_cast<float>(i / 10));
    const std::string name = "walker " + std::to_string(i);
    if (model.empty()) {
      c.roots.push_back(add_builtin_character(w, Entity::null(), at, name));
    } else {
      auto imported = import_gltf(w, model);
      if (!imported) return imported.error();
      w.add<EntityKey>(imported->root, EntityKey{name});
      w.add<Transform>(imported->root, at);
      c.roots.push_back(imported->root);
    }
  }
  w.update(0.0);
  PENUMBRA_TRY(add_default_lighting(w, Preset::Draft, /*authored=*/false));
  BakeSettings settings;
  settings.preset = Preset::Draft;
  ThreadPool pool;
  JobContext jobs(&pool);
  std::vector<std::string> bakers = {"probe-grid", "ao-field"};
  if (!shared) bakers.push_back("pose-ao");
  if (auto baked = bake_world(w, bakers, settings, jobs); !baked) return baked.error();
  if (shared)
    for (Entity root : c.roots) share_pose_ao(*shared->world, shared->roots.front(), w, root);
  return c;
}

// One frame: every character a step along its circle, then the update; the systems' times added.
void step(Crowd& c, int frame, bool measure) {
  World& w = *c.world;
  const float t = static_cast<float>(frame) / 30.0f;
  for (std::size_t i = 0; i < c.roots.size(); ++i) {
    const float a = 0.9f * t + static_cast<float>(i);
    Transform& tr = w.patch<Transform>(c.roots[i]);
    const glm::vec3 centre(-6.0f + 1.5f * static_cast<float>(i % 10), 0.0f, -2.0f + 1.5f * static_cast<float>(i / 10));
    tr.translation = centre + 0.5f * glm::vec3(std::cos(a), 0.0f, std::sin(a));
  }
  w.update(1.0 / 30.0);
  if (!measure) return;
  for (const SystemInfo& s : w.systems()) c.ms[s.name] += s.last_ms;
  ++c.frames;
}

Result<Report> run(const Options& options) {
  Report r;
  r.columns = {"model", "characters", "ms_per_frame", "us_per_character", "by_system_ms"};
  std::vector<std::pair<std::string, std::string>> models = {{"built-in walker", ""}};
  const std::string cesium = std::string(checkout::kSharedDir) + "/assets/CesiumMan.glb";
  if (std::filesystem::exists(cesium)) models.push_back({"CesiumMan", cesium});
  else r.notes.push_back("CesiumMan rows skipped: " + cesium + " is absent");
  const std::vector<int> counts = options.quick ? std::vector<int>{1, 10} : std::vector<int>{1, 10, 50};
  const int frames = options.quick ? 20 : 150, warmup = 10;
  for (const auto& [label, path] : models) {
    std::vector<Crowd> crowds;
    for (int n : counts) {
      auto crowd = make_crowd(path, n, crowds.empty() ? nullptr : &crowds.front());
      if (!crowd) return crowd.error();
      crowds.push_back(std::move(*crowd));
    }
    // Interleaved: frame k of every crowd before frame k + 1 of any.
    for (int k = 0; k < warmup + frames; ++k)
      for (Crowd& c : crowds) step(c, k, k >= warmup);
    std::vector<double> totals;
    for (std::size_t i = 0; i < crowds.size(); ++i) {
      const Crowd& c = crowds[i];
      double total = 0.0;
      std::string by_system;
      for (const auto& [system, ms] : c.ms) {
        const double per_frame = ms / c.frames;
        total += per_frame;
        by_system += (by_system.empty() ? "" : "; ") + system + " " + fmt(per_frame, 3);
      }
      r.rows.push_back({label, std::to_string(counts[i]), fmt(total), fmt(1000.0 * total / counts[i]), by_system});
      totals.push_back(total);
    }
    std::string note = label + ": all systems " + fmt(totals.front(), 3) + " ms per frame with 1 character";
    for (std::size_t i = 1; i < totals.size(); ++i)
      note += ", " + fmt(totals[i] / totals.front(), 3) + "x that with " + std::to_string(counts[i]) + " (" +
              fmt(1000.0 * totals[i] / counts[i], 3) + " us per character)";
    r.notes.push_back(note + "; measured side by side, " + std::to_string(frames) +
                      " frames each (no goal is set: the content issue asks for these figures)");
  }
  r.plot = {"Runtime systems' CPU time per frame against characters", "characters", "ms per frame (all systems)",
            1, 2, 0, true, true, false};
  return r;
}

}  // namespace

PENUMBRA_BENCH("characters", "the runtime systems' CPU ms per frame with 1, 10 and 50 animated characters in the "
               "courtyard (built-in walker, CesiumMan), side by side",
               run);

}  // namespace penumbra::bench
