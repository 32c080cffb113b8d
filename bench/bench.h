// Benchmarks run by `penumbra bench NAME [--quick] [--out DIR]`.
//
// A benchmark is a function that measures and returns a Report; the tool prints the report as a
// table, writes DIR/NAME.csv and plots DIR/NAME.png. Speed goals are judged by ratios measured
// side by side in the same run (the machines are shared and noisy), printed in Report::notes.
#pragma once

#include <functional>
#include <string>
#include <vector>

#include <benchmark/benchmark.h>

#include "penumbra/core/result.h"

namespace penumbra::bench {

struct Options {
  bool quick = false;    // a small sweep for CI and smoke tests
  unsigned threads = 0;  // 0: all hardware threads
  std::string out_dir;   // where the tool writes NAME.csv and NAME.png; benches may add images there
};

// What to plot: y against x, one line per distinct value of the series column (-1: one line).
struct Plot {
  std::string title, x_label, y_label;
  int x_column = 0;
  int y_column = 1;
  int series_column = -1;
  bool log_x = false;
  bool log_y = false;
  bool points_only = false;  // a scatter (e.g. error against cost) rather than lines through the rows
};

struct Report {
  std::vector<std::string> columns;
  std::vector<std::vector<std::string>> rows;  // CSV cells, one per column
  Plot plot;
  std::vector<std::string> notes;  // printed after the table: ratios against goals, references
};

using Function = std::function<Result<Report>(const Options&)>;

// Registers a benchmark under `name` (static registration, see PENUMBRA_BENCH below).
bool register_bench(std::string name, std::string description, Function fn);

struct Entry {
  std::string name, description;
  Function fn;
};
const std::vector<Entry>& registry();

// Runs Google Benchmark cases in this process and returns each case's measurement.
struct Case {
  std::string name;
  std::function<void(benchmark::State&)> body;
};
struct Measurement {
  std::string name;
  double ns_per_iteration = 0.0;  // real time
  double items_per_second = 0.0;  // from state.SetItemsProcessed, 0 when not set
  double iterations = 0.0;
};
// min_time: seconds per case (Google Benchmark's --benchmark_min_time); repetitions > 1 reports
// the median. Measurements come back in the order of `cases`.
std::vector<Measurement> run_cases(const std::vector<Case>& cases, double min_time, int repetitions = 1);

// "%.4g"-style formatting for CSV cells and table entries.
std::string fmt(double value, int precision = 4);

// Output of a finished benchmark: the table as text (columns aligned, notes below), and the files
// DIR/NAME.csv and DIR/NAME.png (the plot is drawn by gnuplot; without gnuplot the CSV is still
// written and the error says so). Files are written to a temporary name and renamed.
std::string format_table(const Report& report);
Status write_csv(const std::string& path, const Report& report);
Status write_plot(const std::string& png_path, const std::string& csv_path, const Report& report);

}  // namespace penumbra::bench

#define PENUMBRA_BENCH_CONCAT2(a, b) a##b
#define PENUMBRA_BENCH_CONCAT(a, b) PENUMBRA_BENCH_CONCAT2(a, b)
// PENUMBRA_BENCH("ecs", "ECS iteration, creation and access against raw vectors", fn);
#define PENUMBRA_BENCH(name, description, fn) \
  static const bool PENUMBRA_BENCH_CONCAT(penumbra_bench_registered_, __LINE__) = \
      ::penumbra::bench::register_bench(name, description, fn)
