// progress.hpp — a progress bar on stderr for long computations.
//
// Shown only when stderr is a terminal, and only once the work has run for
// `delay` (1 s by default), so quick runs and pipes/log files stay clean.
// Engine worker threads report through RunControl::progress; update() is a
// lock-free atomic max, so it is safe and cheap from any thread. A single
// drawing thread owned by the bar reads the value ~10 times a second and is
// the only writer to stderr while the bar lives. finish() (or the destructor)
// stops it and erases the bar line.
#pragma once

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <functional>
#include <mutex>
#include <string>
#include <thread>

namespace horizon::cli {

class ProgressBar {
 public:
  explicit ProgressBar(std::string label, std::chrono::milliseconds delay = std::chrono::seconds(1));
  ~ProgressBar();
  ProgressBar(const ProgressBar&) = delete;
  ProgressBar& operator=(const ProgressBar&) = delete;

  // Records the fraction done, in [0, 1]; never moves the bar backwards.
  void update(double fraction);
  // A callable for RunControl::progress; valid while this bar lives.
  std::function<void(double)> callback();
  // Stops drawing and erases the bar. Idempotent.
  void finish();

 private:
  void draw_loop();
  void draw(double fraction, double seconds);

  const std::string label_;
  const std::chrono::milliseconds delay_;
  const std::chrono::steady_clock::time_point start_;
  std::atomic<double> fraction_{0.0};
  std::mutex mutex_;
  std::condition_variable wake_;
  bool stopping_ = false;  // guarded by mutex_
  bool drawn_ = false;     // touched only by the drawing thread, then by finish() after join
  std::thread thread_;     // empty when stderr is not a terminal
};

}  // namespace horizon::cli
