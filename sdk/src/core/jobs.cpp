// Job system: the thread pool, progress in named stages and the fixed-grain parallel-for
// (see penumbra/core/jobs.h).
#include "penumbra/core/jobs.h"

#include <algorithm>
#include <chrono>
#include <condition_variable>
#include <mutex>
#include <thread>
#include <vector>

namespace penumbra {

// ---------------------------------------------------------------------------------------------
// ThreadPool

namespace {

// One call to ThreadPool::run: items are claimed through `next`.
struct PoolJob {
  std::size_t count = 0;
  const std::function<void(std::size_t)>* task = nullptr;
  std::atomic<std::size_t> next{0};

  void work() {
    for (std::size_t i = next.fetch_add(1, std::memory_order_relaxed); i < count;
         i = next.fetch_add(1, std::memory_order_relaxed)) {
      (*task)(i);
    }
  }
};

}  // namespace

struct ThreadPool::Impl {
  std::vector<std::thread> workers;
  std::mutex mutex;                  // guards job, generation, active, stop
  std::condition_variable work_cv;   // a job was posted, or stop
  std::condition_variable idle_cv;   // a worker left the job
  PoolJob* job = nullptr;
  std::uint64_t generation = 0;
  unsigned active = 0;               // workers currently inside `job`
  bool stop = false;
  std::mutex run_mutex;              // one run() at a time from outside the pool

  void worker_loop();
};

namespace {
// The pool whose run() the current thread is inside (as a worker or as the caller): a nested
// run() on the same pool executes serially instead of deadlocking.
thread_local const void* t_current_pool = nullptr;
}  // namespace

void ThreadPool::Impl::worker_loop() {
  t_current_pool = this;
  std::uint64_t seen = 0;
  std::unique_lock lock(mutex);
  for (;;) {
    work_cv.wait(lock, [&] { return stop || (job != nullptr && generation != seen); });
    if (stop) return;
    seen = generation;
    PoolJob* current = job;
    ++active;
    lock.unlock();
    current->work();
    lock.lock();
    if (--active == 0) idle_cv.notify_all();
  }
}

ThreadPool::ThreadPool(unsigned threads) : impl_(std::make_unique<Impl>()) {
  if (threads == 0) threads = std::max(1u, std::thread::hardware_concurrency());
  // The caller takes part in run(), so threads - 1 workers give `threads`-way parallelism.
  impl_->workers.reserve(threads - 1);
  for (unsigned i = 1; i < threads; ++i) impl_->workers.emplace_back([impl = impl_.get()] { impl->worker_loop(); });
}

ThreadPool::~ThreadPool() {
  {
    std::lock_guard lock(impl_->mutex);
    impl_->stop = true;
  }
  impl_->work_cv.notify_all();
  for (std::thread& t : impl_->workers) t.join();
}

unsigned ThreadPool::concurrency() const { return static_cast<unsigned>(impl_->workers.size()) + 1; }

void ThreadPool::run(std::size_t count, const std::function<void(std::size_t)>& task) {
  if (count == 0) return;
  if (t_current_pool == impl_.get() || impl_->workers.empty() || count == 1) {
    for (std::size_t i = 0; i < count; ++i) task(i);
    return;
  }
  std::lock_guard run_lock(impl_->run_mutex);
  const void* outer = t_current_pool;
  t_current_pool = impl_.get();

  PoolJob job;
  job.count = count;
  job.task = &task;
  {
    std::lock_guard lock(impl_->mutex);
    impl_->job = &job;
    ++impl_->generation;
  }
  impl_->work_cv.notify_all();
  job.work();
  // Every item is claimed; wait for the workers still finishing theirs, then retire the job so
  // that a late-waking worker does not touch it.
  {
    std::unique_lock lock(impl_->mutex);
    impl_->idle_cv.wait(lock, [&] { return impl_->active == 0; });
    impl_->job = nullptr;
  }
  t_current_pool = outer;
}

// ---------------------------------------------------------------------------------------------
// JobContext

struct JobContext::State {
  ProgressCallback callback;
  std::mutex mutex;  // serialises reports; guards the fields below
  std::string stage;
  int stage_index = 0;
  int stage_count = 0;
  std::uint64_t stage_units = 0;
  double last_fraction = -1.0;
  bool stage_ended = false;
  std::atomic<std::uint64_t> done{0};
  std::atomic<std::int64_t> last_report_ns{0};

