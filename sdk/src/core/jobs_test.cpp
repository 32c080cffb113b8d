#include "penumbra/core/jobs.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstring>
#include <mutex>
#include <set>
#include <vector>

#include "penumbra/core/random.h"

namespace penumbra {
namespace {

// A per-item computation with its own random stream: a short random walk.
std::vector<double> compute(JobContext& ctx, std::size_t n) {
  std::vector<double> out(n);
  ctx.begin_stage("walk", n);
  Status s = ctx.parallel_for(n, 7, [&](std::size_t begin, std::size_t end) {
    for (std::size_t i = begin; i < end; ++i) {
      Rng rng = Rng::stream(1234, i);
      double x = 0.0;
      for (int k = 0; k < 100; ++k) x += rng.next_double() - 0.5;
      out[i] = x;
    }
  });
  EXPECT_TRUE(s.ok());
  return out;
}

TEST(ThreadPool, RunsEveryIndexExactlyOnce) {
  for (unsigned threads : {1u, 2u, 4u}) {
    ThreadPool pool(threads);
    EXPECT_EQ(pool.concurrency(), threads);
    for (std::size_t count : {0u, 1u, 5u, 1000u}) {
      std::vector<std::atomic<int>> hits(count);
      pool.run(count, [&](std::size_t i) { hits[i].fetch_add(1); });
      for (std::size_t i = 0; i < count; ++i) EXPECT_EQ(hits[i].load(), 1);
    }
  }
}

TEST(ThreadPool, NestedRunDoesNotDeadlock) {
  ThreadPool pool(2);
  std::atomic<int> total{0};
  pool.run(8, [&](std::size_t) { pool.run(8, [&](std::size_t) { total.fetch_add(1); }); });
  EXPECT_EQ(total.load(), 64);
}

TEST(JobContext, BitIdenticalAtOneAndTwoThreads) {
  JobContext serial;
  const std::vector<double> a = compute(serial, 1001);
  ThreadPool one(1), two(2);
  JobContext c1(&one), c2(&two);
  const std::vector<double> b = compute(c1, 1001);
  const std::vector<double> c = compute(c2, 1001);
  ASSERT_EQ(a.size(), c.size());
  EXPECT_EQ(std::memcmp(a.data(), b.data(), a.size() * sizeof(double)), 0);
  EXPECT_EQ(std::memcmp(a.data(), c.data(), a.size() * sizeof(double)), 0);
  // Different items really draw different numbers.
  EXPECT_NE(a[0], a[1]);
}

TEST(JobContext, ChunksDependOnlyOnCountAndGrain) {
  for (unsigned threads : {1u, 2u}) {
    ThreadPool pool(threads);
    JobContext ctx(&pool);
    std::mutex m;
    std::set<std::pair<std::size_t, std::size_t>> chunks;
    ASSERT_TRUE(ctx.parallel_for(23, 5, [&](std::size_t b, std::size_t e) {
                     std::lock_guard lock(m);
                     chunks.insert({b, e});
                   }).ok());
    const std::set<std::pair<std::size_t, std::size_t>> expected = {{0, 5}, {5, 10}, {10, 15}, {15, 20}, {20, 23}};
    EXPECT_EQ(chunks, expected);
  }
}

TEST(JobContext, CancellationSkipsRemainingChunks) {
  for (unsigned threads : {1u, 2u}) {
    ThreadPool pool(threads);
    CancelToken cancel;
    JobContext ctx(&pool, {}, &cancel);
    ctx.begin_stage("trace", 1000);
    std::atomic<int> chunks_run{0};
    Status s = ctx.parallel_for(1000, 1, [&](std::size_t b, std::size_t) {
      chunks_run.fetch_add(1);
      if (b == 10) cancel.cancel();
    });
    ASSERT_FALSE(s.ok());
    EXPECT_EQ(s.error().code, ErrorCode::Cancelled);
    EXPECT_NE(s.error().message.find("trace"), std::string::npos) << s.error().message;
    EXPECT_LT(chunks_run.load(), 1000);
    EXPECT_TRUE(ctx.cancelled());
  }
  // A default context is never cancelled.
  JobContext plain;
  EXPECT_FALSE(plain.cancelled());
  EXPECT_EQ(plain.concurrency(), 1u);
}

TEST(JobContext, ReportsStagesInOrderWithMonotonicFractions) {
  ThreadPool pool(2);
  std::vector<Progress> reports;
  std::vector<std::string> names;
  JobContext ctx(&pool, [&](const Progress& p) {
    reports.push_back(p);
    names.emplace_back(p.stage);
  });
  ctx.set_stage_count(3);
  ctx.begin_stage("build", 100);
  ASSERT_TRUE(ctx.parallel_for(100, 3, [](std::size_t, std::size_t) {}).ok());
  ctx.begin_stage("empty", 0);
  ctx.begin_stage("partial", 10);
  ctx.advance(4);
  ctx.begin_stage("extra", 1);  // more stages than declared: stage_count grows with the index
  ctx.advance(1);

  ASSERT_FALSE(reports.empty());
  int stage = 0;
  double last = -1.0;
  for (std::size_t i = 0; i < reports.size(); ++i) {
    const Progress& p = reports[i];
    if (p.stage_index != stage) {
      // A new stage starts at 0 and the previous one ended at exactly 1.
      EXPECT_EQ(p.stage_index, stage + 1);
      EXPECT_EQ(p.fraction, 0.0);
      if (i > 0) {
        EXPECT_EQ(reports[i - 1].fraction, stage == 3 ? 0.4 : 1.0);
      }
      stage = p.stage_index;
      last = 0.0;
    }
    EXPECT_GE(p.fraction, last);
    last = p.fraction;
    EXPECT_GE(p.stage_count, p.stage_index);
  }
  EXPECT_EQ(stage, 4);
  EXPECT_EQ(reports.back().fraction, 1.0);
  EXPECT_EQ(reports.back().stage_count, 4);
  EXPECT_EQ(names.front(), "build");
  EXPECT_NE(std::find(names.begin(), names.end(), "empty"), names.end());
}

// A host scheduler that runs tasks in reverse order on the calling thread and counts calls.
class ReverseScheduler final : public TaskScheduler {
 public:
  unsigned concurrency() const override { return 3; }
  void run(std::size_t count, const std::function<void(std::size_t)>& task) override {
    ++calls;
    for (std::size_t i = count; i-- > 0;) task(i);
  }
  int calls = 0;
};

TEST(JobContext, UsesTheHostScheduler) {
  ReverseScheduler host;
  JobContext ctx(&host);
  EXPECT_EQ(ctx.concurrency(), 3u);
  const std::vector<double> a = compute(ctx, 100);
  EXPECT_EQ(host.calls, 1);
  JobContext serial;
  const std::vector<double> b = compute(serial, 100);
  EXPECT_EQ(a, b);
}

}  // namespace
}  // namespace penumbra
