// Fuzz target "bake-file": the .pbake container (read_bake_info, read_bake_file) and every module's
// chunk check and description (LightingModule::check, describe) on what it reads. Its mutator
// (libFuzzer builds) recomputes the file size, the payload, table and header CRC-32s after most
// mutations, so that mutants reach the payload readers instead of stopping at a checksum.
// Invariants: a file either reads or fails with an error naming it; a chunk either checks or
// fails with an error; describing never throws.
#include <algorithm>
#include <cstring>

#include "fuzz/fuzz.h"
#include "penumbra/core/hash.h"
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

#ifdef PENUMBRA_LIBFUZZER
extern "C" std::size_t LLVMFuzzerMutate(std::uint8_t* data, std::size_t size, std::size_t max_size);

namespace {
std::uint32_t get32(const std::uint8_t* p) {
  std::uint32_t v;
  std::memcpy(&v, p, 4);
  return v;
}
std::uint64_t get64(const std::uint8_t* p) {
  std::uint64_t v;
  std::memcpy(&v, p, 8);
  return v;
}
void put32(std::uint8_t* p, std::uint32_t v) { std::memcpy(p, &v, 4); }
void put64(std::uint8_t* p, std::uint64_t v) { std::memcpy(p, &v, 8); }
}  // namespace

// The layout of pbake.h: a 64-byte header (chunk count at 12, file size at 24, table CRC at 56,
// header CRC at 60), then 64 bytes per chunk (offset at 8, size at 16, payload CRC at 24).
extern "C" std::size_t LLVMFuzzerCustomMutator(std::uint8_t* data, std::size_t size, std::size_t max_size,
                                               unsigned int seed) {
  size = LLVMFuzzerMutate(data, size, max_size);
  if (seed % 8 == 0 || size < 64) return size;  // some mutants keep their broken checksums
  const std::uint64_t count = get32(data + 12);
  const std::size_t entries = static_cast<std::size_t>(std::min<std::uint64_t>(count, (size - 64) / 64));
  for (std::size_t i = 0; i < entries; ++i) {
    std::uint8_t* e = data + 64 + 64 * i;
    const std::uint64_t offset = get64(e + 8), length = get64(e + 16);
    if (offset <= size && length <= size - offset)
      put32(e + 24, penumbra::crc32(data + offset, static_cast<std::size_t>(length)));
  }
  put32(data + 56, penumbra::crc32(data + 64, entries * 64));
  put64(data + 24, size);
  put32(data + 60, penumbra::crc32(data, 60));
  return size;
}
#endif
