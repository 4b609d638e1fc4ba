// config.hpp — horizond's configuration: a JSON file, read once at start and
// again on SIGHUP (datasets only).
//
//   {
//     "listen": "0.0.0.0:50051",            gRPC address (host:port; port 0 = any free port)
//     "metrics_listen": "0.0.0.0:9464",     Prometheus /metrics address; "" or absent = off
//     "data_root": "/srv/horizon/dem",      every dataset file resolves inside it
//     "datasets": {                         name -> file or folder (relative to data_root), or
//       "rainier": "rainier.tif",           name -> {"file": "x.tif", "band": 2, "missing_tiles": "nodata"}
//       "multi": {"file": "bands.tif", "band": 2},
//       "alps": "srtm/alps"                 a folder of tiles on one grid (terrain/source.hpp)
//     },                                    "missing_tiles": "error" (default: a request needing a
//                                           tile no file covers fails) or "nodata" (read as voids);
//                                           "valid_range": [-12000, 9000] (the default, metres): a
//                                           cell outside it is a corrupt block, refused at load;
//                                           "sha256": "<64 hex digits>" (a single file): its bytes
//                                           checked against sha256sum's digest at every load
//     "meshes": {                           TIN meshes culled per frame (MeshService, mesh.proto),
//       "rainier_tin": {"dataset": "rainier",  built from a dataset by greedy insertion ("vertices",
//                       "vertices": 100000},   default 100000, [4, 16000000]; "max_error_m", default 0),
//       "city": {"file": "city.ply"}         or read from an OBJ/PLY file inside data_root; knobs
//     },                                    (defaults the thesis's): "sectors" 16 [3, 256],
//                                           "subsectors" 4 [1, 64] (sectors x subsectors <= 1024),
//                                           "seeds" 500, "min_group" 30, "max_groups" 1000 (each
//                                           [1, 1000000]), "orphan_passes" 10 [0, 1000],
//                                           "merge_cutoff" 0.25 (0, 1], "random_seed" 1; "boxes":
//                                           [[x_min, y_min, x_max, y_max, z_min, z_max], ...] in the
//                                           source's CRS, at most limits.max_boxes. Prepared at load
//                                           (and on SIGHUP when changed), held in memory_budget_mb; a
//                                           dataset's TIN reads the whole DEM, at most limits.max_cells
//     "mesh_cache_dir": "cache/meshes",     prepared meshes kept on disk (mesh/prepared_cache.hpp),
//                                           keyed by the TIN and the knobs; absent: none
//     "memory_budget_mb": 2048,             the block cache + the working memory of requests in flight
//     "block_cache_mb": 256,                decoded elevation blocks shared by every request (LRU),
//                                           reserved in memory_budget_mb at start; [1, 1048576]
//     "receive_buffer_mb": 256,             requests still on the wire: gRPC's receive buffers (a
//                                           quota it keeps, reserved in memory_budget_mb at start);
//                                           when full, gRPC sheds connections (their calls end
//                                           UNAVAILABLE, to be retried) rather than read more; at
//                                           least the largest request the limits allow; default
//                                           budget/8, at least that request
//     "worker_kept_mb": 512,                the workers' buffers kept from one run to the next, in
//                                           memory_budget_mb (worker_memory.hpp); past it a run's
//                                           buffers are freed when it ends; 0: none kept; default
//                                           budget/4, at most the budget
//     "io_threads": 2,                      threads decoding blocks for the cache; [1, 64]
//     "worker_threads": 2,                  computations run concurrently (Asio pool); 0 = all cores
//     "engine_threads": 1,                  threads one computation may use; 0 = all cores
//     "limits": {"max_cells": 25000000,     cells in one viewshed or culling window
//                "max_boxes": 100000,       boxes in one CullBoxes call
//                "max_lines": 10000,        sight lines in one LineOfSight call
//                "max_pending": 64,         requests admitted at once (computing, queued or streaming)
//                "max_observers": 1000,     observers in one many-observer ComputeViewshed
//                "max_trace_pixels":        pixels (width x height) of one TraceCamera frame,
//                    16777216},             [1, 67108864] (8192 x 8192, the engine's largest frame)
//     "sessions": {"max": 8,                clip-map sessions open at once (0: none); each holds its
//                  "idle_ms": 60000,        clip-map in memory_budget_mb; ended after idle_ms without
//                  "max_boxes": 100000,     a message; boxes per session; the largest level_size a
//                  "max_level_size": 2048,  client may ask for, and the level_size and subtile a
//                  "level_size": 1024,      client that asks for none gets (powers of two)
//                  "subtile": 64,           exact sessions: the engine memory each reserves for
//                  "exact_mb": 256},        its answers (an answer that needs more is refused)
//     "gpu": {"contexts": 2},               GL contexts for the GPU backend, [0, 64]: one per request
//                                           computing on the GPU at once; absent = one per worker
//                                           thread (at most 64); 0 = no GPU, every request on the CPU
//     "default_deadline_ms": 30000,         for requests that carry no deadline
//     "shutdown_grace_ms": 10000,           SIGTERM/SIGINT: time in-flight requests get to finish
//     "scratch_dir": "/tmp",                holds the daemon's private 0700 directory where GeoTIFF/PNG
//                                           bytes are encoded (default: $TMPDIR or /tmp)
//     "tls": {"cert_file": "server.crt",    the gRPC port's certificate chain and key (PEM); with
//             "key_file": "server.key",     client_ca_file, clients must present a certificate
//             "client_ca_file": "ca.crt"},  that CA signed (mutual TLS)
//     "health_listen": "0.0.0.0:50052",     with tls: a plaintext port for the health service (and
//                                           reflection) only, for probes that cannot speak TLS
//                                           (Kubernetes'); our services refuse calls arriving on it
//     "plaintext": false,                   true: serve gRPC unencrypted; required when "tls" is absent
//                                           (loopback and tests), refused beside it
//     "auth_tokens_file": "tokens"          bearer tokens (auth.hpp), one a line: every call of our
//                                           services must carry one; absent: no token asked
//   }
//
// Files named by keys (tls.*, auth_tokens_file) are read when the config is:
// --check-config proves they are there. Every key is checked; an unknown key, a wrong type or a value out of range
// is an Error whose message and field name the key ("limits.max_cells",
// "datasets.rainier"). Relative data_root and scratch_dir resolve against the
// config file's directory.
//
// GPU. With contexts > 0 the daemon opens a headless EGL display at start
// (gpu/context_pool.hpp: ~30 ms plus ~6 ms a context), on a hardware device
// measures from which window size the GPU beats the CPU (visibility/backend_policy.hpp),
// and logs the device ("gpu_ready"). A request with backend GPU (or auto, on a
// hardware GPU, from that size) borrows a context for its computation,
// waiting when all are lent. No EGL display, or no OpenGL 4.3, is a warning
// ("gpu_unavailable"), not an error: the daemon then answers every request on
// the CPU, and a request that asked for the GPU says so in
// WorkStats.gpu_fallback.
#pragma once

