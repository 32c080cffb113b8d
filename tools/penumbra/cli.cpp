#include "cli.h"

#include <chrono>
#include <cmath>
#include <cstdio>
#include <mutex>
#include <unistd.h>

namespace penumbra::cli {

std::optional<std::string> Args::take(std::string_view name) {
  for (std::size_t i = 0; i < words_.size(); ++i) {
    const std::string& w = words_[i];
    if (w == name) {
      if (i + 1 >= words_.size()) {
        missing_value = true;
        missing_name = std::string(name);
        words_.erase(words_.begin() + static_cast<std::ptrdiff_t>(i));
        return std::nullopt;
      }
      std::string value = words_[i + 1];
      words_.erase(words_.begin() + static_cast<std::ptrdiff_t>(i), words_.begin() + static_cast<std::ptrdiff_t>(i) + 2);
      return value;
    }
    if (w.size() > name.size() && w.compare(0, name.size(), name) == 0 && w[name.size()] == '=') {
      std::string value = w.substr(name.size() + 1);
      words_.erase(words_.begin() + static_cast<std::ptrdiff_t>(i));
      return value;
    }
  }
  return std::nullopt;
}

bool Args::take_flag(std::string_view name) {
  for (std::size_t i = 0; i < words_.size(); ++i) {
    if (words_[i] == name) {
      words_.erase(words_.begin() + static_cast<std::ptrdiff_t>(i));
      return true;
    }
  }
  return false;
}

int fail(int code, std::string_view message) {
  std::fprintf(stderr, "penumbra: %.*s\n", static_cast<int>(message.size()), message.data());
  if (code == kUsage) std::fputs("Run 'penumbra --help' for usage.\n", stderr);
  return code;
}

std::optional<int> reject_unknown_options(const Args& args, std::string_view command) {
  for (const std::string& word : args.rest())
    if (word.size() > 1 && word.starts_with("-"))
      return fail(kUsage, std::string(command) + ": unknown option " + word +
                              " ('penumbra --help' lists the options of each command)");
  return std::nullopt;
}

std::optional<unsigned long long> parse_count(std::string_view option, const std::string& text) {
  if (text.empty() || text.find_first_not_of("0123456789") != std::string::npos || text.size() > 18) {
    fail(kUsage, std::string(option) + " takes a non-negative integer, not '" + text + "'");
    return std::nullopt;
  }
  return std::stoull(text);
}

std::optional<unsigned> parse_threads(const std::optional<std::string>& text) {
  if (!text) return 0u;
  auto n = parse_count("--threads", *text);
  if (!n) return std::nullopt;
  if (*n == 0 || *n > 1024) {
    fail(kUsage, "--threads takes a count from 1 to 1024");
    return std::nullopt;
  }
  return static_cast<unsigned>(*n);
}

std::optional<double> parse_number(const std::string& text) {
  try {
    std::size_t used = 0;
    const double v = std::stod(text, &used);
    if (used != text.size() || !std::isfinite(v)) return std::nullopt;
    return v;
  } catch (const std::exception&) {
    return std::nullopt;
  }
}

std::optional<SkyOption> take_sky(Args& args, bool& ok) {
  ok = true;
  const auto path = args.take("--sky");
  const auto scale = args.take("--sky-scale");
  if (!path) {
    if (scale) ok = fail(kUsage, "--sky-scale scales a --sky map; give --sky SKY.exr too") == kSuccess;
    return std::nullopt;
  }
  SkyOption sky{*path, 1.0f};
  if (scale) {
    const auto v = parse_number(*scale);
    if (!v || *v < 0.0 || *v > 3.0e38) {
      ok = fail(kUsage, "--sky-scale takes a finite number >= 0 (the map's texels are multiplied by it), not '" +
                            *scale + "'") == kSuccess;
      return std::nullopt;
    }
    sky.scale = static_cast<float>(*v);
  }
  return sky;
}

ProgressCallback terminal_progress() {
  if (!::isatty(STDERR_FILENO)) return {};
  struct Bar {
    std::mutex mutex;
    std::string stage;
  };
  auto bar = std::make_shared<Bar>();
  return [bar](const Progress& p) {
    std::lock_guard lock(bar->mutex);
    const int width = 30;
    const int filled = static_cast<int>(p.fraction * width + 0.5);
    std::fprintf(stderr, "\r  [%d/%d] %-28.*s [%s%s] %5.1f%%", p.stage_index, p.stage_count,
                 static_cast<int>(std::min<std::size_t>(p.stage.size(), 28)), p.stage.data(),
                 std::string(static_cast<std::size_t>(filled), '#').c_str(),
                 std::string(static_cast<std::size_t>(width - filled), '.').c_str(), 100.0 * p.fraction);
    if (p.fraction >= 1.0) std::fputc('\n', stderr);
    std::fflush(stderr);
  };
}

}  // namespace penumbra::cli
