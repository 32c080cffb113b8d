#include "penumbra/core/log.h"

#include <gtest/gtest.h>

#include <string>
#include <thread>
#include <vector>

#include "penumbra/core/result.h"

namespace penumbra {
namespace {

struct Captured {
  LogLevel level;
  std::string message;
};

TEST(Log, SilentWithoutSinkAndCapturedWithOne) {
  log(LogLevel::Error, "nobody listens");  // must not crash or print
  std::vector<Captured> got;
  set_log_sink([&](LogLevel level, std::string_view m) { got.push_back({level, std::string(m)}); });
  set_log_level(LogLevel::Info);
  log(LogLevel::Debug, "dropped");
  log(LogLevel::Info, "kept");
  log(LogLevel::Error, "also kept");
  set_log_sink({});
  log(LogLevel::Error, "after removal");
  ASSERT_EQ(got.size(), 2u);
  EXPECT_EQ(got[0].message, "kept");
  EXPECT_EQ(got[1].level, LogLevel::Error);
  EXPECT_STREQ(to_string(LogLevel::Warning), "warning");
}

TEST(Log, MessagesFromManyThreadsAreSerialised) {
  int inside = 0, max_inside = 0, count = 0;
  set_log_sink([&](LogLevel, std::string_view) {
    max_inside = std::max(max_inside, ++inside);
    ++count;
    --inside;
  });
  std::vector<std::thread> threads;
  for (int t = 0; t < 4; ++t) {
    threads.emplace_back([] {
      for (int i = 0; i < 1000; ++i) log(LogLevel::Warning, "x");
    });
  }
  for (auto& t : threads) t.join();
  set_log_sink({});
  EXPECT_EQ(count, 4000);
  EXPECT_EQ(max_inside, 1);
}

TEST(Result, ValuesErrorsAndTry) {
  Result<int> good = 3;
  ASSERT_TRUE(good.ok());
  EXPECT_EQ(*good, 3);
  Result<int> bad = make_error(ErrorCode::NotFound, "x.gltf: not found");
  ASSERT_FALSE(bad.ok());
  EXPECT_EQ(bad.error().code, ErrorCode::NotFound);
  auto chain = [](bool fail) -> Status {
    PENUMBRA_TRY(fail ? Status(make_error(ErrorCode::Io, "disk full")) : Status());
    return make_error(ErrorCode::Internal, "reached the end");
  };
  EXPECT_EQ(chain(true).error().code, ErrorCode::Io);
  EXPECT_EQ(chain(false).error().code, ErrorCode::Internal);
  for (ErrorCode c : {ErrorCode::InvalidArgument, ErrorCode::InvalidInput, ErrorCode::NotFound, ErrorCode::Unsupported,
                      ErrorCode::OutOfBudget, ErrorCode::Io, ErrorCode::Cancelled, ErrorCode::Internal}) {
    EXPECT_STRNE(to_string(c), "unknown error");
  }
  EXPECT_STREQ(to_string(ErrorCode::Cancelled), "cancelled");
}

}  // namespace
}  // namespace penumbra
