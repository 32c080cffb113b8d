// Hashing of bake inputs (to skip re-baking unchanged scenes) and chunk checksums.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>
#include <string_view>
#include <type_traits>
#include <vector>

namespace penumbra {

// 64-bit streaming hash (FNV-1a over 8-byte words, finalised with mix64). Stable across
// platforms of the same endianness and across releases: baked files store it.
class Hasher {
 public:
  void add_bytes(const void* data, std::size_t size);
  template <class T>
    requires std::is_trivially_copyable_v<T>
  void add(const T& value) { add_bytes(&value, sizeof(T)); }
  template <class T>
    requires std::is_trivially_copyable_v<T>
  void add(std::span<const T> values) { add(values.size()); add_bytes(values.data(), values.size_bytes()); }
  template <class T>
    requires std::is_trivially_copyable_v<T>
  void add(const std::vector<T>& values) { add(std::span<const T>(values)); }
  void add(std::string_view s) { add(s.size()); add_bytes(s.data(), s.size()); }

  std::uint64_t digest() const;

 private:
  std::uint64_t state_ = 0xcbf29ce484222325ull;
  std::uint64_t length_ = 0;
};

std::uint64_t hash_bytes(const void* data, std::size_t size);

// CRC-32 (IEEE 802.3, reflected 0xEDB88320), for chunk checksums.
std::uint32_t crc32(const void* data, std::size_t size, std::uint32_t crc = 0);

}  // namespace penumbra
