// Prometheus metrics through prometheus-cpp (core + pull/civetweb).
#include "metrics.hpp"

#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cstdio>
#include <functional>
#include <mutex>
#include <string>
#include <utility>
#include <vector>

#include <prometheus/collectable.h>
#include <prometheus/counter.h>
#include <prometheus/exposer.h>
#include <prometheus/gauge.h>
#include <prometheus/histogram.h>
#include <prometheus/registry.h>

namespace horizon::server {

std::uint64_t process_resident_bytes() {
  std::FILE* f = std::fopen("/proc/self/statm", "r");
  if (!f) return 0;
  unsigned long long size = 0, resident = 0;
  const int n = std::fscanf(f, "%llu %llu", &size, &resident);
  std::fclose(f);
  if (n != 2) return 0;
  return resident * static_cast<std::uint64_t>(::sysconf(_SC_PAGESIZE));
}

namespace {

// One gauge read when scraped, so the figure is current.
class GaugeAtScrape : public prometheus::Collectable {
 public:
  GaugeAtScrape(std::string name, std::string help, std::function<double()> read)
      : name_(std::move(name)), help_(std::move(help)), read_(std::move(read)) {}
  std::vector<prometheus::MetricFamily> Collect() const override {
    prometheus::MetricFamily family;
    family.name = name_;
    family.help = help_;
    family.type = prometheus::MetricType::Gauge;
    prometheus::ClientMetric metric;
    metric.gauge.value = read_();
    family.metric.push_back(metric);
    return {family};
  }

 private:
  std::string name_, help_;
  std::function<double()> read_;
};

}  // namespace

struct Metrics::Impl {
  std::shared_ptr<prometheus::Registry> registry = std::make_shared<prometheus::Registry>();
  std::shared_ptr<GaugeAtScrape> process = std::make_shared<GaugeAtScrape>(
      "horizon_process_resident_bytes", "Resident set size of the daemon, bytes",
      [] { return static_cast<double>(process_resident_bytes()); });
  std::atomic<bool> serving_now{false};
  std::shared_ptr<GaugeAtScrape> serving = std::make_shared<GaugeAtScrape>(
      "horizon_serving", "1 while horizond serves requests; 0 while it loads its datasets or drains",
      [this] { return serving_now.load() ? 1.0 : 0.0; });
  std::unique_ptr<prometheus::Exposer> exposer;

