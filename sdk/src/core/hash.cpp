// Input hashing and CRC-32 (see penumbra/core/hash.h).
#include "penumbra/core/hash.h"

#include <array>

#include "penumbra/core/random.h"

namespace penumbra {

void Hasher::absorb(std::uint64_t word) { state_ = mix64(state_ ^ word); }

void Hasher::add_bytes(const void* data, std::size_t size) {
  const auto* bytes = static_cast<const unsigned char*>(data);
  std::size_t i = 0;
  // Complete the pending word, one byte at a time, in little-endian order.
  while (i < size && (length_ % 8) != 0) {
    pending_ |= static_cast<std::uint64_t>(bytes[i]) << (8 * (length_ % 8));
    ++i;
    if ((++length_ % 8) == 0) {
      absorb(pending_);
      pending_ = 0;
    }
  }
  // Whole words (the shifts compile to a single load on little-endian machines).
  for (; i + 8 <= size; i += 8) {
    std::uint64_t word = 0;
    for (unsigned b = 0; b < 8; ++b) word |= static_cast<std::uint64_t>(bytes[i + b]) << (8 * b);
    absorb(word);
    length_ += 8;
  }
  // The tail starts the next pending word.
  for (; i < size; ++i) {
    pending_ |= static_cast<std::uint64_t>(bytes[i]) << (8 * (length_ % 8));
    ++length_;
  }
}

std::uint64_t Hasher::digest() const {
  // The partial last word and the length make "ab" + "" and "a" + "b\0" hash differently.
  std::uint64_t state = state_;
  if ((length_ % 8) != 0) state = mix64(state ^ pending_);
  return mix64(state ^ length_);
}

std::uint64_t hash_bytes(const void* data, std::size_t size) {
  Hasher h;
  h.add_bytes(data, size);
  return h.digest();
}

namespace {

// The byte-wise table of the reflected CRC-32 polynomial.
constexpr std::array<std::uint32_t, 256> make_crc_table() {
  std::array<std::uint32_t, 256> table{};
  for (std::uint32_t n = 0; n < 256; ++n) {
    std::uint32_t c = n;
    for (int k = 0; k < 8; ++k) c = (c & 1u) ? 0xEDB88320u ^ (c >> 1) : c >> 1;
    table[n] = c;
  }
  return table;
}

constexpr std::array<std::uint32_t, 256> kCrcTable = make_crc_table();

}  // namespace

std::uint32_t crc32(const void* data, std::size_t size, std::uint32_t crc) {
  const auto* bytes = static_cast<const unsigned char*>(data);
  crc = ~crc;
  for (std::size_t i = 0; i < size; ++i) crc = kCrcTable[(crc ^ bytes[i]) & 0xFFu] ^ (crc >> 8);
  return ~crc;
}

}  // namespace penumbra
