// penumbra bench shards: how evenly a sharded bake splits, per baker, and what the merge costs.
// The courtyard (every module's default components) is baked whole, then for N = 1..16 shards each
// shard is baked in turn from a freshly loaded scene (as a farm node would: load, plan, bake its
// items) and the parts merged. Per baker: the largest shard's share of the summed shard time
// (1/N is perfect balance), the merge's time (the global steps), the ideal speed-up on N machines,
// T_whole / (T_largest shard + T_merge), and whether the merged file is the whole bake's bytes.
// One thread everywhere (unless --threads), so that times measure work rather than the pool.
#include <algorithm>
#include <map>

#include "bench.h"
#include "penumbra/bake/shard.h"
#include "penumbra/bakers.h"
#include "penumbra/runtime.h"
#include "penumbra/scene/builtin.h"

namespace penumbra::bench {
namespace {

Result<World> courtyard(Preset preset) {
  World world;
  register_lighting(world);
  register_bakers(world);
  if (auto s = load_builtin(world, "courtyard"); !s) return s.error();
  world.update(0.0);
  PENUMBRA_TRY(add_default_lighting(world, preset, false));
  return world;
}

Result<Report> shards_bench(const Options& options) {
  const Preset preset = options.quick ? Preset::Draft : Preset::Medium;
  const std::vector<std::uint32_t> counts = options.quick ? std::vector<std::uint32_t>{1, 2, 4}
                                                          : std::vector<std::uint32_t>{1, 2, 4, 8, 16};
  BakeSettings settings;
  settings.preset = preset;
  ThreadPool pool(options.threads == 0 ? 1 : options.threads);

  auto whole_world = courtyard(preset);
  if (!whole_world) return whole_world.error();
  // The whole bake twice, each baker's faster time kept (the first run also warms the caches).
  JobContext jobs(&pool);
  auto whole = bake_world(*whole_world, {}, settings, jobs);
  if (!whole) return whole.error();
  auto again = bake_world(*whole_world, {}, settings, jobs);
  if (!again) return again.error();
  std::map<std::string, double> whole_seconds;
  std::vector<std::string> bakers;
  for (std::size_t b = 0; b < whole->report.items.size(); ++b) {
    const auto& item = whole->report.items[b];
    whole_seconds[item.baker] = std::min(item.seconds, again->report.items[b].seconds);
    bakers.push_back(item.baker);
  }
  bool all_identical = true;
  std::string balance;

  Report report;
  report.columns = {"baker", "shards", "items", "largest_share", "ideal_share", "merge_s", "whole_s", "ideal_speedup",
                    "identical"};
  std::vector<std::string> speedups;
  for (std::uint32_t n : counts) {
    // Per baker and shard: the shard's time for that baker (its plan and its items).
    std::map<std::string, std::vector<double>> shard_seconds;
    std::map<std::string, std::size_t> items;
    std::vector<NamedPart> parts;
    for (std::uint32_t i = 0; i < n; ++i) {
      auto world = courtyard(preset);
      if (!world) return world.error();
      JobContext shard_jobs(&pool);
      auto part = bake_shard(*world, {}, settings, ShardSpec{i, n}, "builtin:courtyard", shard_jobs);
      if (!part) return part.error();
      for (const auto& item : part->report.items) shard_seconds[item.baker].push_back(item.seconds);
      auto parsed = read_bake_part(part->file, "part " + std::to_string(i));
      if (!parsed) return parsed.error();
      for (const auto& item : parsed->items) ++items[parsed->bakers[item.baker].name];
      parts.push_back({"part_" + std::to_string(i), std::move(*parsed)});
    }
    World registry;
    register_bakers(registry);
    JobContext merge_jobs(&pool);
    MergeReport merge_report;
    auto merged = merge_bake_parts(registry.resource<BakerRegistry>(), parts, merge_jobs, &merge_report);
    if (!merged) return merged.error();
    std::map<std::string, double> merge_seconds;
    for (const auto& item : merge_report.items) merge_seconds[item.baker] = item.seconds;
    // The merged chunks against the whole bake's, per baker (chunk labels start with the baker).
    for (const std::string& baker : bakers) {
      const auto of = [&](const BakeFile& f) {
        std::vector<const BakeChunk*> out;
        for (const BakeChunk& c : f.chunks)
          if (c.label.starts_with(baker + ":")) out.push_back(&c);
        return out;
      };
      const auto a = of(whole->file), b = of(*merged);
      bool identical = a.size() == b.size() && merged->input_hash == whole->file.input_hash;
      for (std::size_t k = 0; identical && k < a.size(); ++k)
        identical = a[k]->type == b[k]->type && a[k]->version == b[k]->version && a[k]->label == b[k]->label &&
                    a[k]->payload == b[k]->payload;
      const std::vector<double>& t = shard_seconds[baker];
      double sum = 0.0, largest = 0.0;
      for (double s : t) {
        sum += s;
        largest = std::max(largest, s);
      }
      const double speedup = whole_seconds[baker] / (largest + merge_seconds[baker]);
      report.rows.push_back({baker, std::to_string(n), std::to_string(items[baker]), fmt(sum > 0 ? largest / sum : 1.0),
                             fmt(1.0 / n), fmt(merge_seconds[baker]), fmt(whole_seconds[baker]), fmt(speedup),
                             identical ? "yes" : "NO"});
      all_identical = all_identical && identical;
      if (n == counts.back()) balance += (balance.empty() ? "" : ", ") + baker + " " + fmt(n * largest / sum, 3);
      if (n == counts.back())
        speedups.push_back(baker + " " + fmt(speedup, 3) + "x (largest shard " + fmt(largest, 3) + " s + merge " +
                           fmt(merge_seconds[baker], 3) + " s against " + fmt(whole_seconds[baker], 3) + " s whole)");
    }
  }
  report.plot = Plot{"largest shard's share of the bake work (1/N: perfect balance)", "shards", "largest share", 1, 3,
                     0, true, true};
  report.notes.push_back(std::string("courtyard, preset ") + to_string(preset) + ", shards baked one after another "
                         "on this machine, each from a freshly loaded scene, " + std::to_string(pool.concurrency()) +
                         " thread(s); a shard's time per baker includes its plan (rig, per-caster BVHs), which every "
                         "shard repeats, so small bakers stop scaling early");
  std::string ideal = "ideal speed-up on " + std::to_string(counts.back()) + " machines, T_whole / (T_largest + T_merge): ";
  for (std::size_t i = 0; i < speedups.size(); ++i) ideal += (i ? "; " : "") + speedups[i];
  report.notes.push_back(ideal);
  report.notes.push_back("balance at " + std::to_string(counts.back()) + " shards, largest shard / mean shard (1 is "
                         "perfect): " + balance);
  report.notes.push_back(std::string("goal: every merged file byte-identical to the whole bake, per baker and shard "
                                     "count: ") + (all_identical ? "PASS" : "FAIL"));
  return report;
}

}  // namespace

PENUMBRA_BENCH("shards", "sharded bakes: per baker the largest shard's share, merge time and ideal speed-up for 1-16 "
                         "shards, merged bytes against the whole bake",
               shards_bench);

}  // namespace penumbra::bench
