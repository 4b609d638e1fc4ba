#include "memory_budget.hpp"

#include <algorithm>
#include <cassert>

namespace horizon::server {

Reservation& Reservation::operator=(Reservation&& other) noexcept {
  if (this != &other) {
    release();
    budget_ = other.budget_;
    bytes_ = other.bytes_;
    other.budget_ = nullptr;
  }
  return *this;
}

void Reservation::absorb(Reservation&& more) {
  if (!more.budget_) return;
  if (!budget_) {
    *this = std::move(more);
    return;
  }
  assert(budget_ == more.budget_);
  bytes_ += more.bytes_;
  more.budget_ = nullptr;
}

Reservation Reservation::split(std::uint64_t bytes) {
  if (!budget_ || bytes == 0) return {};
  if (bytes > bytes_) bytes = bytes_;
  bytes_ -= bytes;
  return Reservation(budget_, bytes);
}

void Reservation::release() {
  if (budget_) budget_->give_back(bytes_);
  budget_ = nullptr;
}

bool MemoryBudget::try_take(std::uint64_t bytes) {
  const auto want = static_cast<std::int64_t>(bytes);
  std::int64_t available = available_.load();
  while (true) {
    if (want > available) return false;
    if (available_.compare_exchange_weak(available, available - want)) return true;
  }
}

bool MemoryBudget::try_take_parse(std::uint64_t bytes) {
  // Counted first, so that a waiter who sees the shortfall also sees this hold.
  parsing_.fetch_add(static_cast<std::int64_t>(bytes));
  if (waiting_.load() == 0 && try_take(bytes)) return true;
  parsing_.fetch_sub(static_cast<std::int64_t>(bytes));
  return false;
}

bool MemoryBudget::try_reserve_new(std::uint64_t bytes, Reservation& out) {
  return waiting_.load() == 0 && try_reserve(bytes, out);
}

void MemoryBudget::give_parse(std::uint64_t bytes) {
  give_back(bytes);
  parsing_.fetch_sub(static_cast<std::int64_t>(bytes));
  if (waiting_.load() > 0) {
    std::lock_guard lock(parse_mutex_);
    parse_ended_.notify_all();
  }
}

bool MemoryBudget::reserve_after_parses(std::uint64_t bytes, Reservation& out,
                                        std::chrono::steady_clock::time_point until) {
  if (try_reserve(bytes, out)) return true;
  const auto want = static_cast<std::int64_t>(bytes);
  std::unique_lock lock(parse_mutex_);
  waiting_.fetch_add(1);
  bool taken = false;
  while (!(taken = try_reserve(bytes, out)) && want <= available_.load() + parsing_.load() &&
         std::chrono::steady_clock::now() < until) {
    // Woken when a parse ends; the timeout covers a wake-up between the test and the wait.
    parse_ended_.wait_until(lock, std::min(until, std::chrono::steady_clock::now() + std::chrono::milliseconds(5)));
  }
  waiting_.fetch_sub(1);
  return taken;
}

bool MemoryBudget::try_reserve(std::uint64_t bytes, Reservation& out) {
  if (!try_take(bytes)) return false;
  out = Reservation(this, bytes);
  return true;
}

std::uint64_t MemoryBudget::reserved() const {
  const std::int64_t in_use = static_cast<std::int64_t>(total_) - static_cast<std::int64_t>(kBaseBytes) - available_.load();
  return in_use > 0 ? static_cast<std::uint64_t>(in_use) : 0;
}

}  // namespace horizon::server
