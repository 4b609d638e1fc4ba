// parallel_for's process-wide executor (horizon/common/parallel.hpp): calls
// from several threads at once each run every index once, a body may call
// parallel_for again, a call never runs more bodies at once than the threads
// it asked for, and an exception out of a body ends the process.
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <stdexcept>
#include <thread>
#include <vector>

#include "horizon/common/parallel.hpp"

namespace horizon {
namespace {

TEST(ParallelExecutor, RunsEveryIndexOnceForSeveralCallersAtOnce) {
  constexpr int kCallers = 4, kRounds = 50;
  constexpr std::size_t kCount = 500;
  std::vector<std::vector<std::atomic<int>>> hits(kCallers);
  for (auto& h : hits) h = std::vector<std::atomic<int>>(kCount);
  {
    std::vector<std::jthread> callers;
    for (int c = 0; c < kCallers; ++c)
      callers.emplace_back([&, c] {
        for (int round = 0; round < kRounds; ++round)
          parallel_for(kCount, 2 + static_cast<unsigned>(c % 3),
                       [&](std::size_t i) { hits[static_cast<std::size_t>(c)][i].fetch_add(1); });
      });
  }
  for (int c = 0; c < kCallers; ++c)
    for (std::size_t i = 0; i < kCount; ++i)
      ASSERT_EQ(hits[static_cast<std::size_t>(c)][i].load(), kRounds) << "caller " << c << ", index " << i;
}

TEST(ParallelExecutor, NestedCallsComplete) {
  // Three levels deep, from two callers at once: every worker can end up
  // waiting inside a body for an inner call, which must still finish.
  std::atomic<int> leaves{0};
  auto nest = [&] {
    parallel_for(6, 0, [&](std::size_t) {
      parallel_for(5, 2, [&](std::size_t) { parallel_for(4, 3, [&](std::size_t) { ++leaves; }); });
    });
  };
  {
    std::jthread other(nest);
    nest();
  }
  EXPECT_EQ(leaves.load(), 2 * 6 * 5 * 4);
}

TEST(ParallelExecutor, NeverRunsMoreBodiesAtOnceThanThreads) {
  for (unsigned threads : {1u, 2u, 3u}) {
    std::atomic<unsigned> active{0}, most{0};
    // A second caller keeps the executor busy, so helpers freed by one call
    // are at once available to the other.
    std::atomic<bool> done{false};
    std::jthread rival([&] {
      while (!done) parallel_for(8, 0, [](std::size_t) { std::this_thread::sleep_for(std::chrono::microseconds(50)); });
    });
    parallel_for(64, threads, [&](std::size_t) {
      const unsigned now = ++active;
      for (unsigned seen = most.load(); now > seen && !most.compare_exchange_weak(seen, now);) {
      }
      std::this_thread::sleep_for(std::chrono::microseconds(200));
      --active;
    });
    done = true;
    EXPECT_GE(most.load(), 1u);
    EXPECT_LE(most.load(), threads) << threads << " threads";
  }
}

TEST(ParallelExecutor, OneThreadRunsOnTheCallerInOrder) {
  const std::thread::id caller = std::this_thread::get_id();
  std::vector<std::size_t> order;
  bool elsewhere = false;
  parallel_for(100, 1, [&](std::size_t i) {
    order.push_back(i);
    elsewhere = elsewhere || std::this_thread::get_id() != caller;
  });
  ASSERT_EQ(order.size(), 100u);
  for (std::size_t i = 0; i < order.size(); ++i) EXPECT_EQ(order[i], i);
  EXPECT_FALSE(elsewhere);
}

TEST(ParallelExecutorDeathTest, AThrowingBodyEndsTheProcess) {
  GTEST_FLAG_SET(death_test_style, "threadsafe");
  EXPECT_DEATH(parallel_for(16, 2, [](std::size_t) { throw std::runtime_error("body threw"); }), "");
}

}  // namespace
}  // namespace horizon
