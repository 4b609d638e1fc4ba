// daemon_process.hpp — a real horizond for integration tests: started on an
// ephemeral loopback port with a temporary JSON config, its structured log
// captured to a file, stopped with SIGTERM.
#pragma once

#include <sys/types.h>

#include <chrono>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include <grpcpp/channel.h>

#include "test_support.hpp"

namespace horizon::testing {

struct DaemonOptions {
  // name -> file under data/dem (the bundled DEMs).
  std::vector<std::pair<std::string, std::string>> datasets = {
      {"rainier", "rainier_summit_srtm3_400x400.tif"},
      {"everest", "everest_summit_voids_srtm3_300x300.tif"},
      {"olinda", "olinda_coast_utm25s_111x111.tif"},
      {"ecuador", "ecuador_andes_utm17s_10m_383x415.tif"},
  };
  std::string extra_json;  // more top-level keys, e.g. R"("limits": {"max_boxes": 10},)"
  std::string data_root = HORIZON_DATA_DIR;
  int memory_budget_mb = 256;
  bool plaintext = true;  // false: extra_json must give "tls"
  int worker_threads = 2;
};

class DaemonProcess {
 public:
  explicit DaemonProcess(const DaemonOptions& options = {});
  ~DaemonProcess();  // SIGTERM, then SIGKILL if it will not stop
  DaemonProcess(const DaemonProcess&) = delete;
  DaemonProcess& operator=(const DaemonProcess&) = delete;

  // False (with the log in `error()`) when it did not come up.
  bool ready() const { return port_ > 0; }
  const std::string& error() const { return error_; }
  std::string address() const { return "127.0.0.1:" + std::to_string(port_); }
  int metrics_port() const { return metrics_port_; }
  pid_t pid() const { return pid_; }
  const std::string& config_path() const { return config_path_; }
  std::string log() const;  // everything it wrote to stderr so far
  // Lines of the log that are request records (event "request").
  std::vector<std::string> request_lines() const;

  std::shared_ptr<grpc::Channel> channel() const;
  // Sends `signal`; for SIGTERM/SIGINT waits for the exit and returns its status (else -1).
  int signal(int signal, std::chrono::seconds wait = std::chrono::seconds(30));
  // Waits until the log holds `text` (true) or `timeout` passes (false).
  bool wait_for_log(const std::string& text, std::chrono::milliseconds timeout = std::chrono::seconds(10)) const;
  // The Prometheus text it serves on 127.0.0.1:metrics_port/metrics ("" when it cannot be had).
  std::string metrics() const;
  // Any page of that listener (e.g. "/healthz"), the HTTP response whole.
  std::string metrics_page(const std::string& path) const;
  // Waits until at least `calls` requests are in flight (horizon_requests_in_flight): the
  // moment to cancel, reload or stop under a call, on a machine of any speed.
  bool wait_for_in_flight(int calls, std::chrono::milliseconds timeout = std::chrono::seconds(10)) const;
  // Waits until `settled` holds for the metrics text (true) or `timeout` passes (false).
  bool wait_for_metrics(const std::function<bool(const std::string& metrics)>& settled,
                        std::chrono::milliseconds timeout) const;
  // Waits (5 s at most) until no call holds memory: the budget's reservations
  // are the block cache's, the receive buffers' and the kept GL images'. A
  // call leaves the in-flight gauge before its reactor returns its reservation.
  bool memory_returned() const;
  // Peak resident set size (VmHWM) in bytes, while running.
  std::uint64_t peak_rss_bytes() const;
  // Resident set size now (VmRSS) in bytes, while running.
  std::uint64_t rss_bytes() const;

 private:
  TempDir dir_;
  std::string config_path_, log_path_, error_;
  pid_t pid_ = -1;
  int port_ = 0, metrics_port_ = 0;
  mutable bool exited_ = false;
};

// The value of the sample line of Prometheus `text` that starts with `series`
// (name and labels), or -1 when there is none.
double metric(const std::string& text, const std::string& series);

// True when the tests run against another build of horizond than their own
// (HORIZON_TEST_HORIZOND, set by scripts/tsan.sh for a ThreadSanitizer one):
// its memory and speed are the sanitizer's, not the daemon's.
bool another_daemon_build();

// Writes `config_json` into the daemon's config file (for reload tests).
void write_file(const std::string& path, const std::string& text);

}  // namespace horizon::testing
