// Fuzz target "pose_ao": any bytes as the payload of a PSAO chunk of the current version, through
// read_pose_ao_chunk and the module's describe; what reads writes and reads back (fuzz.h).
#include "fuzz/fuzz.h"
#include "penumbra/pose_ao/pose_ao.h"
#include "penumbra/pose_ao/pose_ao_system.h"

extern "C" std::uint32_t penumbra_fuzz_chunk_type() { return penumbra::kPoseAOChunkType; }

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace penumbra;
  return fuzz::chunk_target(data, size, kPoseAOChunkType, kPoseAOChunkVersion, read_pose_ao_chunk, write_pose_ao_chunk, pose_ao_module().describe);
}
