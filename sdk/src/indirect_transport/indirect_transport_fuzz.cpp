// Fuzz target "indirect-transport": any bytes as the payload of a WRTO chunk of the current
// version, through read_transport_chunk and the module's describe, and, when it reads, one update
// with the operator and the bounce probes it holds and a probe lookup; what reads writes and reads
// back (fuzz.h).
#include <vector>

#include "fuzz/fuzz.h"
#include "penumbra/indirect_transport/indirect_transport.h"
#include "penumbra/indirect_transport/indirect_transport_system.h"

extern "C" std::uint32_t penumbra_fuzz_chunk_type() { return penumbra::kTransportChunkType; }

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace penumbra;
  const auto write = [](const TransportChunk& c) { return write_transport_chunk(c.key, c.data); };
  fuzz::chunk_target(data, size, kTransportChunkType, kTransportChunkVersion, read_transport_chunk, write,
                     indirect_transport_module().describe);
  BakeChunk chunk{kTransportChunkType, kTransportChunkVersion, "fuzz",
                  std::vector<std::byte>(reinterpret_cast<const std::byte*>(data),
                                         reinterpret_cast<const std::byte*>(data) + size)};
  auto read = read_transport_chunk(chunk);
  if (read && read->data.leaf_count() <= (1u << 16)) {
    std::vector<glm::vec3> direct(read->data.leaf_count(), glm::vec3(1.0f)), indirect(read->data.leaf_count());
    apply_transport(read->data, direct, indirect);
    const TransportProbes& probes = read->data.probes;
    std::vector<glm::vec3> cubes(6 * probes.nodes());
    bounce_probe_irradiance(read->data, direct, indirect, cubes);
    (void)sample_bounce_probes(probes, cubes, probes.origin + 1.5f * probes.spacing, glm::vec3(0.0f, -1.0f, 0.0f));
  }
  return 0;
}
