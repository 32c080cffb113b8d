// Deterministic random streams. Every work item (a probe, a vertex, a pixel) draws from its own
// stream, derived from the bake's seed and the item's index, so results do not depend on which
// thread handles the item or in which order.
#pragma once

#include <cstdint>

namespace penumbra {

// SplitMix64 finaliser: a bijective 64-bit mix, used to derive stream seeds.
constexpr std::uint64_t mix64(std::uint64_t x) {
  x += 0x9e3779b97f4a7c15ull;
  x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ull;
  x = (x ^ (x >> 27)) * 0x94d049bb133111ebull;
  return x ^ (x >> 31);
}

// PCG32 (O'Neill 2014, XSH-RR output): 64-bit state, 2^63 selectable streams.
class Rng {
 public:
  // The stream for work item `item` of a computation seeded with `seed`.
  static constexpr Rng stream(std::uint64_t seed, std::uint64_t item) {
    return Rng(mix64(seed ^ mix64(item)), mix64(item + 0x632be59bd9b4e019ull));
  }

  constexpr Rng(std::uint64_t state, std::uint64_t sequence) : inc_((sequence << 1u) | 1u) {
    next_u32();
    state_ += state;
    next_u32();
  }

  constexpr std::uint32_t next_u32() {
    std::uint64_t old = state_;
    state_ = old * 6364136223846793005ull + inc_;
    auto xorshifted = static_cast<std::uint32_t>(((old >> 18u) ^ old) >> 27u);
    auto rot = static_cast<std::uint32_t>(old >> 59u);
    return (xorshifted >> rot) | (xorshifted << ((~rot + 1u) & 31u));
  }

  // Uniform in [0, 1): 24 random bits, so the result is exactly representable and never 1.
  constexpr float next_float() { return static_cast<float>(next_u32() >> 8) * 0x1p-24f; }
  // Uniform in [0, 1) with 53 random bits.
  constexpr double next_double() {
    std::uint64_t hi = next_u32(), lo = next_u32();
    return static_cast<double>(((hi << 32) | lo) >> 11) * 0x1p-53;
  }

 private:
  std::uint64_t state_ = 0;
  std::uint64_t inc_;
};

}  // namespace penumbra
