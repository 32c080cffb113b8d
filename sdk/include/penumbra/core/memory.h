// Memory accounting. Every baked artifact reports its size in bytes; bakers check a budget before
// they allocate, so a request that would not fit fails with a clear error instead of an
// allocation failure halfway through.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "penumbra/core/result.h"

namespace penumbra {

// Bytes held by a vector's elements (its capacity).
template <class T>
std::size_t bytes_of(const std::vector<T>& v) { return v.capacity() * sizeof(T); }

// "1.5 MiB", "812 B": for reports.
std::string format_bytes(std::uint64_t bytes);

// A limit on what a computation may allocate, checked before allocating. Not thread-safe: one
// budget belongs to the thread that plans a computation's allocations.
class MemoryBudget {
 public:
  // limit_bytes == 0 means unlimited.
  explicit MemoryBudget(std::uint64_t limit_bytes = 0) : limit_(limit_bytes) {}

  // Reserves `bytes` for `what`; fails with ErrorCode::OutOfBudget naming `what`, the request,
  // what is already reserved and the limit, and suggesting a smaller setting.
  Status reserve(std::string_view what, std::uint64_t bytes);
  // Returns `bytes` of an earlier reservation (releasing more than is reserved is a bug).
  void release(std::uint64_t bytes);

  std::uint64_t limit() const { return limit_; }
  std::uint64_t reserved() const { return reserved_; }
  std::uint64_t peak() const { return peak_; }

 private:
  std::uint64_t limit_ = 0;
  std::uint64_t reserved_ = 0;
  std::uint64_t peak_ = 0;
};

}  // namespace penumbra
