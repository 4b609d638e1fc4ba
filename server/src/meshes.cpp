// Resident meshes and their reload.
#include "meshes.hpp"

#include <atomic>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <string>

#include "request_log.hpp"

namespace horizon::server {
namespace {

bool same_boxes(const std::vector<visibility::BoxSpec>& a, const std::vector<visibility::BoxSpec>& b) {
  if (a.size() != b.size()) return false;
  for (std::size_t i = 0; i < a.size(); ++i)
    if (a[i].x_min != b[i].x_min || a[i].y_min != b[i].y_min || a[i].x_max != b[i].x_max || a[i].y_max != b[i].y_max ||
        a[i].z_min != b[i].z_min || a[i].z_max != b[i].z_max)
      return false;
  return true;
}

// Everything a preparation depends on (the thread count does not change it).
bool same_config(const MeshConfig& a, const MeshConfig& b) {
  const mesh::PrepareOptions &p = a.prepare, &q = b.prepare;
  return a.dataset == b.dataset && a.file == b.file && a.greedy.max_vertices == b.greedy.max_vertices &&
         a.greedy.max_error == b.greedy.max_error && p.horizons.sectors == q.horizons.sectors &&
         p.horizons.subsectors == q.horizons.subsectors && p.crystals.seeds == q.crystals.seeds &&
         p.crystals.min_group_size == q.crystals.min_group_size &&
         p.crystals.max_orphan_passes == q.crystals.max_orphan_passes &&
         p.crystals.max_groups == q.crystals.max_groups && p.crystals.random_seed == q.crystals.random_seed &&
         p.merge_cutoff == q.merge_cutoff && p.max_chain_corners == q.max_chain_corners && same_boxes(a.boxes, b.boxes);
}

// A DEM cell read whole for its TIN: the elevation (4 bytes), the greedy
// insertion's per-cell marks and the cell's place in the Delaunay walk.
constexpr std::uint64_t kBytesPerDemCell = 8;

}  // namespace

Result<std::shared_ptr<const ServedMesh>> MeshRegistry::prepare(const Config& config, const MeshConfig& entry,
                                                                const DatasetSet& datasets, const RunControl* control) {
  const std::string key = "meshes." + entry.name;
  auto in_config = [&](Error e, const std::string& field) {
    e.message = "config '" + config.source + "': " + field + ": " + e.message;
    e.field = field;
    return e;
  };
  const auto started = std::chrono::steady_clock::now();
  mesh::MeshModelOptions options;
  options.greedy = entry.greedy;
  options.prepare = entry.prepare;
  options.prepare.horizons.threads = threads_;
  if (!config.mesh_cache_dir.empty()) options.cache_dir = config.mesh_cache_dir.string();

  // Progress in the log, each quarter of the way.
  std::atomic<int> logged_quarter{0};  // reports may come from any worker thread
  RunControl progress;
  if (control) progress = *control;
  progress.progress = [&](double fraction) {
    const int quarter = static_cast<int>(fraction * 4);
    int seen = logged_quarter.load();
    if (quarter >= 4) return;
    do
      if (quarter <= seen) return;
    while (!logged_quarter.compare_exchange_weak(seen, quarter));
    log_event("info", "mesh_progress", {{"mesh", entry.name}, {"fraction", std::to_string(quarter * 0.25), true}});
  };

  // The working memory, held until the mesh is prepared: the DEM and the
  // insertion's per-cell tables, then the preparation's peak, each reserved
  // before the work that needs it.
  Reservation reading, preparing;
  const auto refuse = [&](std::uint64_t bytes, const std::string& what) {
    return make_error(ErrorCode::kResourceExhausted,
                      "config '" + config.source + "': " + key + ": " + what + " needs about " + mib_text(bytes) +
                          ", more than memory_budget_mb = " + std::to_string(config.memory_budget_bytes >> 20) +
                          " has left beside the block cache, the receive buffers and the other meshes",
                      key);
  };
  options.before_prepare = [&](const mesh::Tin& tin) -> Status {
    const std::uint64_t bytes = mesh::preparation_bytes(tin.vertices.size(), options.prepare, threads_);
    if (!memory_.try_reserve(bytes, preparing))
      return refuse(bytes, "preparing its " + std::to_string(tin.vertices.size()) + " vertices");
    return Status::Ok();
  };

  std::shared_ptr<const Dataset> dataset;
  std::string signature, source;
  std::optional<Result<mesh::MeshModel>> model;
  log_event("info", "mesh_preparing", {{"mesh", entry.name}});
  if (!entry.dataset.empty()) {
    const auto it = datasets.find(entry.dataset);
    if (it == datasets.end())
      return make_error(
          ErrorCode::kNotFound,
          "config '" + config.source + "': " + key + ".dataset: '" + entry.dataset + "' is not a loaded dataset",
          key + ".dataset");
    dataset = it->second;
    source = "dataset:" + entry.dataset;
    const terrain::DemHeader& h = dataset->header();
    const std::uint64_t cells = static_cast<std::uint64_t>(h.width) * static_cast<std::uint64_t>(h.height);
    // The whole DEM is read and measured: bounded like any request's window.
    if (cells > config.limits.max_cells)
      return make_error(ErrorCode::kResourceExhausted,
                        "config '" + config.source + "': " + key + ".dataset: '" + entry.dataset + "' has " +
                            std::to_string(cells) +
                            " cells, more than limits.max_cells = " + std::to_string(config.limits.max_cells) +
                            " (a TIN is built from the whole DEM: crop it, or build the TIN offline with "
                            "`horizon mesh prepare --mesh-out` and configure the file)",
                        key + ".dataset");
    if (const std::uint64_t bytes = cells * kBytesPerDemCell; !memory_.try_reserve(bytes, reading))
      return refuse(bytes, "reading '" + entry.dataset + "' whole for its TIN");
    auto dem = dataset->source->read({0, 0, h.width, h.height}, cache_, control);
    if (!dem.ok()) return in_config(dem.error(), key + ".dataset");
    model = mesh::MeshModel::from_dem(std::move(*dem), options, &progress);
  } else {
    auto path = resolve_mesh_file(config, entry);
    if (!path.ok()) return path.error();
    source = "file:" + entry.file;
    signature = signature_of(*path);
    model = mesh::MeshModel::from_file(path->string(), options, &progress);
  }
  if (!model->ok()) {
    if (model->error().code == ErrorCode::kResourceExhausted && model->error().field == key) return model->error();
    return in_config(model->error(), key);
  }
  if (!entry.boxes.empty())
    if (auto s = (*model)->register_boxes(entry.boxes, threads_); !s.ok()) return in_config(s.error(), key + ".boxes");

  reading.release();
  preparing.release();
  const std::uint64_t bytes = (*model)->memory_bytes();
  Reservation memory;
  if (!memory_.try_reserve(bytes, memory))
    return make_error(ErrorCode::kResourceExhausted,
                      "config '" + config.source + "': " + key + ": the prepared mesh holds " + mib_text(bytes) +
                          ", more than memory_budget_mb = " + std::to_string(config.memory_budget_bytes >> 20) +
                          " has left beside the block cache, the receive buffers and the other meshes",
                      key);
  const mesh::MeshModel& m = **model;
  log_event(
      "info", "mesh_prepared",
      {{"mesh", entry.name},
       {"source", source},
       {"vertices", std::to_string(m.prepared().tin.vertices.size()), true},
       {"triangles", std::to_string(m.prepared().tin.triangles.size()), true},
       {"groups", std::to_string(m.prepared().stats.leaf_groups), true},
       {"from_cache", m.cache_use().hit ? "true" : "false", true},
       {"cache_note", m.cache_use().note},
       {"resident_bytes", std::to_string(bytes), true},
       {"seconds", std::to_string(std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count()),
        true}});
  return std::shared_ptr<const ServedMesh>(std::make_shared<ServedMesh>(
      ServedMesh{entry, source, signature, std::move(dataset), std::move(**model), std::move(memory)}));
}

Status MeshRegistry::load(const Config& config, const DatasetSet& datasets, const RunControl* control) {
  const std::shared_ptr<const MeshSet> old = snapshot();
  auto next = std::make_shared<MeshSet>();
  for (const MeshConfig& entry : config.meshes) {
    if (auto it = old->find(entry.name); it != old->end()) {
      const ServedMesh& have = *it->second;
      bool same_source = false;
      if (!entry.dataset.empty()) {
        const auto d = datasets.find(entry.dataset);
        same_source = d != datasets.end() && d->second == have.dataset;
      } else if (auto path = resolve_mesh_file(config, entry); path.ok()) {
        same_source = entry.file == have.config.file && signature_of(*path) == have.signature;
      }
      if (same_source && same_config(entry, have.config)) {
        (*next)[entry.name] = it->second;
        continue;
      }
    }
    auto served = prepare(config, entry, datasets, control);
    if (!served.ok()) return served.error();
    (*next)[entry.name] = std::move(*served);
  }
  std::lock_guard lock(mutex_);
  current_ = std::move(next);
  return Status::Ok();
}

std::shared_ptr<const MeshSet> MeshRegistry::snapshot() const {
  std::lock_guard lock(mutex_);
  return current_;
}

}  // namespace horizon::server
