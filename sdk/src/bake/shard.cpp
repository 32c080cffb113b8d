// Sharded bakes and their merge (see penumbra/bake/shard.h).
#include "penumbra/bake/shard.h"

#include <algorithm>
#include <charconv>
#include <chrono>
#include <cmath>
#include <map>
#include <numeric>

#include "penumbra/core/random.h"
#include "penumbra/core/version.h"
#include "drive.h"

namespace penumbra {

namespace {

constexpr std::uint32_t kMaxPartBakers = 256;
constexpr std::uint64_t kMaxPartGroups = std::uint64_t{1} << 20;
constexpr std::uint64_t kMaxPartElements = std::uint64_t{1} << 40;

std::uint64_t block_count(const BakeGroup& g) { return (g.elements + g.block - 1) / g.block; }

std::string shard_text(ShardSpec s) { return std::to_string(s.index) + "/" + std::to_string(s.count); }

std::string hex64(std::uint64_t v) {
  char buf[24];
  std::snprintf(buf, sizeof buf, "%016llx", static_cast<unsigned long long>(v));
  return buf;
}

// One baker's items in plan order: (group, block) and the estimated cost.
struct PlannedItem {
  std::uint32_t group = 0;
  std::uint64_t block = 0;
  double cost = 0.0;
};
std::vector<PlannedItem> plan_items(const std::vector<BakeGroup>& groups) {
  std::vector<PlannedItem> items;
  for (std::size_t g = 0; g < groups.size(); ++g)
    for (std::uint64_t k = 0; k < block_count(groups[g]); ++k) {
      const std::uint64_t count = std::min(groups[g].block, groups[g].elements - k * groups[g].block);
      items.push_back({static_cast<std::uint32_t>(g), k, static_cast<double>(count) * groups[g].element_cost});
    }
  return items;
}
std::vector<std::uint32_t> owners_of(const std::vector<PlannedItem>& items, std::vector<double>& loads) {
  std::vector<double> costs(items.size());
  for (std::size_t i = 0; i < items.size(); ++i) costs[i] = items[i].cost;
  return assign_items(costs, loads);
}

void write_group(ByteWriter& w, const BakeGroup& g) {
  w.write_string(g.name);
  w.write(g.elements);
  w.write(g.block);
  w.write(g.element_cost);
  w.write_vector(g.header);
}

Status read_group(ByteReader& r, BakeGroup& g) {
  PENUMBRA_TRY(r.read_string(g.name));
  PENUMBRA_TRY(r.read(g.elements));
  PENUMBRA_TRY(r.read(g.block));
  PENUMBRA_TRY(r.read(g.element_cost));
  PENUMBRA_TRY(r.read_vector(g.header));
  if (g.elements == 0 || g.elements > kMaxPartElements || g.block == 0 ||
      !std::isfinite(g.element_cost) || g.element_cost < 0.0)
    return make_error(ErrorCode::InvalidInput, r.context() + ": group '" + g.name + "' has " +
                                                   std::to_string(g.elements) + " elements in blocks of " +
                                                   std::to_string(g.block) + "; the part is corrupt, re-bake the shard");
  return {};
}

BakeChunk manifest_chunk(const BakePart& part) {
  ByteWriter w;
  w.write(part.input_hash);
  w.write(part.shard.index);
  w.write(part.shard.count);
  w.write(static_cast<std::uint8_t>(part.preset));
  w.write(part.seed);
  w.write_string(part.sdk_version);
  w.write_string(part.scene);
  w.write(static_cast<std::uint32_t>(part.bakers.size()));
  for (const BakePart::Baker& b : part.bakers) {
    w.write_string(b.name);
    w.write(static_cast<std::uint64_t>(b.groups.size()));
    for (const BakeGroup& g : b.groups) write_group(w, g);
  }
  return BakeChunk{kShardManifestChunk, kShardChunkVersion, "shard " + shard_text(part.shard), w.take()};
}

BakeChunk item_chunk(const BakePart& part, const BakePart::Item& item) {
  ByteWriter w;
  w.write(item.baker);
  w.write(item.group);
  w.write(item.block);
  w.write_vector(item.results);
  const BakePart::Baker& b = part.bakers[item.baker];
  return BakeChunk{kShardItemChunk, kShardChunkVersion,
                   chunk_label(b.name, b.groups[item.group].name + "#" + std::to_string(item.block)), w.take()};
}

}  // namespace

Result<ShardSpec> parse_shard(std::string_view text) {
  const auto bad = [&] {
    return make_error(ErrorCode::InvalidArgument, "--shard '" + std::string(text) +
                                                      "' is not I/N with 0 <= I < N <= " + std::to_string(kMaxShards) +
                                                      " (shard I from 0, e.g. 0/4 ... 3/4)");
  };
  const std::size_t slash = text.find('/');
  if (slash == std::string_view::npos) return bad();
  ShardSpec s;
  const char* end = text.data() + slash;
  auto [p1, e1] = std::from_chars(text.data(), end, s.index);
  if (e1 != std::errc{} || p1 != end || slash == 0) return bad();
  const char* last = text.data() + text.size();
  auto [p2, e2] = std::from_chars(end + 1, last, s.count);
  if (e2 != std::errc{} || p2 != last || slash + 1 == text.size()) return bad();
  if (s.count == 0 || s.count > kMaxShards || s.index >= s.count) return bad();
  return s;
}

std::uint64_t part_input_hash(std::uint64_t bake_input_hash, ShardSpec shard) {
  return mix64(bake_input_hash ^ mix64((std::uint64_t{shard.count} << 32 | shard.index) + 0x7368617264ull));
}

std::vector<std::uint32_t> assign_items(std::span<const double> costs, std::vector<double>& loads) {
  std::vector<std::size_t> order(costs.size());
  std::iota(order.begin(), order.end(), std::size_t{0});
  std::stable_sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return costs[a] > costs[b]; });
  std::vector<std::uint32_t> owners(costs.size(), 0);
  for (std::size_t i : order) {
    const auto least = std::min_element(loads.begin(), loads.end());
    owners[i] = static_cast<std::uint32_t>(least - loads.begin());
    *least += costs[i];
  }
  return owners;
}

