#include "memory_budget.hpp"

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
