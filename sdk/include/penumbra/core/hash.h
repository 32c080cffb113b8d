// Hashing of bake inputs (to skip re-baking unchanged scenes) and chunk checksums.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>
#include <string_view>
#include <type_traits>
#include <vector>

namespace penumbra {

// 64-bit streaming hash of a byte sequence, for "have the bake inputs changed?" checks (not
// cryptographic). The bytes are read as little-endian 8-byte words; each word is xor-ed into the
// state, which is then mixed with mix64 (random.h), and the total length is folded in at the end.
// The digest depends only on the concatenated bytes, not on how they were split between calls.
// Stable across releases and platforms of the same endianness: baked files store it.
// Cost: about one multiply-xor round per 8 bytes. A Hasher is not thread-safe; use one per thread.
class Hasher {
 public:
  void add_bytes(const void* data, std::size_t size);
  template <class T>
    requires std::is_trivially_copyable_v<T>
  void add(const T& value) { add_bytes(&value, sizeof(T)); }
  template <class T>
    requires std::is_trivially_copyable_v<T>
  void add(std::span<const T> values) {
    add(static_cast<std::uint64_t>(values.size()));
    add_bytes(values.data(), values.size_bytes());
  }
  template <class T>
    requires std::is_trivially_copyable_v<T>
  void add(const std::vector<T>& values) { add(std::span<const T>(values)); }
  // Sizes are hashed as 64-bit values so that the digest does not depend on size_t's width.
  void add(std::string_view s) { add(static_cast<std::uint64_t>(s.size())); add_bytes(s.data(), s.size()); }

  // The hash of everything added so far; the Hasher may keep accepting bytes afterwards.
  std::uint64_t digest() const;

 private:
  void absorb(std::uint64_t word);

  std::uint64_t state_ = 0xcbf29ce484222325ull;
  std::uint64_t length_ = 0;   // bytes added so far
  std::uint64_t pending_ = 0;  // the low (length_ % 8) bytes of the next word
};

// Hasher().add_bytes(data, size).digest().
std::uint64_t hash_bytes(const void* data, std::size_t size);

// CRC-32 (IEEE 802.3, reflected polynomial 0xEDB88320), for chunk checksums. Pass the previous
// result as `crc` to continue over several buffers: crc32(b, nb, crc32(a, na)) == crc32(ab).
// Thread-safe; about 1 ns per byte.
std::uint32_t crc32(const void* data, std::size_t size, std::uint32_t crc = 0);

}  // namespace penumbra
