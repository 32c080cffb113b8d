// One computation on a worker thread with its own thread pool, its result taken once by the main
// thread: how the editor computes its heat maps without stalling the frame. Main thread only
// (the worker touches nothing but what the function captured).
#pragma once

#include <atomic>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <thread>

#include "penumbra/core/jobs.h"
#include "penumbra/core/result.h"

namespace penumbra::editor {

template <class T>
class BackgroundJob {
 public:
  BackgroundJob() = default;
  ~BackgroundJob() {
    cancel();
    if (worker_.joinable()) worker_.join();
  }
  BackgroundJob(const BackgroundJob&) = delete;
  BackgroundJob& operator=(const BackgroundJob&) = delete;

  // Runs fn on a worker with a pool of `threads` (0: one per hardware thread). InvalidArgument
  // naming `what` while one runs (an earlier result not yet taken is dropped).
  Status start(const char* what, unsigned threads, std::function<Result<T>(JobContext&)> fn) {
    if (running()) return make_error(ErrorCode::InvalidArgument, std::string(what) + ": one is being computed; wait for it");
    if (worker_.joinable()) worker_.join();
    done_ = false;
    {
      std::lock_guard lock(mutex_);
      result_.reset();
    }
    cancel_ = std::make_unique<CancelToken>();
    worker_ = std::thread([this, threads, fn = std::move(fn), cancel = cancel_.get()] {
      ThreadPool pool(threads);
      JobContext jobs(&pool, {}, cancel);
      Result<T> r = fn(jobs);
      std::lock_guard lock(mutex_);
      result_.emplace(std::move(r));
      done_ = true;
    });
    return {};
  }
  bool running() const { return worker_.joinable() && !done_; }
  // The finished result (or its error) once, then nullopt.
  std::optional<Result<T>> take() {
    if (!done_) return std::nullopt;
    if (worker_.joinable()) worker_.join();
    std::lock_guard lock(mutex_);
    std::optional<Result<T>> out;
    out.swap(result_);
    return out;
  }
  // Asks the running computation to stop (it then finishes with Cancelled).
  void cancel() {
    if (cancel_) cancel_->cancel();
  }

 private:
  std::thread worker_;
  std::unique_ptr<CancelToken> cancel_;
  std::atomic<bool> done_{false};
  std::mutex mutex_;
  std::optional<Result<T>> result_;
};

}  // namespace penumbra::editor
