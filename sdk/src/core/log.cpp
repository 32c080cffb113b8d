// The process-wide log sink: silent until the host installs one (see penumbra/core/log.h).
#include "penumbra/core/log.h"

#include <atomic>
#include <mutex>
#include <utility>

namespace penumbra {
namespace {

struct LogState {
  std::mutex mutex;  // guards sink and serialises calls into it
  LogSink sink;
  std::atomic<int> min_level{static_cast<int>(LogLevel::Info)};
};

LogState& state() {
  static LogState s;
  return s;
}

}  // namespace

const char* to_string(LogLevel level) {
  switch (level) {
    case LogLevel::Debug: return "debug";
    case LogLevel::Info: return "info";
    case LogLevel::Warning: return "warning";
    case LogLevel::Error: return "error";
  }
  return "unknown";
}

void set_log_sink(LogSink sink) {
  LogState& s = state();
  std::lock_guard lock(s.mutex);
  s.sink = std::move(sink);
}

void set_log_level(LogLevel min_level) {
  state().min_level.store(static_cast<int>(min_level), std::memory_order_relaxed);
}

void log(LogLevel level, std::string_view message) {
  LogState& s = state();
  if (static_cast<int>(level) < s.min_level.load(std::memory_order_relaxed)) return;
  std::lock_guard lock(s.mutex);
  if (s.sink) s.sink(level, message);
}

}  // namespace penumbra
