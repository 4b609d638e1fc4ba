// meshes.hpp — the TIN meshes a daemon serves (config "meshes"), prepared
// at load and swappable on reload, as the datasets are (datasets.hpp).
//
// Loading a mesh: a dataset's whole DEM is read through the shared block
// cache (refused when it has more than limits.max_cells cells) and made a
// TIN by greedy insertion, or the OBJ/PLY file is read; the TIN is
// prepared (mesh/mesh_model.hpp), through the disk cache when
// mesh_cache_dir is set; the configured boxes are registered. Each step's
// working memory is reserved in the memory budget before the step starts
// (the DEM read whole, kBytesPerDemCell a cell; the preparation's peak,
// mesh::preparation_bytes, once the TIN's size is known), and what the
// model holds is reserved for as long as the mesh is served; a mesh that
// does not fit fails the load, naming it and what did not fit. Progress
// is logged ("mesh_progress", each quarter) and the result too
// ("mesh_prepared": seconds, groups, whether the disk cache answered, bytes).
//
// A MeshSet is immutable once built; a request keeps its snapshot to the
// end. A reload reuses a mesh whose configuration is unchanged and whose
// source is the same: the same dataset object (the dataset registry reuses
// unchanged datasets) or the same file (name, size, modification time).
// Preparing happens before the swap, so a reload that fails leaves the
// running set as it was.
#pragma once

#include <map>
#include <memory>
#include <mutex>
#include <string>

#include "config.hpp"
#include "datasets.hpp"
#include "horizon/common/control.hpp"
#include "horizon/mesh/mesh_model.hpp"
#include "memory_budget.hpp"

namespace horizon::server {

struct ServedMesh {
  MeshConfig config;
  std::string source;                      // "dataset:<name>" or "file:<as configured>"
  std::string signature;                   // a file's size and modification time; empty for a dataset's
  std::shared_ptr<const Dataset> dataset;  // the DEM it was built from (null for a file)
  mesh::MeshModel model;
  Reservation memory;  // model.memory_bytes(), held while the mesh is served
};

using MeshSet = std::map<std::string, std::shared_ptr<const ServedMesh>>;

class MeshRegistry {
 public:
  MeshRegistry(MemoryBudget& memory, terrain::BlockCache* cache, unsigned threads)
      : memory_(memory), cache_(cache), threads_(threads) {}

  // Prepares (or reuses) every mesh of `config` over `datasets`, then swaps
  // the set in. On any error nothing changes and the error names the
  // mesh's config key. `control` may cancel a long preparation.
  Status load(const Config& config, const DatasetSet& datasets, const RunControl* control = nullptr);

  // The current set; empty (not null) before the first load.
  std::shared_ptr<const MeshSet> snapshot() const;

 private:
  Result<std::shared_ptr<const ServedMesh>> prepare(const Config& config, const MeshConfig& entry,
                                                    const DatasetSet& datasets, const RunControl* control);

  MemoryBudget& memory_;
  terrain::BlockCache* cache_;
  unsigned threads_;
  mutable std::mutex mutex_;
  std::shared_ptr<const MeshSet> current_ = std::make_shared<const MeshSet>();
};

}  // namespace horizon::server
