// Fuzz target "probe_grid": any bytes as the payload of a PRBG chunk of the current version, through
// read_probe_grid_chunk and the module's describe; what reads writes and reads back (fuzz.h).
#include "fuzz/fuzz.h"
#include "penumbra/probe_grid/probe_grid.h"
#include "penumbra/probe_grid/probe_grid_system.h"

extern "C" std::uint32_t penumbra_fuzz_chunk_type() { return penumbra::kProbeGridChunkType; }

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace penumbra;
  return fuzz::chunk_target(data, size, kProbeGridChunkType, kProbeGridChunkVersion, read_probe_grid_chunk, write_probe_grid_chunk, probe_grid_module().describe);
}
