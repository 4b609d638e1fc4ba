#include "daemon.hpp"

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <exception>
#include <thread>

#include <grpcpp/ext/proto_server_reflection_plugin.h>
#include <grpcpp/resource_quota.h>
#include <grpcpp/health_check_service_interface.h>
#include <grpcpp/security/server_credentials.h>
#include <grpcpp/server.h>
#include <grpcpp/server_builder.h>

#include "dataset_service.hpp"
#include "grpc/health/v1/health.pb.h"
#include "datasets.hpp"
#include "horizon/gpu/context_pool.hpp"
#include "horizon/visibility/backend_policy.hpp"
#include "horizon/visibility/radial_sweep_gl.hpp"
#include "gl_image_budget.hpp"
#include "memory_budget.hpp"
#include "mesh_service.hpp"
#include "meshes.hpp"
#include "metrics.hpp"
#include "request_log.hpp"
#include "scratch_dir.hpp"
#include "server_env.hpp"
#include "session_service.hpp"
#include "trace_service.hpp"
#include "visibility_service.hpp"
#include "worker_pool.hpp"

namespace horizon::server {
namespace {

constexpr const char* kServices[] = {"", "horizon.v1.DatasetService", "horizon.v1.VisibilityService",
                                     "horizon.v1.SessionService", "horizon.v1.TraceService",
                                     "horizon.v1.MeshService"};

// The GPU contexts config.gpu asks for (absent: one per worker thread), or
// null: none asked for, or no EGL display (a warning; the CPU answers all).
// On a hardware device the CPU/GPU crossover for backend auto and the
// fastest GL variant are measured here into `policy`
// (visibility/backend_policy.hpp; a software rasteriser is not timed).
std::unique_ptr<gpu::ContextPool> open_gpu(const Config& config, unsigned workers, visibility::BackendPolicy& policy) {
  const std::uint32_t contexts = config.gpu.contexts.value_or(std::min(workers, 64u));
  if (contexts == 0) return nullptr;
  auto pool = gpu::ContextPool::create(
      {.contexts = static_cast<int>(contexts), .keep_image_bytes = GlImageBudget::kKeepBytes});
  if (!pool.ok()) {
    log_event("warn", "gpu_unavailable",
              {{"contexts", std::to_string(contexts), true},
               {"message", pool.error().message + "; every request runs on the CPU"}});
    return nullptr;
  }
  // Shaders built on every context now, not by the first requests.
  if (auto prepared = visibility::prepare_radial_gl(**pool); !prepared.ok())
    log_event("warn", "gpu_prepare_failed",
              {{"message", prepared.error().message + "; requests on that context run on the CPU"}});
  auto calibration = visibility::calibrate(**pool, policy, {.threads = config.engine_threads});
  if (!calibration.ok())
    log_event("warn", "gpu_calibration_failed",
              {{"message", calibration.error().message + "; backend auto keeps the default crossover"}});
  const gpu::DeviceInfo& device = (*pool)->device();
  const std::uint64_t crossover = policy.crossover_cells();
  log_event("info", "gpu_ready",
            {{"platform", device.platform},
             {"renderer", device.renderer},
             {"version", device.version},
             {"software", device.software ? "true" : "false", true},
             {"contexts", std::to_string((*pool)->size()), true},
             // Backend auto's threshold; null: auto never picks this device.
             {"auto_from_cells", crossover == UINT64_MAX ? "null" : std::to_string(crossover), true},
             // The GL variant for requests that name none (measured fastest on a hardware device).
             {"variant", visibility::gpu_variant_name(policy.preferred_variant())}});
  return std::move(pool).value();
}

}  // namespace

struct Daemon::Impl {
  explicit Impl(Config c)
      : config(std::move(c)),
        memory(config.memory_budget_bytes),
        cache(cache_options(config)),
        datasets(&cache, config.io_threads),
        meshes(memory, &cache, 0),  // preparing on every core: at start nothing else runs
        pool(config.worker_threads),
        env{config, datasets, pool, memory, metrics, cache, meshes},
        sessions(env),
        dataset_service(env),
        visibility_service(env),
        session_service(env, sessions),
        trace_service(env),
        mesh_service(env) {
    env.trimmer = &trimmer;
    env.deadlines = &deadlines;
  }

