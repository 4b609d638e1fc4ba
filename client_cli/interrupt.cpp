#include "interrupt.hpp"

#include <atomic>
#include <cassert>

namespace horizon::cli {
namespace {

// CancelToken::cancel() is one store to a lock-free atomic<bool>, which is
// async-signal-safe.
CancelToken g_token;
std::atomic<bool> g_active{false};
static_assert(std::atomic<bool>::is_always_lock_free);

extern "C" void on_interrupt(int) {
  g_token.cancel();
}

}  // namespace

InterruptScope::InterruptScope() {
  [[maybe_unused]] const bool was_active = g_active.exchange(true);
  assert(!was_active && "one InterruptScope at a time");
  struct sigaction action {};
  action.sa_handler = on_interrupt;
  sigemptyset(&action.sa_mask);
  sigaction(SIGINT, &action, &previous_int_);
  sigaction(SIGTERM, &action, &previous_term_);
}

InterruptScope::~InterruptScope() {
  sigaction(SIGINT, &previous_int_, nullptr);
  sigaction(SIGTERM, &previous_term_, nullptr);
  g_active.store(false);
}

const CancelToken& InterruptScope::token() const {
  return g_token;
}

}  // namespace horizon::cli
