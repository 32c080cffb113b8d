// Memory accounting (see penumbra/core/memory.h).
#include "penumbra/core/memory.h"

#include <algorithm>
#include <cassert>
#include <cstdio>

namespace penumbra {

std::string format_bytes(std::uint64_t bytes) {
  static constexpr const char* kUnits[] = {"B", "KiB", "MiB", "GiB", "TiB", "PiB", "EiB"};
  if (bytes < 1024) return std::to_string(bytes) + " B";
  auto value = static_cast<double>(bytes);
  int unit = 0;
  while (value >= 1024.0 && unit < 6) {
    value /= 1024.0;
    ++unit;
  }
  char text[32];
  std::snprintf(text, sizeof text, value < 10.0 ? "%.2f %s" : value < 100.0 ? "%.1f %s" : "%.0f %s", value,
                kUnits[unit]);
  return text;
}

Status MemoryBudget::reserve(std::string_view what, std::uint64_t bytes) {
  // Compare against the headroom rather than reserved_ + bytes, which could overflow.
  if (limit_ != 0 && (reserved_ > limit_ || bytes > limit_ - reserved_)) {
    return make_error(ErrorCode::OutOfBudget,
                      std::string(what) + " needs " + format_bytes(bytes) + " but " + format_bytes(reserved_) +
                          " of the " + format_bytes(limit_) +
                          " memory budget is already reserved; lower the quality setting (resolution, sample "
                          "count) or raise the budget");
  }
  reserved_ += bytes;
  peak_ = std::max(peak_, reserved_);
  return {};
}

void MemoryBudget::release(std::uint64_t bytes) {
  assert(bytes <= reserved_ && "MemoryBudget::release: releasing more than was reserved");
  reserved_ -= std::min(bytes, reserved_);
}

}  // namespace penumbra