std::string item_id(std::string_view baker, std::string_view group, std::uint64_t block) {
  return std::string(baker) + ":" + std::string(group) + "#" + std::to_string(block);
}

Result<BakeResult> bake_shard(World& world, const std::vector<std::string>& names, const BakeSettings& settings,
                              ShardSpec shard, std::string_view scene, JobContext& jobs) {
  if (shard.count == 0 || shard.count > kMaxShards || shard.index >= shard.count)
    return make_error(ErrorCode::InvalidArgument, "shard " + shard_text(shard) + " does not exist");
  auto bakers = select_bakers(world.resource<BakerRegistry>(), names);
  if (!bakers) return bakers.error();
  if (bakers->empty()) return make_error(ErrorCode::NotFound, "no baker is registered; link a lighting module");

  BakePart part;
  part.input_hash = bake_input_hash(world, names, settings);
  part.shard = shard;
  part.preset = settings.preset;
  part.seed = settings.seed;
  part.sdk_version = std::string(sdk_version());
  part.scene = std::string(scene);
  std::vector<double> loads(shard.count, 0.0);
  BakeResult result;
  PENUMBRA_TRY(drive_bake(world, *bakers, settings, jobs, result.report,
                          [&](const Baker& b, BakeWork& work, BakeReport::Item& report) -> Status {
                            const auto baker = static_cast<std::uint32_t>(part.bakers.size());
                            part.bakers.push_back({b.name, work.groups});
                            const std::vector<PlannedItem> items = plan_items(work.groups);
                            const std::vector<std::uint32_t> owners = owners_of(items, loads);
                            std::size_t mine = 0;
                            for (std::size_t i = 0; i < items.size(); ++i) {
                              if (owners[i] != shard.index) continue;
                              const BakeGroup& g = work.groups[items[i].group];
                              const std::uint64_t begin = items[i].block * g.block;
                              auto r = work.run(items[i].group, begin, std::min(begin + g.block, g.elements), jobs);
                              if (!r) return r.error();
                              report.bytes += r->size();
                              part.items.push_back({baker, items[i].group, items[i].block, std::move(*r)});
                              ++mine;
                            }
                            report.lines.push_back(std::to_string(mine) + " of " + std::to_string(items.size()) +
                                                   " work items in " + std::to_string(work.groups.size()) +
                                                   " groups");
                            return {};
                          }));
  result.file.input_hash = part_input_hash(part.input_hash, shard);
  result.file.sdk_version = part.sdk_version;
  result.file.chunks.push_back(manifest_chunk(part));
  for (const BakePart::Item& item : part.items) result.file.chunks.push_back(item_chunk(part, item));
  return result;
}

