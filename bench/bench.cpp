// Benchmark registry and the Google Benchmark runner used by every `penumbra bench` case.
#include "bench.h"

#include <algorithm>
#include <cstdio>
#include <map>

namespace penumbra::bench {

namespace {

std::vector<Entry>& mutable_registry() {
  static std::vector<Entry> entries;
  return entries;
}

// Collects the measurements of each run (or the median aggregate when repeated) instead of printing.
class CollectingReporter final : public benchmark::BenchmarkReporter {
 public:
  bool ReportContext(const Context&) override { return true; }
  void ReportRuns(const std::vector<Run>& runs) override {
    for (const Run& run : runs) {
      if (run.error_occurred) continue;
      const bool aggregate = run.run_type == Run::RT_Aggregate;
      if (repeated_ ? !(aggregate && run.aggregate_name == "median") : aggregate) continue;
      Measurement m;
      m.name = run.run_name.function_name;
      m.ns_per_iteration = run.GetAdjustedRealTime() * to_ns(run.time_unit);
      m.iterations = static_cast<double>(run.iterations);
      if (auto it = run.counters.find("items_per_second"); it != run.counters.end()) m.items_per_second = it->second;
      results[m.name] = m;
    }
  }
  explicit CollectingReporter(bool repeated) : repeated_(repeated) {}
  std::map<std::string, Measurement> results;

 private:
  static double to_ns(benchmark::TimeUnit unit) {
    switch (unit) {
      case benchmark::kNanosecond: return 1.0;
      case benchmark::kMicrosecond: return 1e3;
      case benchmark::kMillisecond: return 1e6;
      case benchmark::kSecond: return 1e9;
    }
    return 1.0;
  }
  bool repeated_;
};

}  // namespace

bool register_bench(std::string name, std::string description, Function fn) {
  auto& entries = mutable_registry();
  entries.push_back({std::move(name), std::move(description), std::move(fn)});
  std::sort(entries.begin(), entries.end(), [](const Entry& a, const Entry& b) { return a.name < b.name; });
  return true;
}

const std::vector<Entry>& registry() { return mutable_registry(); }

std::vector<Measurement> run_cases(const std::vector<Case>& cases, double min_time, int repetitions) {
  benchmark::ClearRegisteredBenchmarks();
  for (const Case& c : cases) {
    auto* b = benchmark::RegisterBenchmark(c.name.c_str(), [body = c.body](benchmark::State& state) { body(state); });
    b->MinTime(min_time)->UseRealTime();
    if (repetitions > 1) b->Repetitions(repetitions)->ReportAggregatesOnly(true);
  }
  CollectingReporter reporter(repetitions > 1);
  benchmark::RunSpecifiedBenchmarks(&reporter);
  benchmark::ClearRegisteredBenchmarks();

  std::vector<Measurement> out;
  out.reserve(cases.size());
  for (const Case& c : cases) {
    auto it = reporter.results.find(c.name);
    Measurement m = it != reporter.results.end() ? it->second : Measurement{c.name, 0.0, 0.0, 0.0};
    out.push_back(m);
  }
  return out;
}

std::string fmt(double value, int precision) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.*g", precision, value);
  return buf;
}

}  // namespace penumbra::bench
