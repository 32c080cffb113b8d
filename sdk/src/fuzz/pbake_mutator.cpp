// The libFuzzer mutator of the .pbake targets (bake-file, bake-part): after most mutations it
// recomputes the file size and the payload, table and header CRC-32s, so that mutants reach the
// readers behind the container's checks instead of stopping at a checksum.
#include <algorithm>
#include <cstdint>
#include <cstring>

#include "penumbra/core/hash.h"

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
