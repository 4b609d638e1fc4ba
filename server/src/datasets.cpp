// Resident datasets and their reload.
#include "datasets.hpp"

#include <algorithm>
#include <cmath>

#include "horizon/geodesy/crs.hpp"
#include "horizon/terrain/dem_reader.hpp"

namespace horizon::server {

Result<std::shared_ptr<const Dataset>> load_dataset(const Config& config, const DatasetConfig& entry,
                                                    MemoryBudget& budget) {
  const std::string key = "datasets." + entry.name;
  auto path = resolve_dataset_file(config, entry);
  if (!path.ok()) return path.error();
  auto d = std::make_shared<Dataset>();
  d->name = entry.name;
  d->file = entry.file;
  d->path = *path;
  d->band = entry.band;
  std::error_code ec;
  d->mtime = std::filesystem::last_write_time(*path, ec);

  terrain::ReadOptions read;
  read.band = entry.band;
  auto dem = terrain::read_dem(path->string(), read);
  if (!dem.ok()) {
    Error e = dem.error();
    e.message = "config '" + config.source + "': " + key + ": " + e.message;
    e.field = key;
    return e;
  }
  d->dem = std::move(*dem);
  d->resident_bytes = static_cast<std::uint64_t>(d->dem.elevation.size()) * sizeof(float);
  if (!budget.try_reserve(d->resident_bytes, d->memory))
    return make_error(ErrorCode::kResourceExhausted,
                      "config '" + config.source + "': " + key + ": " + std::to_string(d->resident_bytes >> 20) +
                          " MiB of elevations do not fit in memory_budget_mb (" +
                          std::to_string(budget.reserved() >> 20) + " MiB already held of " +
                          std::to_string((budget.total() - MemoryBudget::kBaseBytes) >> 20) + " MiB usable)",
                      "memory_budget_mb");
  d->stats = terrain::elevation_stats(d->dem.elevation);

  const auto& t = d->dem.georef.transform;
  const double x0 = t.origin_x, x1 = t.origin_x + d->dem.width() * t.pixel_width;
  const double y0 = t.origin_y, y1 = t.origin_y + d->dem.height() * t.pixel_height;
  geodesy::GroundScale scale;
  if (d->dem.georef.epsg != 0) {
    auto crs = geodesy::Crs::from_epsg(d->dem.georef.epsg);
    if (!crs.ok()) return crs.error();
    d->crs_name = crs->name();
    d->geographic = crs->is_geographic();
    scale = crs->ground_scale({(x0 + x1) / 2, (y0 + y1) / 2});
    d->lonlat = geodesy::lonlat_bounds(*crs, std::min(x0, x1), std::min(y0, y1), std::max(x0, x1), std::max(y0, y1));
  }
  d->cell_size_x_m = std::abs(t.pixel_width) * scale.metres_per_x;
  d->cell_size_y_m = std::abs(t.pixel_height) * scale.metres_per_y;
  return std::shared_ptr<const Dataset>(std::move(d));
}

Status DatasetRegistry::load(const Config& config) {
  const std::shared_ptr<const DatasetSet> old = snapshot();
  auto next = std::make_shared<DatasetSet>();
  for (const DatasetConfig& entry : config.datasets) {
    // Reuse a dataset whose file, band and modification time are unchanged.
    if (auto it = old->find(entry.name); it != old->end()) {
      const Dataset& have = *it->second;
      auto path = resolve_dataset_file(config, entry);
      std::error_code ec;
      if (path.ok() && *path == have.path && entry.band == have.band &&
          std::filesystem::last_write_time(*path, ec) == have.mtime) {
        (*next)[entry.name] = it->second;
        continue;
      }
    }
    auto d = load_dataset(config, entry, budget_);
    if (!d.ok()) return d.error();
    (*next)[entry.name] = std::move(*d);
  }
  std::lock_guard lock(mutex_);
  current_ = std::move(next);
  loaded_ = true;
  return Status::Ok();
}

std::shared_ptr<const DatasetSet> DatasetRegistry::snapshot() const {
  std::lock_guard lock(mutex_);
  return current_;
}

bool DatasetRegistry::loaded() const {
  std::lock_guard lock(mutex_);
  return loaded_;
}

std::uint64_t DatasetRegistry::resident_bytes() const {
  std::uint64_t total = 0;
  for (const auto& [name, d] : *snapshot()) total += d->resident_bytes;
  return total;
}

}  // namespace horizon::server