  void set_serving(bool serving) {
    metrics.set_serving(serving && server);
    if (!server) return;
    auto* health = server->GetHealthCheckService();
    for (const char* name : kServices) health->SetServingStatus(name, serving);
  }

  static terrain::BlockCache::Options cache_options(const Config& c) {
    terrain::BlockCache::Options o;
    o.budget_bytes = c.block_cache_bytes;
    o.io_threads = c.io_threads;
    return o;
  }

  Config config;
  MemoryBudget memory;
  ParseAllowanceOfBudget parse_allowance{memory};
  Metrics metrics;
  DeadlineWatch deadlines;    // outlives every call (env.deadlines)
  Reservation cache_memory;   // the block cache's whole budget, held for the daemon's life
  Reservation receive_memory;  // gRPC's receive buffers (config receive_buffer_mb), likewise
  terrain::BlockCache cache;  // outlives the datasets whose blocks it holds
  DatasetRegistry datasets;
  MeshRegistry meshes;  // after the memory budget its meshes reserve from
  GlImageBudget gl_images{memory, metrics};  // outlives the pool that gives back to it
  std::unique_ptr<gpu::ContextPool> gpu;  // outlives the workers that borrow from it
  visibility::BackendPolicy backend;      // when requests use `gpu`; likewise
  WorkerPool pool;
  ServerEnv env;
  HeapTrimmer trimmer{env.live_calls};  // outlives every call (env.trimmer); reads env's count
  SessionRegistry sessions;             // outlives every session call
  DatasetService dataset_service;
  VisibilityService visibility_service;
  SessionService session_service;
  TraceService trace_service;
  MeshService mesh_service;
  ScratchDir scratch;  // env.scratch; removed after the last call
  std::unique_ptr<grpc::Server> server;
  int port = 0;
  bool stopped = false;
};

namespace {

// TLS when configured (mutual when it names a client CA); plaintext only
// when the config said so (parse_config refuses neither).
std::shared_ptr<grpc::ServerCredentials> credentials(const Config& c) {
  if (!c.tls) return grpc::InsecureServerCredentials();
  grpc::SslServerCredentialsOptions options(c.tls->client_ca_pem.empty()
                                                ? GRPC_SSL_DONT_REQUEST_CLIENT_CERTIFICATE
                                                : GRPC_SSL_REQUEST_AND_REQUIRE_CLIENT_CERTIFICATE_AND_VERIFY);
  options.pem_root_certs = c.tls->client_ca_pem;
  options.pem_key_cert_pairs.push_back({c.tls->key_pem, c.tls->cert_pem});
  return grpc::SslServerCredentials(options);
}

}  // namespace

Daemon::Daemon(Config config) : impl_(std::make_unique<Impl>(std::move(config))) {}
Daemon::~Daemon() {
  shutdown();
}

Status Daemon::start() {
  Impl& d = *impl_;
  int metrics_port = 0;
  if (!d.config.metrics_listen.empty()) {
    try {
      metrics_port = d.metrics.serve(d.config.metrics_listen);
    } catch (const std::exception& e) {
      return make_error(ErrorCode::kIoError,
                        "metrics_listen '" + d.config.metrics_listen + "': cannot listen: " + e.what(),
                        "metrics_listen");
    }
  }

  // The cache may fill to its budget: reserve all of it now (config checked that it fits).
  if (!d.memory.try_reserve(d.config.block_cache_bytes, d.cache_memory))
    return make_error(
        ErrorCode::kResourceExhausted,
        "block_cache_mb: " + std::to_string(d.config.block_cache_bytes >> 20) +
            " MiB does not fit in memory_budget_mb = " + std::to_string(d.config.memory_budget_bytes >> 20),
        "block_cache_mb");
  if (!d.memory.try_reserve(d.config.receive_buffer_bytes, d.receive_memory))
    return make_error(ErrorCode::kResourceExhausted,
                      "receive_buffer_mb: " + std::to_string(d.config.receive_buffer_bytes >> 20) +
                          " MiB does not fit in memory_budget_mb = " +
                          std::to_string(d.config.memory_budget_bytes >> 20) + " beside block_cache_mb",
                      "receive_buffer_mb");
  d.metrics.set_receive_buffer(d.config.receive_buffer_bytes);
  d.metrics.set_memory_reserved(d.memory.reserved());

  auto scratch = ScratchDir::create(d.config.scratch_dir);
  if (!scratch.ok()) return scratch.error();
  d.scratch = std::move(*scratch);
  d.env.scratch = d.scratch.path();

  // Before the first call can arrive: env.gpu is read without a lock.
  d.gpu = open_gpu(d.config, d.pool.threads(), d.backend);
  // llvmpipe's images are this process's memory: inside the budget.
  if (d.gpu && d.gpu->device().software) d.gpu->set_image_memory(&d.gl_images);
  d.env.gpu = d.gpu.get();
  d.env.backend = &d.backend;

  grpc::EnableDefaultHealthCheckService(true);
  // Reflection describes the services whose files are in protobuf's
  // generated pool; gRPC's default health service is built without
  // protobuf, so its file is linked in from horizon_proto (the reference
  // keeps the linker from dropping it) for clients such as buf curl.
  (void)grpc::health::v1::HealthCheckRequest::descriptor();
  grpc::reflection::InitProtoReflectionServerBuilderPlugin();
  grpc::ServerBuilder builder;
  int port = 0;
  // gRPC sets SO_REUSEPORT by default, which lets a second daemon bind a
  // port already in use and take half its connections: off, so that bind fails.
  builder.AddChannelArgument(GRPC_ARG_ALLOW_REUSEPORT, 0);
  builder.AddListeningPort(d.config.listen, credentials(d.config), &port);
  int health_port = 0;
  if (!d.config.health_listen.empty())
    builder.AddListeningPort(d.config.health_listen, grpc::InsecureServerCredentials(), &health_port);
  builder.RegisterService(&d.dataset_service);
  builder.RegisterService(&d.visibility_service);
  builder.RegisterService(&d.session_service);
  builder.RegisterService(&d.trace_service);
  builder.RegisterService(&d.mesh_service);
  builder.SetMaxReceiveMessageSize(static_cast<int>(largest_request_bytes(d.config.limits)));
  // Requests on the wire: gRPC reads a whole message before the daemon sees
  // it, so its buffers get a quota of their own (reserved above). Full, gRPC
  // sheds connections rather than reading more.
  grpc::ResourceQuota quota("horizond");
  quota.Resize(d.config.receive_buffer_bytes);
  builder.SetResourceQuota(quota);
  // From the first request on, each is parsed only when the budget can take it.
  proto::set_parse_allowance(&d.parse_allowance);
  d.server = builder.BuildAndStart();
  if (!d.server || port == 0 || (!d.config.health_listen.empty() && health_port == 0)) {
    proto::remove_parse_allowance(&d.parse_allowance);
    const bool main_port = !d.server || port == 0;
    const std::string key = main_port ? "listen" : "health_listen";
    return make_error(ErrorCode::kIoError,
                      key + " '" + (main_port ? d.config.listen : d.config.health_listen) +
                          "': cannot listen there (is another process using the port, or is the host not an "
                          "address of this machine?)",
                      key);
  }
  d.port = port;
  d.set_serving(false);  // until the datasets are loaded

  const std::string host = d.config.listen.substr(0, d.config.listen.rfind(':'));
  log_event("info", "listening",
            {{"grpc", host + ":" + std::to_string(port)},
             {"grpc_port", std::to_string(port), true},
             {"transport", d.config.tls ? (d.config.tls->client_ca_pem.empty() ? "tls" : "mutual tls") : "plaintext"},
             {"auth", d.config.auth_tokens.empty() ? "none" : "bearer tokens"},
             {"health_port", std::to_string(health_port), true},
             {"metrics_port", std::to_string(metrics_port), true},
             {"workers", std::to_string(d.pool.threads()), true},
             {"memory_budget_mb", std::to_string(d.config.memory_budget_bytes >> 20), true},
             {"block_cache_mb", std::to_string(d.config.block_cache_bytes >> 20), true},
             {"receive_buffer_mb", std::to_string(d.config.receive_buffer_bytes >> 20), true}});
  return Status::Ok();
}

Status Daemon::load_datasets(const CancelToken* cancel) {
  Impl& d = *impl_;
  RunControl control;
  control.cancel = cancel;
  const auto started = std::chrono::steady_clock::now();
  HORIZON_RETURN_IF_ERROR(d.datasets.load(d.config));
  const auto set = d.datasets.snapshot();
  // The meshes are prepared before the daemon says SERVING.
  HORIZON_RETURN_IF_ERROR(d.meshes.load(d.config, *set, &control));
  d.metrics.set_datasets(set->size());
  d.metrics.set_block_cache(d.cache.stats());
  d.metrics.set_memory_reserved(d.memory.reserved());
  d.set_serving(true);
  log_event(
      "info", "datasets_loaded",
      {{"datasets", std::to_string(set->size()), true},
       {"meshes", std::to_string(d.meshes.snapshot()->size()), true},
       {"resident_bytes", std::to_string(d.cache.stats().resident_bytes), true},
       {"seconds", std::to_string(std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count()),
        true}});
  return Status::Ok();
}

Status Daemon::reload(const Config& config, const CancelToken* cancel) {
  Impl& d = *impl_;
  RunControl control;
  control.cancel = cancel;
  HORIZON_RETURN_IF_ERROR(d.datasets.load(config));
  const auto set = d.datasets.snapshot();
  HORIZON_RETURN_IF_ERROR(d.meshes.load(config, *set, &control));
  d.metrics.set_datasets(set->size());
  d.metrics.set_block_cache(d.cache.stats());
  d.metrics.set_memory_reserved(d.memory.reserved());
  log_event("info", "datasets_reloaded",
            {{"datasets", std::to_string(set->size()), true},
             {"meshes", std::to_string(d.meshes.snapshot()->size()), true},
             {"resident_bytes", std::to_string(d.cache.stats().resident_bytes), true}});
  // Everything else is fixed at start: say so rather than ignore it silently.
  if (const auto keys = keys_needing_restart(d.config, config); !keys.empty()) {
    std::string list;
    for (const std::string& k : keys) list += (list.empty() ? "" : ", ") + k;
    log_event("warn", "reload_needs_restart",
              {{"keys", list}, {"message", "changed in the config but applied only at the next start: " + list}});
  }
  return Status::Ok();
}

int Daemon::port() const {
  return impl_->port;
}

void Daemon::shutdown() {
  Impl& d = *impl_;
  if (d.stopped) return;
  d.stopped = true;
  if (d.server) {
    d.set_serving(false);
    log_event("info", "draining",
              {{"in_flight", std::to_string(d.env.pending.load()), true},
               {"grace_ms", std::to_string(d.config.shutdown_grace.count()), true}});
    // New calls are refused (UNAVAILABLE: a client retries elsewhere) and
    // the ones admitted get the grace to finish. Then Shutdown ends what is
    // left: calls past the grace, and the health watches load balancers hold
    // open for ever, which would otherwise keep it waiting the whole grace.
    d.env.draining.store(true);
    d.sessions.drain();  // sessions end now, with UNAVAILABLE: they would never finish on their own
    const auto deadline = std::chrono::steady_clock::now() + d.config.shutdown_grace;
    while (d.env.live_calls.load() > 0 && std::chrono::steady_clock::now() < deadline)
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    d.server->Shutdown(std::chrono::system_clock::now());
  }
  d.pool.join();
  if (d.server) d.server->Wait();
  proto::remove_parse_allowance(&d.parse_allowance);  // no parse of this server's can run now
  log_event("info", "stopped", {});
}

}  // namespace horizon::server
