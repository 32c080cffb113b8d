// penumbra bake SCENE -o FILE.pbake [...] and penumbra info FILE.pbake
#include <algorithm>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <filesystem>
#include <sstream>

#include "cli.h"
#include "penumbra/runtime.h"
#include "penumbra/bake/baker.h"
#include "penumbra/bake/estimate.h"
#include "penumbra/bake/shard.h"
#include "penumbra/bakers.h"
#include "penumbra/core/pbake.h"
#include "penumbra/core/memory.h"
#include "penumbra/import/gltf.h"

namespace penumbra::cli {

namespace {

CancelToken g_cancel;

void on_interrupt(int) { g_cancel.cancel(); }

std::vector<std::string> split_list(const std::string& text) {
  std::vector<std::string> out;
  std::stringstream in(text);
  for (std::string item; std::getline(in, item, ',');)
    if (!item.empty()) out.push_back(item);
  return out;
}

std::string hex64(std::uint64_t v) {
  char buf[24];
  std::snprintf(buf, sizeof buf, "%016llx", static_cast<unsigned long long>(v));
  return buf;
}

// penumbra bake SCENE --estimate: what the bake would take, from measured samples of it
// (bake/estimate.h), without writing anything.
int estimate(const std::string& scene, const std::vector<std::string>& names, const BakeSettings& settings,
             const std::vector<std::string>& pose_files, const std::optional<SkyOption>& sky, unsigned threads) {
  World world;
  if (Status s = load_world(world, scene, settings.preset); !s) return fail(kFailure, s.error().message);
  if (sky)
    if (Status s = set_sky_map(world, sky->path, sky->scale); !s) return fail(kFailure, "--sky: " + s.error().message);
  for (const std::string& f : pose_files)
    if (auto added = import_animations(world, f); !added) return fail(kFailure, "--poses: " + added.error().message);
  ThreadPool pool(threads);
  std::signal(SIGINT, on_interrupt);
  JobContext jobs(&pool, terminal_progress(), &g_cancel);
  const auto t0 = std::chrono::steady_clock::now();
  auto e = estimate_bake(world, names, settings, jobs);
  std::signal(SIGINT, SIG_DFL);
  if (!e) return fail(kFailure, scene + ": " + e.error().message);
  if (std::all_of(e->groups.begin(), e->groups.end(), [](const BakeEstimate::Group& g) { return g.elements == 0; }))
    return fail(kFailure, scene + ": nothing to bake, so nothing to estimate (no baker planned any work)");
  const double spent = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  std::printf("estimate of baking %s (preset %s, %u threads), from samples of the bake itself:\n", scene.c_str(),
              to_string(settings.preset), pool.concurrency());
  std::printf("  %-18s  %8.3f s\n", "ray scene", e->ray_scene_seconds);
  for (const BakeEstimate::Item& item : e->items) {
    std::uint64_t elements = 0, sampled = 0;
    for (const BakeEstimate::Group& g : e->groups)
      if (g.baker == item.baker) elements += g.elements, sampled += g.sampled;
    std::printf("  %-18s  %8.3f s  %10s  (%llu of %llu elements run)\n", item.baker.c_str(), item.seconds,
                item.bytes ? format_bytes(*item.bytes).c_str() : "after bake", static_cast<unsigned long long>(sampled),
                static_cast<unsigned long long>(elements));
  }
  std::printf("  %-18s  %8.3f s  (the estimate took %.3f s)\n", "total", e->seconds(), spent);
  return kSuccess;
}

}  // namespace

int cmd_bake(Args args) {
  const bool list = args.take_flag("--list");
  const bool force = args.take_flag("--force");
  const bool estimate_only = args.take_flag("--estimate");
  const auto out = args.take("-o");
  const auto only = args.take("--only");
  const auto preset = args.take("--preset");
  const auto threads = args.take("--threads");
  const auto seed = args.take("--seed");
  const auto shard_arg = args.take("--shard");
  std::vector<std::string> pose_files;
  while (const auto poses = args.take("--poses"))
    for (const std::string& f : split_list(*poses)) pose_files.push_back(f);
  bool sky_ok = true;
  const auto sky = take_sky(args, sky_ok);
  if (args.missing_value) return fail(kUsage, args.missing_name + " needs a value");
  if (!sky_ok) return kUsage;
  std::optional<ShardSpec> shard;
  if (shard_arg) {
    auto s = parse_shard(*shard_arg);
    if (!s) return fail(kUsage, s.error().message);
    shard = *s;
  }

  if (list) {
    World world;
    if (Status s = load_world(world, "builtin:furnace"); !s) return fail(kFailure, s.error().message);
    for (const Baker& b : world.resource<BakerRegistry>().all())
      std::printf("%-12s %s\n", b.name.c_str(), b.description.c_str());
    return kSuccess;
  }
  if (const auto unknown = reject_unknown_options(args, "bake")) return *unknown;
  if (args.rest().size() != 1)
    return fail(kUsage, "bake takes one SCENE (a glTF file or builtin:NAME) and -o FILE.pbake");
  if (!out && !estimate_only) return fail(kUsage, "bake needs -o FILE.pbake (or --estimate, to only estimate it)");
  if (estimate_only && shard) return fail(kUsage, "--estimate estimates the whole bake; leave out --shard");

  BakeSettings settings;
  if (preset) {
    auto p = parse_preset(*preset);
    if (!p) return fail(kUsage, p.error().message);
    settings.preset = *p;
  }
  if (seed) {
    auto s = parse_count("--seed", *seed);
    if (!s) return kUsage;
    settings.seed = *s;
  }
  const std::optional<unsigned> thread_count = parse_threads(threads);
  if (!thread_count) return kUsage;
  const std::vector<std::string> names = only ? split_list(*only) : std::vector<std::string>{};

  const std::string& scene = args.rest()[0];
  if (estimate_only) return estimate(scene, names, settings, pose_files, sky, *thread_count);
  // What -o may replace: never the scene being read; an existing file only when it is a .pbake
  // (or with --force); a symbolic link is written through (its target replaced, the link kept).
  std::filesystem::path out_path = *out;
  std::error_code ec;
  if (std::filesystem::is_symlink(out_path, ec)) {
    const std::filesystem::path target = std::filesystem::weakly_canonical(out_path, ec);
    if (ec) return fail(kFailure, *out + ": cannot resolve the symbolic link (" + ec.message() + ")");
    out_path = target;
  }
  if (std::filesystem::exists(out_path, ec)) {
    if (!scene.starts_with("builtin:") && std::filesystem::equivalent(out_path, scene, ec))
      return fail(kFailure, *out + " is the scene being baked; write the bake to another file, e.g. " +
                                std::filesystem::path(scene).replace_extension(".pbake").string());
    if (!std::filesystem::is_regular_file(out_path, ec))
      return fail(kFailure, *out + " exists and is not a regular file; choose another -o");
    if (auto info = read_bake_info(out_path); !info && !force)
      return fail(kFailure, *out + " exists and is not a .pbake file (" + info.error().message +
                                "); choose another -o, or pass --force to replace it");
  }
  const auto t0 = std::chrono::steady_clock::now();
  World world;
  if (Status s = load_world(world, scene, settings.preset); !s) return fail(kFailure, s.error().message);
  if (sky)
    if (Status s = set_sky_map(world, sky->path, sky->scale); !s) return fail(kFailure, "--sky: " + s.error().message);
  for (const std::string& f : pose_files) {
    auto added = import_animations(world, f);
    if (!added) return fail(kFailure, "--poses: " + added.error().message);
    for (const std::string& w : added->warnings) std::fprintf(stderr, "penumbra: warning: %s\n", w.c_str());
    std::printf("poses from %s: %zu clips, %zu channels retargeted by joint name\n", f.c_str(), added->clips,
                added->channels);
  }

  // Skip the bake when the file on disk was made from the same inputs (a part: and the same shard).
  const std::uint64_t input_hash = bake_input_hash(world, names, settings);
  const std::uint64_t file_hash = shard ? part_input_hash(input_hash, *shard) : input_hash;
  if (!force && std::filesystem::exists(out_path)) {
    if (auto info = read_bake_info(out_path); info && info->input_hash == file_hash) {
      std::printf("%s is up to date (input hash %s%s): nothing to bake; --force bakes anyway\n", out->c_str(),
                  hex64(input_hash).c_str(), shard ? (", shard " + *shard_arg).c_str() : "");
      return kSuccess;
    }
  }

  ThreadPool pool(*thread_count);
  std::signal(SIGINT, on_interrupt);
  JobContext jobs(&pool, terminal_progress(), &g_cancel);
  auto result = shard ? bake_shard(world, names, settings, *shard, scene, jobs) : bake_world(world, names, settings, jobs);
  std::signal(SIGINT, SIG_DFL);
  if (!result) return fail(kFailure, scene + ": " + result.error().message);
  // A part is empty when no baker planned any work (a shard may hold no item of a small plan).
  bool empty = result->file.chunks.empty();
  if (shard) {
    auto part = read_bake_part(result->file, *out);
    if (!part) return fail(kFailure, part.error().message);
    empty = std::all_of(part->bakers.begin(), part->bakers.end(), [](const auto& b) { return b.groups.empty(); });
  }
  if (empty) {
    // Each baker that ran says what it bakes and what the scene has instead.
    std::string why;
    for (const LightingModule* m : lighting_modules()) {
      const bool ran = names.empty() || std::find(names.begin(), names.end(), m->name) != names.end();
      if (ran) why += "\n  " + (m->explain_empty ? m->explain_empty(world) : std::string(m->name) + " found nothing");
    }
    return fail(kFailure, scene + ": baked nothing, so " + *out + " was not written:" + why);
  }
  if (Status s = write_bake_file(out_path, result->file, &g_cancel); !s) return fail(kFailure, s.error().message);
  const double total = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();

  const BakeReport& r = result->report;
  std::printf("baked %s%s -> %s (preset %s, seed %llu, %u threads)\n",
              shard ? ("shard " + *shard_arg + " of ").c_str() : "", scene.c_str(), out->c_str(),
              to_string(settings.preset), static_cast<unsigned long long>(settings.seed), pool.concurrency());
  std::printf("  %-18s  %8.3f s  %10s  %zu triangles\n", "ray scene", r.ray_scene_seconds,
              format_bytes(r.ray_scene_bytes).c_str(), r.triangles);
  for (const auto& item : r.items) {
    std::printf("  %-18s  %8.3f s  %10s\n", item.baker.c_str(), item.seconds, format_bytes(item.bytes).c_str());
    for (const auto& line : item.lines) std::printf("      %s\n", line.c_str());
    // A whole bake's module that wrote nothing says why (a shard may simply hold none of its items).
    if (!shard && item.bytes == 0)
      for (const LightingModule* m : lighting_modules())
        if (m->name == item.baker && m->explain_empty) std::printf("      nothing to bake: %s\n", m->explain_empty(world).c_str());
  }
  std::printf("  %-18s  %8.3f s  %10s on disk, input hash %s\n", "total", total,
              format_bytes(std::filesystem::file_size(out_path)).c_str(), hex64(input_hash).c_str());
  return kSuccess;
}

// penumbra merge PART... -o FILE.pbake: the parts of a sharded bake into the file a single machine
// writes.
int cmd_merge(Args args) {
  const bool force = args.take_flag("--force");
  const auto out = args.take("-o");
  const auto threads = args.take("--threads");
  if (args.missing_value) return fail(kUsage, args.missing_name + " needs a value");
  if (!out) return fail(kUsage, "merge needs -o FILE.pbake");
  if (const auto unknown = reject_unknown_options(args, "merge")) return *unknown;
  if (args.rest().empty()) return fail(kUsage, "merge takes the part files ('penumbra bake --shard I/N' wrote) and -o FILE");
  const std::optional<unsigned> thread_count = parse_threads(threads);
  if (!thread_count) return kUsage;
  const std::filesystem::path out_path = *out;
  std::error_code ec;
  std::vector<NamedPart> parts;
  for (const std::string& path : args.rest()) {
    if (std::filesystem::exists(out_path, ec) && std::filesystem::equivalent(out_path, path, ec))
      return fail(kFailure, *out + " is one of the parts; write the merged file to another path");
    auto file = read_bake_file(path);
    if (!file) return fail(kFailure, file.error().message);
    auto part = read_bake_part(*file, path);
    if (!part) return fail(kFailure, part.error().message);
    parts.push_back({path, std::move(*part)});
  }
  if (std::filesystem::exists(out_path, ec) && !force) {
    if (!std::filesystem::is_regular_file(out_path, ec))
      return fail(kFailure, *out + " exists and is not a regular file; choose another -o");
    if (auto info = read_bake_info(out_path); !info)
      return fail(kFailure, *out + " exists and is not a .pbake file (" + info.error().message +
                                "); choose another -o, or pass --force to replace it");
  }
  const auto t0 = std::chrono::steady_clock::now();
  World world;  // only for the registry of bakers, whose finish() the merge runs
  register_bakers(world);
  ThreadPool pool(*thread_count);
  std::signal(SIGINT, on_interrupt);
  JobContext jobs(&pool, terminal_progress(), &g_cancel);
  MergeReport report;
  auto merged = merge_bake_parts(world.resource<BakerRegistry>(), parts, jobs, &report);
  std::signal(SIGINT, SIG_DFL);
  if (!merged) return fail(kFailure, merged.error().message);
  if (Status s = write_bake_file(out_path, *merged, &g_cancel); !s) return fail(kFailure, s.error().message);
  const double total = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  std::printf("merged %zu parts of %u shards of %s -> %s (preset %s, seed %llu)\n", parts.size(),
              parts.front().part.shard.count, parts.front().part.scene.c_str(), out->c_str(),
              to_string(parts.front().part.preset), static_cast<unsigned long long>(parts.front().part.seed));
  for (const MergeReport::Item& item : report.items)
    std::printf("  %-18s  %8.3f s  %10s  from %zu work items (the global steps)\n", item.baker.c_str(), item.seconds,
                format_bytes(item.bytes).c_str(), item.items);
  std::printf("  %-18s  %8.3f s  %10s on disk, input hash %s\n", "total", total,
              format_bytes(std::filesystem::file_size(out_path)).c_str(), hex64(merged->input_hash).c_str());
  return kSuccess;
}

namespace {

// `penumbra info` and `validate` of a part file: its manifest, checked.
int describe_part(const std::string& path, const BakeFile& file, bool verbose) {
  auto part = read_bake_part(file, path);
  if (!part) return fail(kFailure, part.error().message);
  std::size_t groups = 0;
  for (const auto& b : part->bakers) groups += b.groups.size();
  std::printf("%s: part of a sharded bake: shard %u/%u of %s (preset %s, seed %llu, bake input hash %s), %zu work "
              "items of %zu groups; merge the parts with 'penumbra merge'\n",
              path.c_str(), part->shard.index, part->shard.count, part->scene.c_str(), to_string(part->preset),
              static_cast<unsigned long long>(part->seed), hex64(part->input_hash).c_str(), part->items.size(), groups);
  if (verbose)
    for (const BakePart::Item& item : part->items) {
      const auto& b = part->bakers[item.baker];
      std::printf("  item %s: %s of results\n", item_id(b.name, b.groups[item.group].name, item.block).c_str(),
                  format_bytes(item.results.size()).c_str());
    }
  return kSuccess;
}

}  // namespace

int cmd_info(Args args) {
  if (const auto unknown = reject_unknown_options(args, "info")) return *unknown;
  if (args.rest().size() != 1) return fail(kUsage, "info takes one FILE.pbake");
  const std::string& path = args.rest()[0];
  auto file = read_bake_file(path);
  if (!file) return fail(kFailure, file.error().message);
  if (file->find(kShardManifestChunk) != nullptr) return describe_part(path, *file, true);

  std::printf("%s\n  format version %u, written by Penumbra %s\n  input hash %s\n  %zu chunks, %s in all\n",
              path.c_str(), file->format_version, file->sdk_version.c_str(), hex64(file->input_hash).c_str(),
              file->chunks.size(), format_bytes(std::filesystem::file_size(path)).c_str());
  std::size_t invalid = 0;
  for (const BakeChunk& chunk : file->chunks) {
    std::printf("  chunk %s v%u '%s': %s\n", fourcc_to_string(chunk.type).c_str(), chunk.version, chunk.label.c_str(),
                format_bytes(chunk.payload.size()).c_str());
    // Each module checks and describes its own chunks.
    const LightingModule* module = lighting_module_for_chunk(chunk.type);
    if (module == nullptr) {
      std::printf("      (no linked lighting module reads this chunk type)\n");
    } else if (Status s = module->check ? module->check(chunk) : Status{}; !s) {
      std::printf("      invalid: %s\n", s.error().message.c_str());
      ++invalid;
    } else if (module->describe) {
      for (const auto& line : module->describe(chunk)) std::printf("      %s\n", line.c_str());
    }
  }
  if (invalid > 0)
    return fail(kFailure, path + ": " + std::to_string(invalid) + " of " + std::to_string(file->chunks.size()) +
                              " chunks are invalid (above); re-bake the scene");
  return kSuccess;
}

// Checks FILE without baking: a .pbake as `info` does (every chunk through its module's check), a
// glTF by importing it into a scratch World with every check the importer makes.
int cmd_validate(Args args) {
  if (const auto unknown = reject_unknown_options(args, "validate")) return *unknown;
  if (args.rest().size() != 1)
    return fail(kUsage, "validate takes one FILE (.gltf, .glb or .pbake)");
  const std::filesystem::path path = args.rest()[0];
  const std::string ext = path.extension().string();
  if (ext == ".pbake") {
    auto file = read_bake_file(path);
    if (!file) return fail(kFailure, file.error().message);
    if (file->find(kShardManifestChunk) != nullptr) return describe_part(path.string(), *file, false);
    std::size_t invalid = 0, unread = 0;
    for (const BakeChunk& chunk : file->chunks) {
      const LightingModule* module = lighting_module_for_chunk(chunk.type);
      if (module == nullptr) {
        ++unread;
        continue;
      }
      if (Status s = module->check ? module->check(chunk) : Status{}; !s) {
        std::fprintf(stderr, "penumbra: %s\n", s.error().message.c_str());
        ++invalid;
      }
    }
    if (invalid > 0)
      return fail(kFailure, path.string() + ": " + std::to_string(invalid) + " of " +
                                std::to_string(file->chunks.size()) + " chunks are invalid (above); re-bake the scene");
    std::printf("%s: valid .pbake, %zu chunks%s\n", path.c_str(), file->chunks.size(),
                unread > 0 ? (", " + std::to_string(unread) + " of a type no linked module reads").c_str() : "");
    return kSuccess;
  }
  if (ext == ".gltf" || ext == ".glb") {
    World world;
    auto imported = import_gltf(world, path);
    if (!imported) return fail(kFailure, imported.error().message);
    // The PENUMBRA_lighting declarations, turned into components as a bake would.
    std::size_t declared = 0;
    world.view<AuthoredLighting>().each([&](Entity, AuthoredLighting& a) { declared += a.components.size(); });
    register_lighting(world);
    if (Status s = apply_authored_lighting(world); !s) return fail(kFailure, s.error().message);
    std::printf("%s: valid glTF, %zu nodes, %zu meshes, %zu triangles, %zu materials, %zu skins, %zu animations, "
                "%zu lights, %zu cameras, %zu lighting components declared, %zu warnings%s\n",
                path.c_str(), imported->nodes.size(), imported->mesh_entities, imported->triangles, imported->materials,
                imported->skins, imported->animations, imported->lights, imported->cameras, declared,
                imported->warnings.size(), imported->warnings.empty() ? "" : " (on stderr)");
    return kSuccess;
  }
  return fail(kUsage, path.string() + ": validate reads .gltf, .glb and .pbake files; give one of those");
}

}  // namespace penumbra::cli
