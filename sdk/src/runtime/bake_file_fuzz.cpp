// Fuzz target "bake-file": the .pbake container (read_bake_info, read_bake_file) and every module's
// chunk check and description (LightingModule::check, describe) on what it reads. Its mutator
// (pbake_mutator.cpp) keeps most mutants' checksums valid, so that they reach the payload readers.
// Invariants: a file either reads or fails with an error naming it; a chunk either checks or
// fails with an error; describing never throws.
#include "fuzz/fuzz.h"
#include "penumbra/core/pbake.h"
#include "penumbra/lighting/module.h"
#include "penumbra/runtime.h"

extern "C" std::uint32_t penumbra_fuzz_chunk_type() { return 0; }

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace penumbra;
  const std::filesystem::path path = fuzz::scratch_file(data, size, ".pbake");
  auto info = read_bake_info(path);
  auto file = read_bake_file(path);
  fuzz::require(file.ok() || file.error().message.find(path.filename().string()) != std::string::npos,
                "a container error that does not name the file");
  if (!file) return 0;
  fuzz::require(info.ok(), "the file reads but its header and table do not");
  for (const BakeChunk& chunk : file->chunks) {
    const LightingModule* module = lighting_module_for_chunk(chunk.type);
    if (module == nullptr) continue;
    const Status checked = module->check(chunk);
    fuzz::require(checked.ok() || !checked.error().message.empty(), "a chunk error without a message");
    if (module->describe) (void)module->describe(chunk);
  }
  return 0;
}
