// horizond — the Horizon visibility daemon.
//
//   horizond --config FILE [--listen HOST:PORT] [--metrics-listen HOST:PORT] [--data-root DIR]
//   horizond --check-config FILE [--data-root DIR]
//
// Exit status: 0 after a clean shutdown (SIGTERM/SIGINT) or a valid
// --check-config; 1 when the daemon cannot start (bad config, a dataset that
// does not load, an address in use); 2 for a usage error.
#include <condition_variable>
#include <cstdio>
#include <cstring>
#include <mutex>
#include <string>
#include <string_view>

#include "allocator.hpp"
#include "config.hpp"
#include "daemon.hpp"
#include "datasets.hpp"
#include "memory_budget.hpp"
#include "meshes.hpp"
#include "request_log.hpp"
#include "signals.hpp"

namespace {

using namespace horizon::server;

constexpr const char* kUsage =
    "Usage: horizond --config FILE [--listen HOST:PORT] [--metrics-listen HOST:PORT] [--data-root DIR]\n"
    "       horizond --check-config FILE [--data-root DIR]\n"
    "\n"
    "Serves the horizon.v1 gRPC API (DatasetService, VisibilityService, SessionService,\n"
    "TraceService, MeshService), the gRPC health service and server reflection;\n"
    "Prometheus metrics on metrics_listen.\n"
    "SIGTERM/SIGINT drain and exit 0; SIGHUP reloads the datasets and meshes from FILE.\n"
    "--check-config validates FILE, loads every dataset and prepares every mesh, then\n"
    "exits (0 = accepted).\n"
    "The overrides replace the file's values (port 0 = any free port).\n";

struct Options {
  std::string config;
  bool check = false;
  ConfigOverrides overrides;
};

int usage_error(const std::string& message) {
  std::fprintf(stderr, "horizond: error: %s\n%s", message.c_str(), kUsage);
  return 2;
}

// Events from the signal thread to the main thread.
struct Events {
  std::mutex mutex;
  std::condition_variable wake;
  bool stop = false;
  int reloads = 0;
};

int check_config(const Options& o) {
  auto config = load_config(o.config, o.overrides);
  if (!config.ok()) {
    std::fprintf(stderr, "horizond: %s\n", config.error().message.c_str());
    return 1;
  }
  // Every dataset opened and every block decoded once, nothing kept.
  DatasetRegistry registry(nullptr, config->io_threads);
  if (auto s = registry.load(*config); !s.ok()) {
    std::fprintf(stderr, "horizond: %s\n", s.error().message.c_str());
    return 1;
  }
  // Every mesh prepared, in what the budget leaves beside the cache and the receive buffers.
  MemoryBudget memory(config->memory_budget_bytes);
  Reservation fixed;
  (void)memory.try_reserve(config->block_cache_bytes + config->receive_buffer_bytes, fixed);
  MeshRegistry meshes(memory, nullptr, 0);
  if (auto s = meshes.load(*config, *registry.snapshot()); !s.ok()) {
    std::fprintf(stderr, "horizond: %s\n", s.error().message.c_str());
    return 1;
  }
  std::uint64_t cells = 0;
  for (const auto& [name, d] : *registry.snapshot())
    cells += static_cast<std::uint64_t>(d->header().width) * static_cast<std::uint64_t>(d->header().height);
  std::printf(
      "horizond: config '%s' accepted: %zu datasets, %llu M cells (every block decodes), %zu meshes prepared, a %llu "
      "MiB block cache of a %llu MiB budget, listen %s\n",
      o.config.c_str(), config->datasets.size(), static_cast<unsigned long long>(cells / 1000000),
      config->meshes.size(),
      static_cast<unsigned long long>(config->block_cache_bytes >> 20),
      static_cast<unsigned long long>(config->memory_budget_bytes >> 20), config->listen.c_str());
  return 0;
}

int serve(const Options& o) {
  tune_allocator();  // before any thread: gRPC's and the workers' arenas start with it
  auto config = load_config(o.config, o.overrides);
  if (!config.ok()) {
    log_event("error", "config_rejected", {{"message", config.error().message}, {"key", config.error().field}});
    return 1;
  }
  Events events;
  // A stop while the meshes are being prepared (seconds to minutes) ends the preparation.
  horizon::CancelToken loading;
  // Signals are watched before anything starts, so an early SIGTERM is a clean stop.
  SignalWatcher signals(
      [&] {
        loading.cancel();
        std::lock_guard lock(events.mutex);
        events.stop = true;
        events.wake.notify_all();
      },
      [&] {
        std::lock_guard lock(events.mutex);
        ++events.reloads;
        events.wake.notify_all();
      });

  Daemon daemon(*config);
  if (auto s = daemon.start(); !s.ok()) {
    log_event("error", "start_failed", {{"message", s.error().message}, {"key", s.error().field}});
    return 1;
  }
  if (auto s = daemon.load_datasets(&loading); !s.ok()) {
    if (loading.cancelled()) {  // SIGTERM/SIGINT while loading: a clean stop
      daemon.shutdown();
      return 0;
    }
    log_event("error", "datasets_rejected", {{"message", s.error().message}, {"key", s.error().field}});
    daemon.shutdown();
    return 1;
  }

  std::unique_lock lock(events.mutex);
  while (true) {
    events.wake.wait(lock, [&] { return events.stop || events.reloads > 0; });
    if (events.stop) break;
    events.reloads = 0;
    lock.unlock();
    // Datasets only: addresses, limits and threads stay as started.
    auto next = load_config(o.config, o.overrides);
    if (!next.ok())
      log_event("warn", "reload_rejected", {{"message", next.error().message}, {"key", next.error().field}});
    else if (auto s = daemon.reload(*next, &loading); !s.ok())
      log_event("warn", "reload_rejected", {{"message", s.error().message}, {"key", s.error().field}});
    lock.lock();
  }
  lock.unlock();
  daemon.shutdown();
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  Options o;
  for (int i = 1; i < argc; ++i) {
    const std::string_view arg = argv[i];
    auto value = [&](std::string& out) {
      if (i + 1 >= argc) return false;
      out = argv[++i];
      return true;
    };
    if (arg == "--help" || arg == "-h") {
      std::fputs(kUsage, stdout);
      return 0;
    } else if (arg == "--config") {
      if (!value(o.config)) return usage_error("--config needs a file");
    } else if (arg == "--check-config") {
      o.check = true;
      if (!value(o.config)) return usage_error("--check-config needs a file");
    } else if (arg == "--listen") {
      if (!value(o.overrides.listen)) return usage_error("--listen needs HOST:PORT");
    } else if (arg == "--metrics-listen") {
      if (!value(o.overrides.metrics_listen)) return usage_error("--metrics-listen needs HOST:PORT");
    } else if (arg == "--data-root") {
      if (!value(o.overrides.data_root)) return usage_error("--data-root needs a directory");
    } else {
      return usage_error("unknown argument '" + std::string(arg) + "'");
    }
  }
  if (o.config.empty()) return usage_error("give --config FILE (or --check-config FILE)");
  return o.check ? check_config(o) : serve(o);
}
