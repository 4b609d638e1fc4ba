// metrics.hpp — Prometheus metrics (prometheus-cpp), served on
// metrics_listen at /metrics:
//   horizon_requests_total{method, code}            counter
//   horizon_request_duration_seconds{method}        histogram (1 ms .. 60 s)
//   horizon_requests_in_flight                      gauge
//   horizon_cells_evaluated_total{method}           counter (viewshed/culling cells)
//   horizon_boxes_total                             counter (boxes culled)
//   horizon_dataset_resident_bytes                  gauge (elevations held)
//   horizon_memory_reserved_bytes                   gauge (datasets + requests, as budgeted)
//   horizon_process_resident_bytes                  gauge (RSS from /proc/self/statm, read at scrape)
//   horizon_datasets                                gauge
// (prometheus-cpp stays inside metrics.cpp.)
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <string_view>

namespace horizon::server {

class Metrics {
 public:
  Metrics();
  ~Metrics();
  Metrics(const Metrics&) = delete;
  Metrics& operator=(const Metrics&) = delete;

  // Starts the HTTP endpoint; returns the bound port (the given one, or the
  // one chosen for port 0). Throws std::runtime_error when it cannot bind.
  int serve(const std::string& address);

  void request_started();
  void request_finished(std::string_view method, std::string_view code, double seconds, std::uint64_t cells,
                        std::uint64_t boxes);
  void set_datasets(std::size_t count, std::uint64_t resident_bytes);
  void set_memory_reserved(std::uint64_t bytes);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// Resident set size of this process, bytes (0 when /proc is unavailable).
std::uint64_t process_resident_bytes();

}  // namespace horizon::server
