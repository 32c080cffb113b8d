// Bake estimates from measured samples (penumbra/bake/estimate.h).
#include "penumbra/bake/estimate.h"

#include <algorithm>
#include <chrono>
#include <cstring>

#include "drive.h"

namespace penumbra {

namespace {

// One group's samples: each sampled range's first element and its results.
struct Sampled {
  std::vector<std::uint64_t> begin;
  std::vector<std::vector<std::byte>> results;
  std::uint64_t length = 0;  // elements per range
};

}  // namespace

double BakeEstimate::seconds() const {
  double total = ray_scene_seconds;
  for (const Item& item : items) total += item.seconds;
  return total;
}

Result<BakeEstimate> estimate_bake(World& world, const std::vector<std::string>& names, const BakeSettings& settings,
                                   JobContext& jobs, std::uint32_t ranges) {
  auto bakers = select_bakers(world.resource<BakerRegistry>(), names);
  if (!bakers) return bakers.error();
  if (bakers->empty()) return make_error(ErrorCode::NotFound, "no baker is registered; link a lighting module");
  ranges = std::max(ranges, 1u);

  BakeEstimate estimate;
  BakeReport report;
  std::vector<double> step_seconds;  // per baker: the sampling, to tell plan()'s time apart
  PENUMBRA_TRY(drive_bake(world, *bakers, settings, jobs, report,
                          [&](const Baker& b, BakeWork& work, BakeReport::Item&) -> Status {
    const auto step_start = std::chrono::steady_clock::now();
    BakeEstimate::Item item;
    item.baker = b.name;
    std::vector<Sampled> samples(work.groups.size());
    bool fixed_size = true;
    std::vector<std::uint64_t> element_bytes(work.groups.size(), 0);
    for (std::size_t g = 0; g < work.groups.size(); ++g) {
      const BakeGroup& group = work.groups[g];
      BakeEstimate::Group out{b.name, group.name, group.elements, 0, 0.0};
      if (group.elements == 0) {
        estimate.groups.push_back(std::move(out));
        continue;
      }
      // Ranges long enough for every worker (at least a block), spread evenly; all of a small group.
      Sampled& s = samples[g];
      s.length = std::min<std::uint64_t>(group.elements, std::max<std::uint64_t>(group.block, 4ull * jobs.concurrency()));
      if (group.elements <= std::uint64_t{ranges} * s.length) s.length = group.elements;  // small: all of it
      const std::uint64_t count = std::min<std::uint64_t>(ranges, group.elements / s.length);
      double seconds = 0.0;
      for (std::uint64_t r = 0; r < count; ++r) {
        // Range r starts at the r-th of `count` equal parts, so the ranges never overlap.
        const std::uint64_t begin = r * (group.elements / count);
        const std::uint64_t end = r + 1 == count && count * s.length >= group.elements ? group.elements : begin + s.length;
        const auto start = std::chrono::steady_clock::now();
        auto results = work.run(g, begin, end, jobs);
        if (!results) return results.error();
        seconds += seconds_since(start);
        out.sampled += end - begin;
        if (results->size() % (end - begin) != 0) fixed_size = false;
        const std::uint64_t per = results->size() / (end - begin);
        if (r > 0 && per != element_bytes[g]) fixed_size = false;
        element_bytes[g] = per;
        s.begin.push_back(begin);
        s.results.push_back(std::move(*results));
      }
      out.seconds = seconds / static_cast<double>(out.sampled) * static_cast<double>(group.elements);
      item.seconds += out.seconds;
      estimate.groups.push_back(std::move(out));
    }
    const double sampling = seconds_since(step_start);
    // finish() on the extrapolated results: element e takes the nearest sampled element's bytes.
    if (fixed_size) {
      std::vector<std::vector<std::byte>> results(work.groups.size());
      for (std::size_t g = 0; g < work.groups.size(); ++g) {
        const Sampled& s = samples[g];
        const std::uint64_t per = element_bytes[g], elements = work.groups[g].elements;
        if (elements == 0) continue;
        results[g].resize(elements * per);
        for (std::uint64_t e = 0; e < elements; ++e) {
          // The range holding or nearest to e, and the element of it nearest to e.
          std::size_t best = 0;
          std::uint64_t best_distance = ~0ull;
          for (std::size_t r = 0; r < s.begin.size(); ++r) {
            const std::uint64_t first = s.begin[r], last = first + s.results[r].size() / std::max<std::uint64_t>(per, 1) - 1;
            const std::uint64_t d = e < first ? first - e : e > last ? e - last : 0;
            if (d < best_distance) best_distance = d, best = r;
          }
          const std::uint64_t first = s.begin[best], last = first + s.results[best].size() / std::max<std::uint64_t>(per, 1) - 1;
          const std::uint64_t at = std::clamp(e, first, last) - first;
          if (per > 0) std::memcpy(results[g].data() + e * per, s.results[best].data() + at * per, per);
        }
      }
      const auto start = std::chrono::steady_clock::now();
      auto chunks = finish_groups(b, work.groups, results, jobs);
      if (!chunks) return Error{chunks.error().code, "finish on the sampled results: " + chunks.error().message};
      item.finish_seconds = seconds_since(start);
      std::uint64_t bytes = 0;
      for (const BakeChunk& c : *chunks) {
        bytes += c.payload.size();
        estimate.parts.push_back({b.name, b.chunk_key ? b.chunk_key(c) : std::string(), c.payload.size()});
      }
      item.bytes = bytes;
      item.seconds += item.finish_seconds;
    }
    item.sampled_seconds = seconds_since(step_start);
    step_seconds.push_back(sampling + item.finish_seconds);
    estimate.items.push_back(std::move(item));
    return {};
  }));
  // plan()'s own time, measured by the driver around the step, counts in full.
  estimate.ray_scene_seconds = report.ray_scene_seconds;
  for (std::size_t i = 0; i < estimate.items.size() && i < report.items.size(); ++i)
    estimate.items[i].seconds += std::max(0.0, report.items[i].seconds - step_seconds[i]);
  return estimate;
}

}  // namespace penumbra
