// Lighting module descriptors (see module.h).
#include "penumbra/lighting/module.h"

#include <algorithm>

namespace penumbra {

bool LightingModule::owns(std::uint32_t chunk_type) const {
  return std::find(chunk_types.begin(), chunk_types.end(), chunk_type) != chunk_types.end();
}

std::string leading_chunk_key(const BakeChunk& chunk) {
  ByteReader r(chunk.payload, "chunk");
  std::string key;
  return r.read_string(key) ? key : std::string();
}

std::string chunk_label(std::string_view module_name, std::string_view key) {
  std::string label = std::string(module_name) + ":" + std::string(key);
  if (label.size() <= kPbakeMaxLabel) return label;
  // Too long: the key's tail, where sibling paths differ ("pose-ao:~Body/mesh/1").
  const std::string head = std::string(module_name) + ":~";
  const std::size_t keep = kPbakeMaxLabel > head.size() ? kPbakeMaxLabel - head.size() : 0;
  return (head + std::string(key.substr(key.size() - std::min(keep, key.size())))).substr(0, kPbakeMaxLabel);
}

}  // namespace penumbra
