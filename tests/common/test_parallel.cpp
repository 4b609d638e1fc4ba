// parallel_for (horizon/common/parallel.hpp): every index runs exactly once,
// and under a RunControl a cancel or a passed deadline skips the items not yet
// begun and is the call's status, while progress climbs from `from` to `to`.
#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <mutex>
#include <vector>

#include "horizon/common/parallel.hpp"

namespace horizon {
namespace {

TEST(ParallelFor, RunsEveryIndexOnce) {
  for (unsigned threads : {1u, 2u, 5u}) {
    std::vector<std::atomic<int>> hits(1000);
    parallel_for(hits.size(), threads, [&](std::size_t i) { ++hits[i]; });
    for (std::size_t i = 0; i < hits.size(); ++i) ASSERT_EQ(hits[i].load(), 1) << "index " << i << ", " << threads;
  }
}

TEST(ParallelFor, UnderControlRunsEveryIndexAndReportsProgressFromTo) {
  std::mutex m;
  std::vector<double> seen;
  CancelToken token;
  RunControl control;
  control.cancel = &token;
  control.progress = [&](double f) {
    std::lock_guard lock(m);
    seen.push_back(f);
  };
  std::atomic<int> runs{0};
  const Status s = parallel_for(
      40, 2, &control, [&](std::size_t) { ++runs; }, 0.25, 0.75);
  ASSERT_TRUE(s.ok()) << s.error().message;
  EXPECT_EQ(runs.load(), 40);
  ASSERT_EQ(seen.size(), 40u);
  std::sort(seen.begin(), seen.end());
  EXPECT_DOUBLE_EQ(seen.front(), 0.25 + 0.5 / 40);
  EXPECT_DOUBLE_EQ(seen.back(), 0.75);
}

TEST(ParallelFor, ACancelSkipsTheItemsNotBegunAndIsTheStatus) {
  CancelToken token;
  RunControl control;
  control.cancel = &token;
  std::atomic<int> runs{0};
  // One thread: items run in order, and item 9 cancels.
  const Status s = parallel_for(100, 1, &control, [&](std::size_t i) {
    ++runs;
    if (i == 9) token.cancel();
  });
  EXPECT_EQ(runs.load(), 10);
  ASSERT_FALSE(s.ok());
  EXPECT_EQ(s.error().code, ErrorCode::kCancelled);
}

TEST(ParallelFor, APassedDeadlineRunsNothingAndIsTheStatus) {
  RunControl control;
  control.deadline = std::chrono::steady_clock::now() - std::chrono::seconds(1);
  std::atomic<int> runs{0};
  const Status s = parallel_for(100, 2, &control, [&](std::size_t) { ++runs; });
  EXPECT_EQ(runs.load(), 0);
  ASSERT_FALSE(s.ok());
  EXPECT_EQ(s.error().code, ErrorCode::kDeadlineExceeded);
}

TEST(ParallelFor, WithoutAControlRunsEverything) {
  std::atomic<int> runs{0};
  EXPECT_TRUE(parallel_for(64, 2, nullptr, [&](std::size_t) { ++runs; }).ok());
  EXPECT_EQ(runs.load(), 64);
}

}  // namespace
}  // namespace horizon
