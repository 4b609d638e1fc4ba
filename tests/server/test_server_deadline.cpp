// Which cancellations the daemon logs as DEADLINE_EXCEEDED. A client's own
// timer cancels its call at the deadline, and that cancel reaches the daemon
// at about the instant the daemon's copy of the deadline passes: sometimes
// just before it (in one CI run, 19.55 ms into a call with a 20 ms deadline).
// Such a cancel is the deadline; a cancel well before it is the client's choice.
#include <chrono>
#include <optional>

#include <gtest/gtest.h>

#include "call_scope.hpp"

namespace horizon::server {
namespace {

using Clock = std::chrono::steady_clock;
using std::chrono::milliseconds;

TEST(DeadlineRace, CancelAtOrAfterTheDeadlineIsTheDeadline) {
  const Clock::time_point deadline = Clock::now();
  EXPECT_TRUE(cancel_reads_as_deadline(deadline, deadline));
  EXPECT_TRUE(cancel_reads_as_deadline(deadline + milliseconds(5), deadline));
  EXPECT_TRUE(cancel_reads_as_deadline(deadline + std::chrono::hours(1), deadline));
}

TEST(DeadlineRace, CancelJustBeforeTheDeadlineIsTheClientsTimer) {
  const Clock::time_point deadline = Clock::now() + std::chrono::seconds(10);
  // The CI case: seen 19.55 ms into the call, about 0.45 ms before a 20 ms deadline.
  EXPECT_TRUE(cancel_reads_as_deadline(deadline - std::chrono::microseconds(450), deadline));
  EXPECT_TRUE(cancel_reads_as_deadline(deadline - kDeadlineRace, deadline));
}

TEST(DeadlineRace, CancelWellBeforeTheDeadlineIsACancel) {
  const Clock::time_point deadline = Clock::now() + std::chrono::seconds(30);
  EXPECT_FALSE(cancel_reads_as_deadline(deadline - kDeadlineRace - milliseconds(1), deadline));
  // ServerRpc.DeadlineAndCancellationStopTheComputation cancels 200 ms into a 30 s deadline.
  EXPECT_FALSE(cancel_reads_as_deadline(deadline - std::chrono::seconds(29), deadline));
}

TEST(DeadlineRace, WithoutADeadlineEveryCancelIsACancel) {
  EXPECT_FALSE(cancel_reads_as_deadline(Clock::now(), std::nullopt));
  EXPECT_FALSE(cancel_reads_as_deadline(Clock::now() + std::chrono::hours(1), std::nullopt));
}

}  // namespace
}  // namespace horizon::server
