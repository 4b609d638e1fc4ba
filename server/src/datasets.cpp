// Resident datasets and their reload.
#include "datasets.hpp"

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "horizon/geodesy/crs.hpp"
#include "file_digest.hpp"
#include "horizon/terrain/dem_reader.hpp"

namespace horizon::server {

std::string signature_of(const std::filesystem::path& path) {
  namespace fs = std::filesystem;
  std::error_code ec;
  auto stamp = [&ec](const fs::path& p) {
    const auto size = fs::is_regular_file(p, ec) ? fs::file_size(p, ec) : 0;
    const auto time = fs::last_write_time(p, ec).time_since_epoch().count();
    return p.filename().string() + ":" + std::to_string(size) + ":" + std::to_string(time) + ";";
  };
  if (!fs::is_directory(path, ec)) return stamp(path);
  std::vector<std::string> entries;
  for (const auto& entry : fs::directory_iterator(path, ec)) entries.push_back(stamp(entry.path()));
  std::sort(entries.begin(), entries.end());
  std::string all;
  for (const auto& e : entries) all += e;
  return all;
}

Result<std::shared_ptr<const Dataset>> load_dataset(const Config& config, const DatasetConfig& entry,
                                                    terrain::BlockCache* cache, unsigned scan_threads) {
  const std::string key = "datasets." + entry.name;
  auto path = resolve_dataset_file(config, entry);
  if (!path.ok()) return path.error();
  auto in_config = [&](Error e) {
    e.message = "config '" + config.source + "': " + key + ": " + e.message;
    e.field = key;
    return e;
  };
  auto d = std::make_shared<Dataset>();
  d->name = entry.name;
  d->file = entry.file;
  d->path = *path;
  d->band = entry.band;
  d->missing_as_nodata = entry.missing_as_nodata;
  d->valid_min = entry.valid_min;
  d->valid_max = entry.valid_max;
  d->signature = signature_of(*path);
  d->sha256 = entry.sha256;
  if (!entry.sha256.empty()) {
    std::error_code ec;
    if (std::filesystem::is_directory(*path, ec))
      return in_config(make_error(ErrorCode::kInvalidArgument,
                                  "sha256: names one file's digest, and '" + entry.file + "' is a folder of tiles",
                                  key));
    auto digest = sha256_of_file(*path);
    if (!digest.ok()) return in_config(digest.error());
    if (*digest != entry.sha256)
      return in_config(make_error(ErrorCode::kDataError,
                                  "sha256: '" + entry.file + "' has SHA-256 " + *digest + ", not the configured " +
                                      entry.sha256 + ": the file is corrupt, or not the one configured",
                                  key));
  }

  terrain::SourceOptions options;
  options.band = entry.band;
  options.missing_as_nodata = entry.missing_as_nodata;
  options.valid_min = entry.valid_min;
  options.valid_max = entry.valid_max;
  auto source = terrain::ElevationSource::open(path->string(), options);
  if (!source.ok()) return in_config(source.error());
  d->source = std::move(*source);
  auto stats = d->source->scan(scan_threads, cache);
  if (!stats.ok()) return in_config(stats.error());
  d->stats = *stats;

  const terrain::DemHeader& h = d->header();
  const auto& t = h.georef.transform;
  const double x0 = t.origin_x, x1 = t.origin_x + h.width * t.pixel_width;
  const double y0 = t.origin_y, y1 = t.origin_y + h.height * t.pixel_height;
  geodesy::GroundScale scale;
  if (h.georef.has_crs()) {
    auto crs = geodesy::Crs::of(h.georef);
    if (!crs.ok()) return crs.error();
    d->crs_name = crs->name();
    d->crs_wkt = crs->wkt();
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
    // Reuse a dataset whose path, options and files are unchanged.
    if (auto it = old->find(entry.name); it != old->end()) {
      const Dataset& have = *it->second;
      auto path = resolve_dataset_file(config, entry);
      if (path.ok() && *path == have.path && entry.band == have.band &&
          entry.missing_as_nodata == have.missing_as_nodata && entry.valid_min == have.valid_min &&
          entry.valid_max == have.valid_max && entry.sha256 == have.sha256 && signature_of(*path) == have.signature) {
        (*next)[entry.name] = it->second;
        continue;
      }
    }
    auto d = load_dataset(config, entry, cache_, scan_threads_);
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

}  // namespace horizon::server
