// Fuzz target "vertex_ao": any bytes as the payload of a VXAO chunk of the current version, through
// read_vertex_ao_chunk and the module's describe; what reads writes and reads back (fuzz.h).
#include "fuzz/fuzz.h"
#include "penumbra/vertex_ao/vertex_ao.h"
#include "penumbra/vertex_ao/vertex_ao_system.h"

extern "C" std::uint32_t penumbra_fuzz_chunk_type() { return penumbra::kVertexAoChunkType; }

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace penumbra;
  return fuzz::chunk_target(data, size, kVertexAoChunkType, kVertexAoChunkVersion, read_vertex_ao_chunk, write_vertex_ao_chunk, vertex_ao_module().describe);
}
