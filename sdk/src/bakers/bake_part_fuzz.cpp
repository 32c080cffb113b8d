// Fuzz target "bake-part": a part of a sharded bake (read_bake_file, read_bake_part) merged alone
// (merge_bake_parts, which runs every baker's finish() over the items' results). Seed: a 1-shard
// part of the courtyard, which holds every work item, so mutants reach each finish(). Mutator:
// pbake_mutator.cpp. Invariants: a part either parses or fails with an error naming the file; a
// merge either fails with a message or writes chunks that their modules' checks accept.
#include <cstdio>

#include "fuzz/fuzz.h"
#include "penumbra/bake/shard.h"
#include "penumbra/bakers.h"
#include "penumbra/core/pbake.h"
#include "penumbra/runtime.h"

extern "C" std::uint32_t penumbra_fuzz_chunk_type() { return 0; }

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace penumbra;
  const std::filesystem::path path = fuzz::scratch_file(data, size, ".pbake");
  auto file = read_bake_file(path);
  if (!file) return 0;
  auto part = read_bake_part(*file, path.string());
  fuzz::require(part.ok() || part.error().message.find(path.filename().string()) != std::string::npos,
                "a part error that does not name the file");
  if (!part) return 0;
  static World* registry = [] {
    auto* w = new World;
    register_bakers(*w);
    return w;
  }();
  const NamedPart named{path.string(), std::move(*part)};
  JobContext jobs;
  auto merged = merge_bake_parts(registry->resource<BakerRegistry>(), std::span<const NamedPart>(&named, 1), jobs);
  fuzz::require(merged.ok() || !merged.error().message.empty(), "a merge error without a message");
  if (!merged) return 0;
  for (const BakeChunk& chunk : merged->chunks) {
    const LightingModule* module = lighting_module_for_chunk(chunk.type);
    fuzz::require(module != nullptr, "the merge wrote a chunk no module reads");
    const Status checked = module->check(chunk);
    if (!checked) std::fprintf(stderr, "%s\n", checked.error().message.c_str());
    fuzz::require(checked.ok(), "the merge wrote a chunk its module refuses");
  }
  return 0;
}
