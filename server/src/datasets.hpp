// datasets.hpp — the DEMs a daemon serves, swappable on reload.
//
// A dataset is an elevation source (terrain/source.hpp): one raster file, or
// a folder of tiles on one grid. Loading opens it (headers only), then scans
// every block once through the daemon's shared BlockCache (checking that each
// decodes, and measuring the elevation statistics), which keeps what fits:
// requests read the blocks they need through the same cache, so a dataset
// may be far larger than memory.
//
// A DatasetSet is immutable once built. Requests take a snapshot (a
// shared_ptr) when they start and keep it until they end, so a reload
// (SIGHUP) swaps in a new set without disturbing any request: the old set's
// datasets are freed when the last request using them finishes. A reload
// reuses datasets whose path, options and files (names, sizes, modification
// times) are unchanged.
#pragma once

#include <filesystem>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>

#include "config.hpp"
#include "horizon/common/error.hpp"
#include "horizon/geodesy/crs.hpp"
#include "horizon/terrain/dem.hpp"
#include "horizon/terrain/source.hpp"

namespace horizon::server {

struct Dataset {
  std::string name;
  std::string file;  // as configured, relative to the data root
  std::filesystem::path path;
  int band = 0;
  bool missing_as_nodata = false;
  double valid_min = 0.0, valid_max = 0.0;  // as configured
  std::string sha256;                        // as configured ("" = not checked)
  std::string signature;  // the files' names, sizes and modification times
  std::shared_ptr<const terrain::ElevationSource> source;
  terrain::ElevationStats stats;
  std::string crs_name, crs_wkt;  // empty without a CRS
  bool geographic = false;
  std::optional<geodesy::LonLatBounds> lonlat;  // when the CRS converts
  double cell_size_x_m = 0, cell_size_y_m = 0;  // at the raster's centre

  const terrain::DemHeader& header() const { return source->header(); }
};

using DatasetSet = std::map<std::string, std::shared_ptr<const Dataset>>;

class DatasetRegistry {
 public:
  // Loading scans each dataset through `cache` (may be null: nothing kept)
  // on `scan_threads` threads (0 = all cores).
  explicit DatasetRegistry(terrain::BlockCache* cache, unsigned scan_threads = 0)
      : cache_(cache), scan_threads_(scan_threads) {}

  // Loads (or reuses) every dataset of `config`, then swaps the set in. On
  // any error nothing changes and the error names the dataset's config key.
  Status load(const Config& config);

  // The current set; empty (not null) before the first successful load.
  std::shared_ptr<const DatasetSet> snapshot() const;
  bool loaded() const;

 private:
  terrain::BlockCache* cache_;
  unsigned scan_threads_;
  mutable std::mutex mutex_;
  std::shared_ptr<const DatasetSet> current_ = std::make_shared<const DatasetSet>();
  bool loaded_ = false;
};

// What a reload compares: for a file its name, size and modification time,
// for a folder those of every entry in it (a tile added, removed or
// rewritten changes it). Meshes read from files use it too (meshes.hpp).
std::string signature_of(const std::filesystem::path& path);

// Loads one dataset: resolve inside the data root, open, scan, describe.
Result<std::shared_ptr<const Dataset>> load_dataset(const Config& config, const DatasetConfig& entry,
                                                    terrain::BlockCache* cache, unsigned scan_threads);

}  // namespace horizon::server