  static std::int64_t now_ns() {
    return std::chrono::duration_cast<std::chrono::nanoseconds>(
               std::chrono::steady_clock::now().time_since_epoch())
        .count();
  }

  // Sends one report with the mutex held. Fractions of a stage only grow, and the end report
  // (fraction 1) is sent exactly once.
  void report_locked(double fraction, bool end) {
    if (stage_ended || fraction < last_fraction || (fraction == last_fraction && !end)) return;
    last_fraction = fraction;
    stage_ended = end;
    last_report_ns.store(now_ns(), std::memory_order_relaxed);
    if (callback) callback(Progress{stage, stage_index, std::max(stage_count, stage_index), fraction});
  }

  double fraction_locked() const {
    if (stage_units == 0) return 1.0;
    return std::min(1.0, static_cast<double>(done.load(std::memory_order_relaxed)) /
                             static_cast<double>(stage_units));
  }
};

namespace {
constexpr std::int64_t kReportIntervalNs = 50'000'000;  // 50 ms between throttled reports
}

JobContext::JobContext() : state_(std::make_unique<State>()) {}

JobContext::JobContext(TaskScheduler* scheduler, ProgressCallback progress, const CancelToken* cancel)
    : scheduler_(scheduler), cancel_(cancel), state_(std::make_unique<State>()) {
  state_->callback = std::move(progress);
}

JobContext::~JobContext() = default;

void JobContext::set_stage_count(int count) {
  std::lock_guard lock(state_->mutex);
  state_->stage_count = count;
}

void JobContext::begin_stage(std::string name, std::uint64_t work_units) {
  State& s = *state_;
  std::lock_guard lock(s.mutex);
  // Close the previous stage if its work did not reach its declared units.
  if (s.stage_index > 0 && !s.stage_ended) s.report_locked(s.fraction_locked(), true);
  s.stage = std::move(name);
  ++s.stage_index;
  s.stage_units = work_units;
  s.done.store(0, std::memory_order_relaxed);
  s.last_fraction = -1.0;
  s.stage_ended = false;
  s.report_locked(0.0, false);
  if (work_units == 0) s.report_locked(1.0, true);
}

void JobContext::advance(std::uint64_t units) {
  State& s = *state_;
  if (units == 0 || s.stage_index == 0) return;
  const std::uint64_t before = s.done.fetch_add(units, std::memory_order_relaxed);
  const std::uint64_t after = before + units;
  const bool crossed_end = before < s.stage_units && after >= s.stage_units;
  if (!crossed_end &&
      State::now_ns() - s.last_report_ns.load(std::memory_order_relaxed) < kReportIntervalNs) {
    return;
  }
  std::lock_guard lock(s.mutex);
  if (crossed_end) {
    s.report_locked(1.0, true);
  } else if (State::now_ns() - s.last_report_ns.load(std::memory_order_relaxed) >= kReportIntervalNs) {
    s.report_locked(s.fraction_locked(), false);
  }
}

unsigned JobContext::concurrency() const { return scheduler_ != nullptr ? scheduler_->concurrency() : 1u; }

Status JobContext::parallel_for(std::size_t count, std::size_t grain,
                                const std::function<void(std::size_t begin, std::size_t end)>& fn) {
  if (grain == 0) grain = 1;
  const std::size_t chunks = (count + grain - 1) / grain;
  std::atomic<bool> skipped{false};
  auto run_chunk = [&](std::size_t chunk) {
    if (cancelled()) {
      skipped.store(true, std::memory_order_relaxed);
      return;
    }
    const std::size_t begin = chunk * grain;
    const std::size_t end = std::min(count, begin + grain);
    fn(begin, end);
    advance(end - begin);
  };
  if (scheduler_ != nullptr) {
    scheduler_->run(chunks, run_chunk);
  } else {
    for (std::size_t c = 0; c < chunks; ++c) run_chunk(c);
  }
  if (skipped.load(std::memory_order_relaxed)) {
    std::string stage;
    {
      std::lock_guard lock(state_->mutex);
      stage = state_->stage;
    }
    return make_error(ErrorCode::Cancelled,
                      stage.empty() ? std::string("cancelled by the host")
                                    : "cancelled by the host during stage '" + stage + "'");
  }
  return {};
}

}  // namespace penumbra
