// Shared pieces of the penumbra command-line tool: argument parsing, exit codes, progress output.
#pragma once

#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "penumbra/bake/baker.h"
#include "penumbra/core/jobs.h"
#include "penumbra/ecs/world.h"
#include "load_world.h"

namespace penumbra::cli {

// Exit codes: 0 success, 1 failure with a message, 2 bad usage.
enum Exit : int { kSuccess = 0, kFailure = 1, kUsage = 2 };

// Arguments after the command name: positional words and --options (with or without a value).
class Args {
 public:
  Args(std::vector<std::string> words) : words_(std::move(words)) {}
  // The value of --name VALUE (or --name=VALUE); removes it. Sets `missing_value` when the option
  // is last and has no value.
  std::optional<std::string> take(std::string_view name);
  bool take_flag(std::string_view name);
  // What is left: positional arguments; an unknown --option left here is a usage error.
  const std::vector<std::string>& rest() const { return words_; }
  bool missing_value = false;
  std::string missing_name;

 private:
  std::vector<std::string> words_;
};

// Prints "penumbra: message" to stderr and returns `code`.
int fail(int code, std::string_view message);
// After `command` took every option it knows from `args`: a usage error (kUsage, printed) naming the
// first word left that looks like an option (-x or --name), or nullopt when none is left.
std::optional<int> reject_unknown_options(const Args& args, std::string_view command);
// Parses a non-negative integer option; prints a usage error on failure.
std::optional<unsigned long long> parse_count(std::string_view option, const std::string& text);

// The thread count of --threads (0 when absent: every hardware thread); prints a usage error and
// returns nullopt for anything but 1..1024.
std::optional<unsigned> parse_threads(const std::optional<std::string>& text);

// A finite number, the whole of `text`; nullopt otherwise.
std::optional<double> parse_number(const std::string& text);

// --sky SKY.exr [--sky-scale K] of bake and render (set_sky_map, load_world.h).
struct SkyOption {
  std::string path;
  float scale = 1.0f;
};
// Takes both options from `args`: nullopt without --sky; false (after printing a usage error)
// for --sky-scale without --sky or a scale that is not a finite number >= 0.
std::optional<SkyOption> take_sky(Args& args, bool& ok);

// A progress bar on stderr when it is a terminal; nothing in a pipe.
ProgressCallback terminal_progress();

int cmd_info(Args args);
int cmd_bake(Args args);
int cmd_merge(Args args);
int cmd_bench(Args args);
int cmd_render(Args args);
int cmd_compare(Args args);
int cmd_validate(Args args);

}  // namespace penumbra::cli