#include <chrono>
#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "horizon/common/error.hpp"
#include "horizon/mesh/prepared_mesh.hpp"
#include "horizon/mesh/tin_from_dem.hpp"
#include "horizon/terrain/source.hpp"
#include "horizon/visibility/cull.hpp"

namespace horizon::server {

// The longest dataset name (bytes); requests naming a longer one are refused unread.
inline constexpr std::size_t kMaxDatasetName = 128;

struct DatasetConfig {
  std::string name;                // the key
  std::string file;                // as written, relative to data_root: a raster, or a folder of tiles
  int band = 0;                    // 1-based; 0 = the file's only band
  bool missing_as_nodata = false;  // "missing_tiles": "nodata"
  // "valid_range": [min, max], plausible elevations (terrain::SourceOptions).
  double valid_min = terrain::SourceOptions{}.valid_min;
  double valid_max = terrain::SourceOptions{}.valid_max;
  // "sha256": the file's SHA-256 (64 hex digits, kept lowercase), checked on
  // every load; empty: not checked. A single file only, not a folder of tiles.
  std::string sha256;
};

// One configured mesh: a TIN from a dataset, or from a file.
struct MeshConfig {
  std::string name;     // the key
  std::string dataset;  // a configured dataset's name, or
  std::string file;     // an OBJ or PLY file, relative to data_root
  mesh::GreedyOptions greedy;    // dataset only
  mesh::PrepareOptions prepare;  // the knobs (threads: the daemon's io_threads at load)
  std::vector<visibility::BoxSpec> boxes;  // registered with the mesh, in the source's CRS
};

struct Limits {
  std::uint64_t max_cells = 25'000'000;
  std::uint32_t max_boxes = 100'000;
  std::uint32_t max_lines = 10'000;
  std::uint32_t max_pending = 64;
  std::uint32_t max_observers = 1'000;
  std::uint64_t max_trace_pixels = 4096ull * 4096ull;
};

// The largest request message the limits allow (gRPC's max receive size): a
// full CullBoxes (about 70 bytes per box on the wire), LineOfSight or
// many-observer ComputeViewshed call, with room to spare; at most 512 MiB.
std::uint64_t largest_request_bytes(const Limits& limits);

// The most limits.max_trace_pixels may be: the engine's largest frame
// (trace::kMaxSide squared).
inline constexpr std::uint64_t kMaxTracePixelsCeiling = 8192ull * 8192ull;

// The gRPC port's TLS: a server certificate, and optionally the CA whose
// client certificates it requires (mutual TLS). PEM text, read at load.
struct TlsConfig {
  std::string cert_pem, key_pem;
  std::string client_ca_pem;  // empty: no client certificate asked for
};

// Clip-map sessions (protos/horizon/v1/session.proto).
struct SessionConfig {
  std::uint32_t max = 8;                // open at once; 0 = no sessions
  std::uint32_t idle_ms = 60'000;       // a session without a message for this long is ended
  std::uint32_t max_boxes = 100'000;    // boxes in one session
  std::uint32_t max_level_size = 2048;  // the largest level_size a client may ask for
  std::uint32_t level_size = 1024;      // when a client asks for none
  std::uint32_t subtile = 64;           // when a client asks for none
  std::uint32_t exact_mb = 256;         // engine memory an exact session reserves for its answers
};

struct GpuConfig {
  // EGL contexts, [0, 64]; nullopt = one per worker thread (at most 64); 0 = no GPU.
  std::optional<std::uint32_t> contexts;
};

struct Config {
  std::string source;  // path of the file, for messages
  std::string listen = "127.0.0.1:50051";
  std::string metrics_listen;
  std::filesystem::path data_root;
  std::vector<DatasetConfig> datasets;  // in name order
  std::vector<MeshConfig> meshes;       // in name order
  std::filesystem::path mesh_cache_dir;  // empty: no cache
  std::uint64_t memory_budget_bytes = 2048ull << 20;
  std::uint64_t block_cache_bytes = 256ull << 20;
  std::uint64_t receive_buffer_bytes = 256ull << 20;
  std::uint64_t worker_kept_bytes = 512ull << 20;
  unsigned io_threads = 2;
  unsigned worker_threads = 2;
  unsigned engine_threads = 1;
  Limits limits;
  SessionConfig sessions;
  GpuConfig gpu;
  std::chrono::milliseconds default_deadline{30'000};
  std::chrono::milliseconds shutdown_grace{10'000};
  std::filesystem::path scratch_dir;
  // Transport and callers: TLS, or plaintext only when the file says so.
  std::optional<TlsConfig> tls;
  std::string health_listen;  // with tls only; empty: none
  bool plaintext = false;
  std::vector<std::string> auth_tokens;  // auth_tokens_file's; empty: every caller accepted
};

// Command-line overrides applied before checking (empty: keep the file's value).
// A deployment config can so be checked against a local copy of the DEM
// volume (--data-root), or a test daemon put on an ephemeral port (--listen).
struct ConfigOverrides {
  std::string listen, metrics_listen, data_root;  // data_root: relative to the working directory
};

// The keys whose values differ between the running configuration and one
// read on SIGHUP, among those a reload does not apply (everything but the
// datasets, the meshes, mesh_cache_dir and data_root): they take effect at the next start. In the order
// the file documents them, e.g. {"listen", "limits.max_cells"}.
std::vector<std::string> keys_needing_restart(const Config& running, const Config& next);

// Parses and checks a configuration document. `base_dir` resolves relative paths.
Result<Config> parse_config(const std::string& text, const std::string& source, const std::filesystem::path& base_dir,
                            const ConfigOverrides& overrides = {});
// Reads and parses a file.
Result<Config> load_config(const std::string& path, const ConfigOverrides& overrides = {});

// The dataset's file or folder, resolved (symlinks followed) and checked to
// lie inside the data root. Errors name "datasets.<name>".
Result<std::filesystem::path> resolve_dataset_file(const Config& config, const DatasetConfig& dataset);
// A mesh's file, likewise; errors name "meshes.<name>.file".
Result<std::filesystem::path> resolve_mesh_file(const Config& config, const MeshConfig& mesh);

}  // namespace horizon::server