Result<BakePart> read_bake_part(const BakeFile& file, std::string_view context) {
  const std::string where(context);
  const BakeChunk* manifest = file.find(kShardManifestChunk);
  if (manifest == nullptr)
    return make_error(ErrorCode::InvalidInput,
                      where + ": not a part of a sharded bake (no 'SHRD' manifest chunk); give the part files that "
                              "'penumbra bake --shard I/N' wrote");
  PENUMBRA_TRY(check_chunk(*manifest, kShardManifestChunk, kShardChunkVersion, where + ": chunk 'SHRD'"));
  BakePart part;
  ByteReader r(manifest->payload, where + ": chunk 'SHRD'");
  std::uint8_t preset = 0;
  std::uint32_t baker_count = 0;
  PENUMBRA_TRY(r.read(part.input_hash));
  PENUMBRA_TRY(r.read(part.shard.index));
  PENUMBRA_TRY(r.read(part.shard.count));
  PENUMBRA_TRY(r.read(preset));
  PENUMBRA_TRY(r.read(part.seed));
  PENUMBRA_TRY(r.read_string(part.sdk_version, kPbakeMaxSdkVersion));
  PENUMBRA_TRY(r.read_string(part.scene));
  PENUMBRA_TRY(r.read(baker_count));
  if (part.shard.count == 0 || part.shard.count > kMaxShards || part.shard.index >= part.shard.count ||
      preset > static_cast<std::uint8_t>(Preset::High) || baker_count > kMaxPartBakers)
    return make_error(ErrorCode::InvalidInput, r.context() + ": shard " + shard_text(part.shard) + ", preset " +
                                                   std::to_string(preset) + ", " + std::to_string(baker_count) +
                                                   " bakers: out of range; the part is corrupt, re-bake the shard");
  part.preset = static_cast<Preset>(preset);
  for (std::uint32_t b = 0; b < baker_count; ++b) {
    BakePart::Baker baker;
    std::uint64_t groups = 0;
    PENUMBRA_TRY(r.read_string(baker.name));
    PENUMBRA_TRY(r.read(groups));
    if (groups > kMaxPartGroups || groups > r.remaining())
      return make_error(ErrorCode::InvalidInput, r.context() + ": baker '" + baker.name + "' claims " +
                                                     std::to_string(groups) + " groups; the part is corrupt");
    baker.groups.resize(static_cast<std::size_t>(groups));
    for (BakeGroup& g : baker.groups) PENUMBRA_TRY(read_group(r, g));
    part.bakers.push_back(std::move(baker));
  }
  PENUMBRA_TRY(r.finish());
  if (file.input_hash != part_input_hash(part.input_hash, part.shard))
    return make_error(ErrorCode::InvalidInput, where + ": the header's input hash " + hex64(file.input_hash) +
                                                   " is not the manifest's shard " + shard_text(part.shard) +
                                                   "; the part is corrupt, re-bake the shard");

  for (std::size_t c = 0; c < file.chunks.size(); ++c) {
    const BakeChunk& chunk = file.chunks[c];
    if (chunk.type == kShardManifestChunk) {
      if (&chunk != manifest)
        return make_error(ErrorCode::InvalidInput, where + ": chunk " + std::to_string(c) + " is a second manifest");
      continue;
    }
    const std::string ctx = where + ": chunk " + std::to_string(c) + " '" + chunk.label + "'";
    PENUMBRA_TRY(check_chunk(chunk, kShardItemChunk, kShardChunkVersion, ctx));
    ByteReader ir(chunk.payload, ctx);
    BakePart::Item item;
    PENUMBRA_TRY(ir.read(item.baker));
    PENUMBRA_TRY(ir.read(item.group));
    PENUMBRA_TRY(ir.read(item.block));
    PENUMBRA_TRY(ir.read_vector(item.results));
    PENUMBRA_TRY(ir.finish());
    if (item.baker >= part.bakers.size() || item.group >= part.bakers[item.baker].groups.size() ||
        item.block >= block_count(part.bakers[item.baker].groups[item.group]))
      return make_error(ErrorCode::InvalidInput, ctx + ": names baker " + std::to_string(item.baker) + ", group " +
                                                     std::to_string(item.group) + ", block " +
                                                     std::to_string(item.block) +
                                                     ", which the manifest lacks; the part is corrupt");
    part.items.push_back(std::move(item));
  }
  return part;
}

