#include "progress.hpp"

#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>

namespace horizon::cli {
namespace {
constexpr int kBarWidth = 30;
constexpr auto kRedrawInterval = std::chrono::milliseconds(100);
}  // namespace

ProgressBar::ProgressBar(std::string label, std::chrono::milliseconds delay)
    : label_(std::move(label)), delay_(delay), start_(std::chrono::steady_clock::now()) {
  if (::isatty(STDERR_FILENO)) thread_ = std::thread([this] { draw_loop(); });
}

ProgressBar::~ProgressBar() {
  finish();
}

void ProgressBar::update(double fraction) {
  if (!(fraction >= 0.0)) return;  // NaN or negative: ignore
  fraction = std::min(fraction, 1.0);
  double seen = fraction_.load(std::memory_order_relaxed);
  while (fraction > seen && !fraction_.compare_exchange_weak(seen, fraction, std::memory_order_relaxed)) {
  }
}

std::function<void(double)> ProgressBar::callback() {
  return [this](double fraction) { update(fraction); };
}

void ProgressBar::finish() {
  if (!thread_.joinable()) return;
  {
    std::lock_guard lock(mutex_);
    stopping_ = true;
  }
  wake_.notify_all();
  thread_.join();
  if (drawn_) {
    std::fputs("\r\033[K", stderr);  // erase the bar line
    std::fflush(stderr);
  }
}

void ProgressBar::draw_loop() {
  std::unique_lock lock(mutex_);
  while (!wake_.wait_for(lock, kRedrawInterval, [this] { return stopping_; })) {
    const auto elapsed = std::chrono::steady_clock::now() - start_;
    if (elapsed < delay_) continue;
    draw(fraction_.load(std::memory_order_relaxed), std::chrono::duration<double>(elapsed).count());
  }
}

void ProgressBar::draw(double fraction, double seconds) {
  const int filled = static_cast<int>(std::floor(fraction * kBarWidth));
  std::string bar(static_cast<std::size_t>(filled), '#');
  bar.append(static_cast<std::size_t>(kBarWidth - filled), '.');
  std::fprintf(stderr, "\r%s [%s] %3d%%  %.1f s", label_.c_str(), bar.c_str(),
               static_cast<int>(std::floor(fraction * 100.0)), seconds);
  std::fflush(stderr);
  drawn_ = true;
}

}  // namespace horizon::cli
