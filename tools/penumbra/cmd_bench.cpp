// penumbra bench NAME [--quick] [--out DIR] [--threads N]
#include <chrono>
#include <cstdio>
#include <filesystem>

#include "../../bench/bench.h"
#include "cli.h"

namespace penumbra::cli {

int cmd_bench(Args args) {
  const bool list = args.take_flag("--list");
  bench::Options options;
  options.quick = args.take_flag("--quick");
  const std::string out_dir = args.take("--out").value_or("bench-results");
  options.out_dir = out_dir;
  if (auto threads = args.take("--threads")) {
    auto n = parse_count("--threads", *threads);
    if (!n) return kUsage;
    options.threads = static_cast<unsigned>(*n);
  }
  if (args.missing_value) return fail(kUsage, args.missing_name + " needs a value");

  if (list) {
    for (const auto& e : bench::registry()) std::printf("%-12s %s\n", e.name.c_str(), e.description.c_str());
    return kSuccess;
  }
  if (const auto unknown = reject_unknown_options(args, "bench")) return *unknown;
  if (args.rest().size() != 1)
    return fail(kUsage, "bench takes one benchmark name ('penumbra bench --list' names them)");
  const std::string& name = args.rest()[0];

  const bench::Entry* entry = nullptr;
  for (const auto& e : bench::registry()) if (e.name == name) entry = &e;
  if (entry == nullptr) {
    std::string known;
    for (const auto& e : bench::registry()) known += (known.empty() ? "" : ", ") + e.name;
    return fail(kUsage, "no benchmark named '" + name + "'; known: " + known);
  }

  std::error_code ec;
  std::filesystem::create_directories(out_dir, ec);
  if (ec) return fail(kFailure, out_dir + ": cannot create the output directory (" + ec.message() + ")");

  std::printf("penumbra bench %s%s: %s\n", name.c_str(), options.quick ? " (quick)" : "", entry->description.c_str());
  std::fflush(stdout);
  const auto start = std::chrono::steady_clock::now();
  Result<bench::Report> report = entry->fn(options);
  if (!report) return fail(kFailure, "bench " + name + ": " + report.error().message);
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();

  std::printf("\n%s\n", bench::format_table(*report).c_str());
  const std::string csv = (std::filesystem::path(out_dir) / (name + ".csv")).string();
  const std::string png = (std::filesystem::path(out_dir) / (name + ".png")).string();
  if (Status s = bench::write_csv(csv, *report); !s) return fail(kFailure, s.error().message);
  std::printf("wrote %s\n", csv.c_str());
  if (Status s = bench::write_plot(png, csv, *report); !s) return fail(kFailure, s.error().message);
  std::printf("wrote %s\n", png.c_str());
  std::printf("bench %s took %.1f s\n", name.c_str(), seconds);
  return kSuccess;
}

}  // namespace penumbra::cli