Result<BakeFile> merge_bake_parts(const BakerRegistry& registry, std::span<const NamedPart> parts, JobContext& jobs,
                                  MergeReport* report) {
  if (parts.empty()) return make_error(ErrorCode::InvalidArgument, "merge needs at least one part file");
  const NamedPart& first = parts.front();
  const BakePart& ref = first.part;
  // Same inputs and settings: name what differs, the settings first.
  for (const NamedPart& np : parts) {
    const BakePart& p = np.part;
    const std::string both = np.path + " and " + first.path;
    const auto differ = [&](const std::string& what) {
      return make_error(ErrorCode::InvalidInput, both + " are parts of different bakes (" + what +
                                                     "); re-bake every shard with the same scene and settings");
    };
    if (p.sdk_version != ref.sdk_version)
      return differ("written by Penumbra " + p.sdk_version + " and " + ref.sdk_version);
    if (p.shard.count != ref.shard.count)
      return differ("shards of " + std::to_string(p.shard.count) + " and of " + std::to_string(ref.shard.count));
    if (p.preset != ref.preset) return differ(std::string("preset ") + to_string(p.preset) + " and " + to_string(ref.preset));
    if (p.seed != ref.seed) return differ("seed " + std::to_string(p.seed) + " and " + std::to_string(ref.seed));
    std::string names_p, names_ref;
    for (const auto& b : p.bakers) names_p += (names_p.empty() ? "" : ",") + b.name;
    for (const auto& b : ref.bakers) names_ref += (names_ref.empty() ? "" : ",") + b.name;
    if (names_p != names_ref) return differ("bakers " + names_p + " and " + names_ref);
    if (p.input_hash != ref.input_hash)
      return differ("scene content: input hashes " + hex64(p.input_hash) + " and " + hex64(ref.input_hash));
    for (std::size_t b = 0; b < p.bakers.size(); ++b) {
      const auto& gp = p.bakers[b].groups;
      const auto& gr = ref.bakers[b].groups;
      bool same = gp.size() == gr.size();
      for (std::size_t g = 0; same && g < gp.size(); ++g)
        same = gp[g].name == gr[g].name && gp[g].elements == gr[g].elements && gp[g].block == gr[g].block &&
               gp[g].element_cost == gr[g].element_cost && gp[g].header == gr[g].header;
      if (!same) return differ("the plans of baker '" + p.bakers[b].name + "' differ although the input hashes match");
    }
  }
  if (ref.sdk_version != sdk_version())
    return make_error(ErrorCode::Unsupported, first.path + " was written by Penumbra " + ref.sdk_version +
                                                  " and this is " + std::string(sdk_version()) +
                                                  "; merge with the version that baked the shards");
  std::vector<const Baker*> bakers;
  for (const BakePart::Baker& b : ref.bakers) {
    const Baker* found = registry.find(b.name);
    if (found == nullptr || !found->finish)
      return make_error(ErrorCode::Unsupported, first.path + " holds work of baker '" + b.name +
                                                    "', which this build does not link; merge with the build that "
                                                    "baked the shards");
    bakers.push_back(found);
  }

  // Each item exactly once: where it came from, per baker, group and block.
  std::vector<std::vector<std::vector<std::pair<const BakePart::Item*, const NamedPart*>>>> found(ref.bakers.size());
  for (std::size_t b = 0; b < ref.bakers.size(); ++b) {
    found[b].resize(ref.bakers[b].groups.size());
    for (std::size_t g = 0; g < ref.bakers[b].groups.size(); ++g)
      found[b][g].assign(static_cast<std::size_t>(block_count(ref.bakers[b].groups[g])), {nullptr, nullptr});
  }
  for (const NamedPart& np : parts)
    for (const BakePart::Item& item : np.part.items) {
      auto& slot = found[item.baker][item.group][static_cast<std::size_t>(item.block)];
      if (slot.first != nullptr)
        return make_error(ErrorCode::InvalidInput,
                          "item " + item_id(ref.bakers[item.baker].name, ref.bakers[item.baker].groups[item.group].name,
                                            item.block) +
                              " is in both " + slot.second->path + " (shard " + shard_text(slot.second->part.shard) +
                              ") and " + np.path + " (shard " + shard_text(np.part.shard) +
                              "); give each shard's part once");
      slot = {&item, &np};
    }
  std::vector<double> loads(ref.shard.count, 0.0);
  for (std::size_t b = 0; b < ref.bakers.size(); ++b) {
    const std::vector<PlannedItem> items = plan_items(ref.bakers[b].groups);
    const std::vector<std::uint32_t> owners = owners_of(items, loads);
    for (std::size_t i = 0; i < items.size(); ++i) {
      if (found[b][items[i].group][static_cast<std::size_t>(items[i].block)].first != nullptr) continue;
      const BakeGroup& g = ref.bakers[b].groups[items[i].group];
      const std::uint64_t begin = items[i].block * g.block;
      const ShardSpec owner{owners[i], ref.shard.count};
      return make_error(ErrorCode::InvalidInput,
                        "no part holds item " + item_id(ref.bakers[b].name, g.name, items[i].block) + " (elements " +
                            std::to_string(begin) + ".." + std::to_string(std::min(begin + g.block, g.elements) - 1) +
                            "), which shard " + shard_text(owner) + " bakes; bake it with 'penumbra bake " +
                            ref.scene + " --shard " + shard_text(owner) + " -o part_" + std::to_string(owner.index) +
                            ".pbake' and merge again");
    }
  }

  // The global steps, baker by baker, over each group's items' results in block order.
  BakeFile out;
  out.input_hash = ref.input_hash;
  out.sdk_version = ref.sdk_version;
  for (std::size_t b = 0; b < ref.bakers.size(); ++b) {
    if (jobs.cancelled()) return make_error(ErrorCode::Cancelled, "the merge was cancelled");
    const auto start = std::chrono::steady_clock::now();
    const std::vector<BakeGroup>& groups = ref.bakers[b].groups;
    std::vector<std::vector<std::byte>> results(groups.size());
    std::size_t count = 0;
    for (std::size_t g = 0; g < groups.size(); ++g)
      for (const auto& [item, from] : found[b][g]) {
        results[g].insert(results[g].end(), item->results.begin(), item->results.end());
        ++count;
      }
    auto chunks = finish_groups(*bakers[b], groups, results, jobs);
    if (!chunks) return Error{chunks.error().code, bakers[b]->name + ": " + chunks.error().message};
    MergeReport::Item item{bakers[b]->name, 0.0, 0, count};
    for (BakeChunk& chunk : *chunks) {
      // Values no reader accepts come from a damaged part (its CRC-32s rewritten, or a bug).
      if (bakers[b]->check)
        if (Status s = bakers[b]->check(chunk); !s)
          return make_error(ErrorCode::InvalidInput, bakers[b]->name + ": the merged chunk is invalid (" +
                                                         s.error().message +
                                                         "); a part is corrupt: re-bake the shards and merge again");
      item.bytes += chunk.payload.size();
      out.chunks.push_back(std::move(chunk));
    }
    item.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    if (report) report->items.push_back(std::move(item));
  }
  return out;
}

}  // namespace penumbra
