// metrics.hpp — Prometheus metrics (prometheus-cpp), served on
// metrics_listen at /metrics, and horizon_serving alone at /healthz (for a
// load balancer's HTTP check: HAProxy's `http-check expect string
// "horizon_serving 1"`):
//   horizon_serving                                 gauge (1 serving; 0 loading or draining)
//   horizon_requests_total{method, code}            counter
//   horizon_request_duration_seconds{method}        histogram (1 ms .. 60 s)
//   horizon_requests_in_flight                      gauge
//   horizon_cells_evaluated_total{method}           counter (viewshed/culling cells)
//   horizon_boxes_total                             counter (boxes culled)
//   horizon_dataset_resident_bytes                  gauge (elevation bytes the block cache keeps)
//   horizon_block_cache_budget_bytes                gauge
//   horizon_block_cache_held_bytes                  gauge (evicted blocks requests still hold)
//   horizon_block_cache_peak_resident_bytes         gauge
//   horizon_block_cache_requests_total{result}      counter (blocks asked for: hit, join, miss)
//   horizon_block_cache_evictions_total             counter
//   horizon_block_cache_decoded_bytes_total         counter (float bytes decoded)
//   horizon_block_cache_failures_total              counter (blocks that failed to decode)
//   horizon_receive_buffer_bytes                    gauge (gRPC's receive quota, receive_buffer_mb)
//   horizon_gpu_image_bytes                         gauge (GL images taken from the budget: on a software
//                                                   rasteriser, what contexts keep and what runs hold)
//   horizon_memory_reserved_bytes                   gauge (block cache + receive buffers + requests
//                                                   + the workers' kept buffers, as budgeted)
//   horizon_worker_kept_bytes                       gauge (the workers' buffers kept between calls,
//                                                   worker_memory.hpp)
//   horizon_process_resident_bytes                  gauge (RSS from /proc/self/statm, read at scrape)
//   horizon_datasets                                gauge
//   horizon_backend_requests_total{backend}         counter (viewsheds and culls by where the OHF was
//                                                   computed: "cpu" or "gpu")
//   horizon_gpu_fallbacks_total                     counter (the GPU was asked for but failed, or the
//                                                   daemon has none; the CPU answered)
// (prometheus-cpp stays inside metrics.cpp.)
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <string_view>

#include "horizon/terrain/block_cache.hpp"

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
  // One OHF computed on `backend` ("cpu" or "gpu"); `gpu_fallback`: the GPU was asked for and the CPU answered.
  void ohf_computed(std::string_view backend, bool gpu_fallback);
  void set_datasets(std::size_t count);
  // The cache's figures now (counters advance by what changed since the last call).
  void set_block_cache(const terrain::BlockCacheStats& stats);
  void set_memory_reserved(std::uint64_t bytes);
  void set_worker_kept(std::uint64_t bytes);
  void set_receive_buffer(std::uint64_t bytes);
  void set_gpu_images(std::uint64_t bytes);
  // What the health service says (Daemon: SERVING once loaded, NOT_SERVING when draining).
  void set_serving(bool serving);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// Resident set size of this process, bytes (0 when /proc is unavailable).
std::uint64_t process_resident_bytes();

}  // namespace horizon::server
