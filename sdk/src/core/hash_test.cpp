#include "penumbra/core/hash.h"

#include <gtest/gtest.h>

#include <string>
#include <vector>

namespace penumbra {
namespace {

TEST(Crc32, KnownVectors) {
  // The standard check value of CRC-32/ISO-HDLC and a few well-known strings.
  EXPECT_EQ(crc32("123456789", 9), 0xCBF43926u);
  EXPECT_EQ(crc32("", 0), 0x00000000u);
  EXPECT_EQ(crc32("a", 1), 0xE8B7BE43u);
  const std::string fox = "The quick brown fox jumps over the lazy dog";
  EXPECT_EQ(crc32(fox.data(), fox.size()), 0x414FA339u);
}

TEST(Crc32, ContinuesAcrossBuffers) {
  const std::string text = "The quick brown fox jumps over the lazy dog";
  for (std::size_t split = 0; split <= text.size(); ++split) {
    EXPECT_EQ(crc32(text.data() + split, text.size() - split, crc32(text.data(), split)),
              crc32(text.data(), text.size()));
  }
}

TEST(Hasher, IndependentOfHowBytesAreSplit) {
  std::vector<unsigned char> bytes(100);
  for (std::size_t i = 0; i < bytes.size(); ++i) bytes[i] = static_cast<unsigned char>(i * 37 + 11);
  const std::uint64_t whole = hash_bytes(bytes.data(), bytes.size());
  for (std::size_t a = 0; a <= bytes.size(); a += 3) {
    for (std::size_t b = a; b <= bytes.size(); b += 7) {
      Hasher h;
      h.add_bytes(bytes.data(), a);
      h.add_bytes(bytes.data() + a, b - a);
      h.add_bytes(bytes.data() + b, bytes.size() - b);
      EXPECT_EQ(h.digest(), whole) << a << " " << b;
    }
  }
}

TEST(Hasher, EverySingleBitChangesTheDigest) {
  std::vector<unsigned char> bytes(37, 0x5a);
  const std::uint64_t base = hash_bytes(bytes.data(), bytes.size());
  std::vector<std::uint64_t> seen{base};
  for (std::size_t i = 0; i < bytes.size() * 8; ++i) {
    bytes[i / 8] ^= static_cast<unsigned char>(1u << (i % 8));
    seen.push_back(hash_bytes(bytes.data(), bytes.size()));
    bytes[i / 8] ^= static_cast<unsigned char>(1u << (i % 8));
  }
  std::sort(seen.begin(), seen.end());
  EXPECT_EQ(std::adjacent_find(seen.begin(), seen.end()), seen.end()) << "two inputs hash alike";
}

TEST(Hasher, PairedHighBitFlipsDoNotCancel) {
  // Plain FNV-1a over 64-bit words maps these two inputs to the same digest.
  std::uint64_t a[2] = {1, 2};
  std::uint64_t b[2] = {1ull ^ (1ull << 63), 2ull ^ (1ull << 63)};
  EXPECT_NE(hash_bytes(a, sizeof a), hash_bytes(b, sizeof b));
}

TEST(Hasher, LengthAndTrailingZerosMatter) {
  const unsigned char zeros[16] = {};
  std::vector<std::uint64_t> digests;
  for (std::size_t n = 0; n <= 16; ++n) digests.push_back(hash_bytes(zeros, n));
  std::sort(digests.begin(), digests.end());
  EXPECT_EQ(std::adjacent_find(digests.begin(), digests.end()), digests.end());
}

TEST(Hasher, TypedAddsSeparateFields) {
  // "ab" + "c" and "a" + "bc" differ because strings are length-prefixed.
  Hasher h1, h2;
  h1.add(std::string_view("ab"));
  h1.add(std::string_view("c"));
  h2.add(std::string_view("a"));
  h2.add(std::string_view("bc"));
  EXPECT_NE(h1.digest(), h2.digest());
  Hasher h3, h4;
  h3.add(std::vector<float>{1.0f, 2.0f});
  h4.add(std::vector<float>{1.0f, 2.0f});
  EXPECT_EQ(h3.digest(), h4.digest());
  h4.add(0.0f);
  EXPECT_NE(h3.digest(), h4.digest());
}

}  // namespace
}  // namespace penumbra
