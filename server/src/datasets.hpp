// datasets.hpp — the DEMs a daemon holds resident, swappable on reload.
//
// A DatasetSet is immutable once built. Requests take a snapshot (a
// shared_ptr) when they start and keep it until they end, so a reload
// (SIGHUP) swaps in a new set without disturbing any request: the old set's
// datasets are freed when the last request using them finishes. A reload
// reuses datasets whose file, band and modification time are unchanged.
// Each dataset's memory is reserved in the MemoryBudget for as long as it lives.
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
#include "memory_budget.hpp"

namespace horizon::server {

struct Dataset {
  std::string name;
  std::string file;  // as configured, relative to the data root
  std::filesystem::path path;
  int band = 0;
  std::filesystem::file_time_type mtime;
  terrain::Dem dem;
  terrain::ElevationStats stats;
  std::string crs_name;
  bool geographic = false;
  std::optional<geodesy::LonLatBounds> lonlat;  // when the CRS converts
  double cell_size_x_m = 0, cell_size_y_m = 0;  // at the raster's centre
  std::uint64_t resident_bytes = 0;
  Reservation memory;
};

using DatasetSet = std::map<std::string, std::shared_ptr<const Dataset>>;

class DatasetRegistry {
 public:
  explicit DatasetRegistry(MemoryBudget& budget) : budget_(budget) {}

  // Loads (or reuses) every dataset of `config`, then swaps the set in. On
  // any error nothing changes and the error names the dataset's config key.
  Status load(const Config& config);

  // The current set; empty (not null) before the first successful load.
  std::shared_ptr<const DatasetSet> snapshot() const;
  bool loaded() const;
  std::uint64_t resident_bytes() const;

 private:
  MemoryBudget& budget_;
  mutable std::mutex mutex_;
  std::shared_ptr<const DatasetSet> current_ = std::make_shared<const DatasetSet>();
  bool loaded_ = false;
};

// Loads one dataset: resolve inside the data root, read, describe, reserve memory.
Result<std::shared_ptr<const Dataset>> load_dataset(const Config& config, const DatasetConfig& entry,
                                                    MemoryBudget& budget);

}  // namespace horizon::server
