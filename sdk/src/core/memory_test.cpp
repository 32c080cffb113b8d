#include "penumbra/core/memory.h"

#include <gtest/gtest.h>

#include <limits>

namespace penumbra {
namespace {

TEST(FormatBytes, Units) {
  EXPECT_EQ(format_bytes(0), "0 B");
  EXPECT_EQ(format_bytes(812), "812 B");
  EXPECT_EQ(format_bytes(1024), "1.00 KiB");
  EXPECT_EQ(format_bytes(1536 * 1024), "1.50 MiB");
  EXPECT_EQ(format_bytes(300ull << 30), "300 GiB");
}

TEST(MemoryBudget, ReservesWithinTheLimitAndTracksThePeak) {
  MemoryBudget budget(1000);
  ASSERT_TRUE(budget.reserve("probe grid", 600).ok());
  ASSERT_TRUE(budget.reserve("ray batch", 400).ok());
  EXPECT_EQ(budget.reserved(), 1000u);
  budget.release(700);
  EXPECT_EQ(budget.reserved(), 300u);
  EXPECT_EQ(budget.peak(), 1000u);
}

TEST(MemoryBudget, OverBudgetIsAnErrorNamingTheRequest) {
  MemoryBudget budget(1 << 20);
  ASSERT_TRUE(budget.reserve("mesh", 600 << 10).ok());
  Status s = budget.reserve("AO field 256^3", 512 << 10);
  ASSERT_FALSE(s.ok());
  EXPECT_EQ(s.error().code, ErrorCode::OutOfBudget);
  EXPECT_NE(s.error().message.find("AO field 256^3"), std::string::npos) << s.error().message;
  EXPECT_NE(s.error().message.find("512 KiB"), std::string::npos) << s.error().message;
  EXPECT_NE(s.error().message.find("600 KiB"), std::string::npos) << s.error().message;
  EXPECT_NE(s.error().message.find("1.00 MiB"), std::string::npos) << s.error().message;
  // A failed reservation reserves nothing.
  EXPECT_EQ(budget.reserved(), 600u << 10);
}

TEST(MemoryBudget, HugeRequestsDoNotOverflow) {
  MemoryBudget budget(100);
  ASSERT_TRUE(budget.reserve("a", 50).ok());
  EXPECT_FALSE(budget.reserve("b", std::numeric_limits<std::uint64_t>::max() - 10).ok());
  MemoryBudget unlimited;
  EXPECT_TRUE(unlimited.reserve("c", std::numeric_limits<std::uint64_t>::max() / 2).ok());
}

TEST(MemoryBudget, BytesOfCountsCapacity) {
  std::vector<double> v;
  v.reserve(10);
  EXPECT_EQ(bytes_of(v), v.capacity() * sizeof(double));
}

}  // namespace
}  // namespace penumbra
