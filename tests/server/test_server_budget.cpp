// The budget's per-message figures (memory_budget.hpp) against the messages
// themselves: a call reserves what its messages will really hold. And when
// the heap trimmer (allocator.hpp) gives freed memory back.
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <cstdint>
#include <thread>

#include "allocator.hpp"
#include "arena_allocator.hpp"
#include "horizon/v1/visibility.pb.h"
#include "memory_budget.hpp"

namespace horizon::server {
namespace {

// A CullBoxes answer of n boxes on the call's arena, every field set.
std::uint64_t answer_bytes(int n) {
  ArenaAllocator<v1::CullBoxesRequest, v1::CullBoxesResponse> allocator;
  auto* holder = allocator.AllocateMessages();
  const std::uint64_t before = held_bytes(*holder->response());
  v1::CullBoxesResponse& response = *holder->response();
  response.mutable_boxes()->Reserve(n);  // as cull_call does
  for (int i = 0; i < n; ++i) {
    v1::BoxVisibility* b = response.add_boxes();
    b->set_visible(i % 2 == 0);
    b->set_ohf_min(1234.5 + i);
    b->set_state(v1::BOX_STATE_UNDETERMINED);
  }
  const std::uint64_t after = held_bytes(response);
  holder->Release();
  return after - before;
}

TEST(ServerBudget, ACullAnswerHoldsNoMoreThanItsReservation) {
  for (int n : {1'000, 10'000, 100'000}) {
    const std::uint64_t bytes = answer_bytes(n);
    EXPECT_LE(bytes, static_cast<std::uint64_t>(n) * MemoryBudget::kResponseBytesPerBox) << n << " boxes";
    // And the figure is not wildly above it: the reservation refuses calls it need not.
    EXPECT_GE(bytes * 2, static_cast<std::uint64_t>(n) * MemoryBudget::kResponseBytesPerBox) << n << " boxes";
  }
}

TEST(ServerBudget, AReceivedRequestIsCountedAtLeastAsItsWireSize) {
  ArenaAllocator<v1::CullBoxesRequest, v1::CullBoxesResponse> allocator;
  auto* holder = allocator.AllocateMessages();
  v1::CullBoxesRequest& request = *holder->request();
  request.set_dataset("ecuador");
  for (int i = 0; i < 50'000; ++i) {
    v1::Box* b = request.add_boxes();
    b->set_x_min(700000.0 + i);
    b->set_x_max(700010.0 + i);
    b->set_y_min(9500000.0 + i);
    b->set_y_max(9500010.0 + i);
    b->set_z_min(2000);
    b->set_z_max(2100);
  }
  EXPECT_GE(held_bytes(request), request.ByteSizeLong());
  // A message off any arena is counted by its own footprint.
  v1::CullBoxesRequest copy = request;
  EXPECT_GE(held_bytes(copy), copy.ByteSizeLong());
  holder->Release();
}

// A call that reserves in steps (CallScope::reserve) holds one reservation:
// absorbing another adds its bytes, and releasing gives both back.
TEST(ServerBudget, AReservationAbsorbsAnotherOfTheSameBudget) {
  MemoryBudget budget(MemoryBudget::kBaseBytes + 100);
  Reservation first, second, empty;
  ASSERT_TRUE(budget.try_reserve(40, first));
  ASSERT_TRUE(budget.try_reserve(50, second));
  EXPECT_FALSE(budget.try_reserve(11, empty));  // 90 of 100 held
  first.absorb(std::move(second));
  EXPECT_EQ(first.bytes(), 90u);
  EXPECT_EQ(second.bytes(), 0u);  // NOLINT(bugprone-use-after-move): absorb leaves it empty
  EXPECT_EQ(budget.reserved(), 90u);
  second.release();  // empty: gives nothing back
  EXPECT_EQ(budget.reserved(), 90u);
  Reservation taker;  // an empty one takes the other over whole
  taker.absorb(std::move(first));
  EXPECT_EQ(taker.bytes(), 90u);
  taker.release();
  EXPECT_EQ(budget.reserved(), 0u);
  EXPECT_TRUE(budget.try_reserve(100, empty));
}

// A worker keeping a call's buffers takes their bytes out of the call's
// reservation (WorkspaceLease): the budget's total does not move, and each
// part gives back its own share.
TEST(ServerBudget, AReservationSplitsInTwoThatGiveBackTheirOwnShares) {
  MemoryBudget budget(MemoryBudget::kBaseBytes + 100);
  Reservation call;
  ASSERT_TRUE(budget.try_reserve(70, call));
  Reservation kept = call.split(30);
  EXPECT_EQ(call.bytes(), 40u);
  EXPECT_EQ(kept.bytes(), 30u);
  EXPECT_EQ(budget.reserved(), 70u);
  Reservation rest = call.split(1000);  // no more than it holds
  EXPECT_EQ(rest.bytes(), 40u);
  EXPECT_EQ(call.bytes(), 0u);
  EXPECT_EQ(Reservation().split(5).bytes(), 0u);  // an empty one has nothing to give
  rest.release();
  EXPECT_EQ(budget.reserved(), 30u);
  kept.release();
  EXPECT_EQ(budget.reserved(), 0u);
}

// A call that has started and lacks only what parses hold waits for them to
// end, and meanwhile no parse starts and no call is admitted: a flood of
// arriving requests cannot take what the admitted call needs (the daemon's
// CI once refused every one of 72 admitted CullBoxes calls so).
TEST(ServerBudget, AStartedCallWaitsForParsesAndTakesWhatTheyGiveBack) {
  MemoryBudget budget(MemoryBudget::kBaseBytes + 100);
  Reservation admitted;
  ASSERT_TRUE(budget.try_reserve_new(50, admitted));
  ASSERT_TRUE(budget.try_take_parse(40));  // a request being parsed
  std::atomic<bool> refused_during_wait{false};
  std::thread parse([&] {
    // New parses are taken (and given back) until the waiter is in its wait.
    const auto give_up = std::chrono::steady_clock::now() + std::chrono::seconds(20);
    while (budget.try_take_parse(1) && std::chrono::steady_clock::now() < give_up) {
      budget.give_parse(1);
      std::this_thread::yield();
    }
    // Then no new call takes the room the waiter wants either.
    Reservation other;
    refused_during_wait = !budget.try_take_parse(1) && !budget.try_reserve_new(1, other);
    budget.give_parse(40);  // the parse ends
  });
  Reservation more;
  // 30 more: 10 free now, the parse's 40 once it ends.
  EXPECT_TRUE(budget.reserve_after_parses(30, more, std::chrono::steady_clock::now() + std::chrono::seconds(60)));
  parse.join();
  EXPECT_TRUE(refused_during_wait.load());
  EXPECT_EQ(more.bytes(), 30u);
  EXPECT_EQ(budget.reserved(), 80u);
  // No one waits now: parses and calls are taken again.
  EXPECT_TRUE(budget.try_take_parse(20));
  budget.give_parse(20);
  Reservation next;
  EXPECT_TRUE(budget.try_reserve_new(20, next));
}

// What parses' ending would not make room for is refused at once, whatever
// the time left; what they would is refused at `until` if they never end.
TEST(ServerBudget, AStartedCallWaitsOnlyForWhatParsesCouldGiveAndOnlyUntilItsTime) {
  MemoryBudget budget(MemoryBudget::kBaseBytes + 100);
  Reservation admitted, more;
  ASSERT_TRUE(budget.try_reserve(50, admitted));
  ASSERT_TRUE(budget.try_take_parse(40));
  const auto start = std::chrono::steady_clock::now();
  // 60 > 10 free + 40 parsing: no wait (a wrong answer here would wait an hour).
  EXPECT_FALSE(budget.reserve_after_parses(60, more, start + std::chrono::hours(1)));
  // 30 <= 50, but the parse never ends: refused at `until`.
  EXPECT_FALSE(budget.reserve_after_parses(30, more, start + std::chrono::milliseconds(40)));
  EXPECT_GE(std::chrono::steady_clock::now() - start, std::chrono::milliseconds(40));
  EXPECT_EQ(more.bytes(), 0u);
  EXPECT_EQ(budget.reserved(), 90u);
  budget.give_parse(40);
  EXPECT_TRUE(budget.reserve_after_parses(30, more, start));  // fits now: no wait, whatever `until`
  EXPECT_EQ(budget.reserved(), 80u);
}

// Trims wait for the daemon to be idle at the end of the delay, and come at
// most once an interval however often it falls idle. (Bounds are generous:
// each waits several times the delay the trimmer is given.)
TEST(HeapTrimmer, TrimsOnlyWhenStillIdleAndAtMostOnceAnInterval) {
  using namespace std::chrono_literals;
  std::atomic<std::uint32_t> live{1};
  HeapTrimmer trimmer(live);
  trimmer.idle();  // told idle, but a call is live again
  std::this_thread::sleep_for(HeapTrimmer::kDelay * 4);
  EXPECT_EQ(trimmer.trims(), 0u);

  live = 0;
  trimmer.idle();
  const auto until = std::chrono::steady_clock::now() + 5s;
  while (trimmer.trims() == 0 && std::chrono::steady_clock::now() < until) std::this_thread::sleep_for(10ms);
  EXPECT_EQ(trimmer.trims(), 1u);
  // A client falling idle between calls 60 times a second: no second trim within the interval.
  for (int i = 0; i < 30; ++i) {
    trimmer.idle();
    std::this_thread::sleep_for(16ms);
  }
  EXPECT_LE(trimmer.trims(), 2u);  // 480 ms of idles: the first trim's interval covers them, at most one more
}

}  // namespace
}  // namespace horizon::server