  prometheus::Family<prometheus::Counter>& requests = prometheus::BuildCounter()
                                                          .Name("horizon_requests_total")
                                                          .Help("Requests answered, by method and gRPC code")
                                                          .Register(*registry);
  prometheus::Family<prometheus::Histogram>& durations = prometheus::BuildHistogram()
                                                             .Name("horizon_request_duration_seconds")
                                                             .Help("Request latency, seconds, by method")
                                                             .Register(*registry);
  prometheus::Family<prometheus::Counter>& cells = prometheus::BuildCounter()
                                                       .Name("horizon_cells_evaluated_total")
                                                       .Help("Cells evaluated, by method")
                                                       .Register(*registry);
  prometheus::Counter& boxes =
      prometheus::BuildCounter().Name("horizon_boxes_total").Help("Object boxes culled").Register(*registry).Add({});
  prometheus::Gauge& in_flight = prometheus::BuildGauge()
                                     .Name("horizon_requests_in_flight")
                                     .Help("Requests admitted and not yet finished")
                                     .Register(*registry)
                                     .Add({});
  prometheus::Gauge& resident = prometheus::BuildGauge()
                                    .Name("horizon_dataset_resident_bytes")
                                    .Help("Elevation bytes held resident")
                                    .Register(*registry)
                                    .Add({});
  prometheus::Gauge& reserved =
      prometheus::BuildGauge()
          .Name("horizon_memory_reserved_bytes")
          .Help("Bytes reserved in the memory budget (cache, receive buffers, requests, kept buffers)")
          .Register(*registry)
          .Add({});
  prometheus::Gauge& worker_kept = prometheus::BuildGauge()
                                       .Name("horizon_worker_kept_bytes")
                                       .Help("Bytes of the memory budget the workers' buffers hold between calls")
                                       .Register(*registry)
                                       .Add({});
  prometheus::Gauge& receive_buffer = prometheus::BuildGauge()
                                          .Name("horizon_receive_buffer_bytes")
                                          .Help("Bytes gRPC may hold for requests still on the wire")
                                          .Register(*registry)
                                          .Add({});
  prometheus::Gauge& gpu_images = prometheus::BuildGauge()
                                      .Name("horizon_gpu_image_bytes")
                                      .Help("GL images taken from the memory budget (software rasteriser)")
                                      .Register(*registry)
                                      .Add({});
  prometheus::Gauge& cache_budget = prometheus::BuildGauge()
                                        .Name("horizon_block_cache_budget_bytes")
                                        .Help("Bytes the block cache may keep")
                                        .Register(*registry)
                                        .Add({});
  prometheus::Gauge& cache_held = prometheus::BuildGauge()
                                      .Name("horizon_block_cache_held_bytes")
                                      .Help("Evicted blocks still held by requests, bytes")
                                      .Register(*registry)
                                      .Add({});
  prometheus::Gauge& cache_peak = prometheus::BuildGauge()
                                      .Name("horizon_block_cache_peak_resident_bytes")
                                      .Help("Most bytes the block cache has kept at once")
                                      .Register(*registry)
                                      .Add({});
  prometheus::Family<prometheus::Counter>& cache_requests = prometheus::BuildCounter()
                                                                .Name("horizon_block_cache_requests_total")
                                                                .Help("Blocks asked for, by result: hit, join, miss")
                                                                .Register(*registry);
  prometheus::Counter& cache_evictions = prometheus::BuildCounter()
                                             .Name("horizon_block_cache_evictions_total")
                                             .Help("Blocks evicted from the block cache")
                                             .Register(*registry)
                                             .Add({});
  prometheus::Counter& cache_decoded = prometheus::BuildCounter()
                                           .Name("horizon_block_cache_decoded_bytes_total")
                                           .Help("Elevation bytes decoded into the block cache")
                                           .Register(*registry)
                                           .Add({});
  prometheus::Counter& cache_failures = prometheus::BuildCounter()
                                            .Name("horizon_block_cache_failures_total")
                                            .Help("Blocks that failed to decode")
                                            .Register(*registry)
                                            .Add({});
  std::mutex cache_mutex;
  terrain::BlockCacheStats cache_seen;  // what the counters have counted so far
  prometheus::Gauge& datasets =
      prometheus::BuildGauge().Name("horizon_datasets").Help("Datasets loaded").Register(*registry).Add({});
  prometheus::Family<prometheus::Counter>& backends = prometheus::BuildCounter()
                                                          .Name("horizon_backend_requests_total")
                                                          .Help("Viewsheds and culls, by where the OHF was computed")
                                                          .Register(*registry);
  prometheus::Counter& gpu_fallbacks = prometheus::BuildCounter()
                                           .Name("horizon_gpu_fallbacks_total")
                                           .Help("Requests that asked for the GPU and were answered on the CPU")
                                           .Register(*registry)
                                           .Add({});
};

Metrics::Metrics() : impl_(std::make_unique<Impl>()) {
  // Both series from the start, so that a rate over them is defined before the first request.
  for (const char* backend : {"cpu", "gpu"}) impl_->backends.Add({{"backend", backend}});
}
Metrics::~Metrics() = default;

int Metrics::serve(const std::string& address) {
  impl_->exposer = std::make_unique<prometheus::Exposer>(address);
  impl_->exposer->RegisterCollectable(impl_->registry);
  impl_->exposer->RegisterCollectable(impl_->process);
  impl_->exposer->RegisterCollectable(impl_->serving);
  impl_->exposer->RegisterCollectable(impl_->serving, "/healthz");
  const auto ports = impl_->exposer->GetListeningPorts();
  return ports.empty() ? 0 : ports.front();
}

void Metrics::request_started() {
  impl_->in_flight.Increment();
}

void Metrics::request_finished(std::string_view method, std::string_view code, double seconds, std::uint64_t cells,
                               std::uint64_t boxes) {
  impl_->in_flight.Decrement();
  const std::string m(method);
  impl_->requests.Add({{"method", m}, {"code", std::string(code)}}).Increment();
  static const prometheus::Histogram::BucketBoundaries kBuckets{0.001, 0.002, 0.005, 0.01, 0.02, 0.05, 0.1,
                                                                0.2,   0.5,   1.0,   2.0,  5.0,  10.0, 60.0};
  impl_->durations.Add({{"method", m}}, kBuckets).Observe(seconds);
  if (cells) impl_->cells.Add({{"method", m}}).Increment(static_cast<double>(cells));
  if (boxes) impl_->boxes.Increment(static_cast<double>(boxes));
}

void Metrics::ohf_computed(std::string_view backend, bool gpu_fallback) {
  impl_->backends.Add({{"backend", std::string(backend)}}).Increment();
  if (gpu_fallback) impl_->gpu_fallbacks.Increment();
}

void Metrics::set_datasets(std::size_t count) {
  impl_->datasets.Set(static_cast<double>(count));
}

void Metrics::set_block_cache(const terrain::BlockCacheStats& s) {
  Impl& m = *impl_;
  std::lock_guard lock(m.cache_mutex);
  m.resident.Set(static_cast<double>(s.resident_bytes));
  m.cache_budget.Set(static_cast<double>(s.budget_bytes));
  m.cache_held.Set(static_cast<double>(s.held_bytes));
  m.cache_peak.Set(static_cast<double>(s.peak_resident_bytes));
  // Stats are cumulative and only grow; a caller that read them earlier may call later.
  auto advance = [](prometheus::Counter& c, std::uint64_t now, std::uint64_t& seen) {
    if (now > seen) c.Increment(static_cast<double>(now - seen));
    seen = std::max(seen, now);
  };
  advance(m.cache_requests.Add({{"result", "hit"}}), s.hits, m.cache_seen.hits);
  advance(m.cache_requests.Add({{"result", "join"}}), s.joins, m.cache_seen.joins);
  advance(m.cache_requests.Add({{"result", "miss"}}), s.misses, m.cache_seen.misses);
  advance(m.cache_evictions, s.evictions, m.cache_seen.evictions);
  advance(m.cache_decoded, s.bytes_decoded, m.cache_seen.bytes_decoded);
  advance(m.cache_failures, s.failures, m.cache_seen.failures);
}

void Metrics::set_serving(bool serving) {
  impl_->serving_now.store(serving);
}

void Metrics::set_gpu_images(std::uint64_t bytes) {
  impl_->gpu_images.Set(static_cast<double>(bytes));
}

void Metrics::set_receive_buffer(std::uint64_t bytes) {
  impl_->receive_buffer.Set(static_cast<double>(bytes));
}

void Metrics::set_memory_reserved(std::uint64_t bytes) {
  impl_->reserved.Set(static_cast<double>(bytes));
}

void Metrics::set_worker_kept(std::uint64_t bytes) {
  impl_->worker_kept.Set(static_cast<double>(bytes));
}

}  // namespace horizon::server
