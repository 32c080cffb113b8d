// Fuzz target "ao_field": any bytes as the payload of a AOFC chunk of the current version, through
// read_ao_field_chunk and the module's describe; what reads writes and reads back (fuzz.h).
#include "fuzz/fuzz.h"
#include "penumbra/ao_field/ao_field.h"
#include "penumbra/ao_field/ao_field_system.h"

extern "C" std::uint32_t penumbra_fuzz_chunk_type() { return penumbra::kAOFieldChunkType; }

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace penumbra;
  return fuzz::chunk_target(data, size, kAOFieldChunkType, kAOFieldChunkVersion, read_ao_field_chunk, write_ao_field_chunk, ao_field_module().describe);
}
