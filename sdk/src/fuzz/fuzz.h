// What every fuzz target shares (libFuzzer harnesses, scripts/fuzz; the replay runner in
// replay.cpp runs the same harness over a seed corpus in the normal test build).
//
// A harness defines LLVMFuzzerTestOneInput(data, size), which must return 0 for every input and
// traps (fuzz_require) when an invariant of the loader breaks: a crash, a hang or a sanitizer
// report is a finding, a clear error is not. A harness of one chunk type also defines
// penumbra_fuzz_chunk_type(), so that the replay runner feeds it the payloads of that type found
// in .pbake seeds; the others return 0.
#pragma once

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <string_view>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size);
extern "C" std::uint32_t penumbra_fuzz_chunk_type();

namespace penumbra::fuzz {

// Writes `size` bytes to this process's scratch file with extension `ext` (in /dev/shm when it
// exists, else the temporary directory) and returns its path; the loaders under test read files.
std::filesystem::path scratch_file(const std::uint8_t* data, std::size_t size, std::string_view ext);

// Traps (a finding) with `what` on stderr when `ok` is false.
void require(bool ok, const char* what);

}  // namespace penumbra::fuzz

#include "penumbra/core/pbake.h"

namespace penumbra::fuzz {

// The body of a chunk target: `data` as the payload of a chunk of `type` and `version`, read
// (Result<Data> read(const BakeChunk&)) and described; what reads must write (BakeChunk
// write(const Data&)) and read back. Returns 0.
template <class Read, class Write, class Describe>
int chunk_target(const std::uint8_t* data, std::size_t size, std::uint32_t type, std::uint32_t version, Read read,
                 Write write, Describe describe) {
  BakeChunk chunk;
  chunk.type = type;
  chunk.version = version;
  chunk.label = "fuzz";
  chunk.payload.assign(reinterpret_cast<const std::byte*>(data), reinterpret_cast<const std::byte*>(data) + size);
  auto first = read(chunk);
  (void)describe(chunk);
  if (!first) {
    require(!first.error().message.empty(), "a chunk error without a message");
    return 0;
  }
  require(read(write(*first)).ok(), "a chunk that reads does not read back after writing");
  return 0;
}

}  // namespace penumbra::fuzz
