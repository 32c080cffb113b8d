// Job system: parallel-for with a fixed work decomposition, progress in named stages,
// cancellation, and a hook for a host-supplied task scheduler.
//
// Determinism: parallel_for splits [0, count) into chunks of `grain` items whatever the thread
// count; callers give each item its own random stream (random.h) and write results by index, so
// output is bit-identical at any thread count.
#pragma once

#include <atomic>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <string_view>

#include "penumbra/core/result.h"

namespace penumbra {

// The host's scheduler. run() executes task(i) for every i in [0, count), possibly in parallel,
// and returns when all have finished. Tasks never throw.
class TaskScheduler {
 public:
  virtual ~TaskScheduler() = default;
  virtual unsigned concurrency() const = 0;
  virtual void run(std::size_t count, const std::function<void(std::size_t)>& task) = 0;
};

// Penumbra's default scheduler: a fixed pool of threads - 1 workers plus the calling thread, which
// takes part in run(). threads == 0 means one per hardware thread; threads == 1 runs serially.
// run() may be called from several threads (calls are served one at a time) and from inside a
// task of the same pool (the nested call runs serially on the calling thread).
class ThreadPool final : public TaskScheduler {
 public:
  explicit ThreadPool(unsigned threads = 0);
  ~ThreadPool() override;
  ThreadPool(const ThreadPool&) = delete;
  ThreadPool& operator=(const ThreadPool&) = delete;

  unsigned concurrency() const override;
  void run(std::size_t count, const std::function<void(std::size_t)>& task) override;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// Cancellation flag shared between the host (UI thread) and the work.
class CancelToken {
 public:
  void cancel() { flag_.store(true, std::memory_order_relaxed); }
  bool cancelled() const { return flag_.load(std::memory_order_relaxed); }

 private:
  std::atomic<bool> flag_{false};
};

// One progress report: stage `stage_index` (1-based) of `stage_count` named `stage`, `fraction` in
// [0, 1]. Within a stage the fractions reported never decrease and the last one is exactly 1.
struct Progress {
  std::string_view stage;
  int stage_index = 0;
  int stage_count = 0;
  double fraction = 0.0;
};

// Called from any thread, serialised, at most about every 50 ms per stage plus once at each
// stage's start and end.
using ProgressCallback = std::function<void(const Progress&)>;

// What long work receives: where to run, whom to tell, whether to stop.
// A default-constructed context runs serially, reports nothing and is never cancelled.
class JobContext {
 public:
  JobContext();
  JobContext(TaskScheduler* scheduler, ProgressCallback progress = {}, const CancelToken* cancel = nullptr);
  ~JobContext();
  JobContext(const JobContext&) = delete;
  JobContext& operator=(const JobContext&) = delete;

  // Declares how many stages the work has in total (for "stage 2 of 5" reports).
  void set_stage_count(int count);
  // Starts the next named stage with `work_units` units of work to report through advance(),
  // closing the previous stage (a final report) if its units were not all advanced. Call from
  // the thread that drives the work, not from inside parallel_for.
  void begin_stage(std::string name, std::uint64_t work_units);
  // Reports `units` more units done in the current stage. Thread-safe.
  void advance(std::uint64_t units);

  bool cancelled() const { return cancel_ != nullptr && cancel_->cancelled(); }
  unsigned concurrency() const;

  // Runs fn(begin, end) over [0, count) in chunks of `grain` items (the last one shorter; grain 0
  // means 1), in parallel on the scheduler, advancing progress by each chunk's size. Chunks not
  // yet started when cancellation is seen are skipped and the result is ErrorCode::Cancelled;
  // chunks already running finish. The chunk boundaries depend only on count and grain.
  Status parallel_for(std::size_t count, std::size_t grain,
                      const std::function<void(std::size_t begin, std::size_t end)>& fn);

 private:
  struct State;
  TaskScheduler* scheduler_ = nullptr;
  const CancelToken* cancel_ = nullptr;
  std::unique_ptr<State> state_;
};

}  // namespace penumbra
