// interrupt.hpp — Ctrl-C (SIGINT) and SIGTERM cancel a running computation.
//
// While an InterruptScope lives, the signals set its CancelToken instead of
// killing the process; the engine notices at its next poll and returns
// ErrorCode::kCancelled, and the command exits 1 without writing anything.
// The previous handlers are restored when the scope ends. One scope at a time.
#pragma once

#include <csignal>

#include "horizon/common/control.hpp"

namespace horizon::cli {

class InterruptScope {
 public:
  InterruptScope();
  ~InterruptScope();
  InterruptScope(const InterruptScope&) = delete;
  InterruptScope& operator=(const InterruptScope&) = delete;

  const CancelToken& token() const;

 private:
  struct sigaction previous_int_ {};
  struct sigaction previous_term_ {};
};

}  // namespace horizon::cli
