// horizon/mesh/mesh_model.hpp — a TIN ready to cull, with what it came from.
//
// What both the CLI (`horizon mesh`) and the daemon (a configured mesh,
// MeshService) hold between frames: the prepared mesh (prepared_mesh.hpp),
// the frame it was prepared in (local_frame.hpp), and the source that
// places viewpoints and boxes on it.
//
//   * From a DEM: a TIN by greedy insertion (tin_from_dem.hpp) in the
//     DEM's CRS, its fit to the DEM measured, then prepared in the DEM's
//     local metric frame. A viewpoint is any PointSpec the DEM resolves
//     (its CRS or WGS 84; a height above its ground or an altitude), as
//     for every other query of Horizon. The DEM is kept: it places
//     viewpoints, and rasterises an answer on its grid.
//   * From a mesh file (OBJ or PLY, tin_io.hpp): the TIN as it is, x, y
//     and z in metres of the file's own frame (no CRS is read). A
//     viewpoint is (x, y) of that frame with a height above the mesh's
//     surface (kOutOfRange off the mesh) or an altitude; WGS 84 is refused.
//
// Preparation goes through a disk cache when `cache_dir` is set
// (prepared_cache.hpp), keyed by the TIN in its frame and the knobs. Boxes
// may be registered once (mesh_boxes.hpp); they are given in the source's
// CRS (a mesh file's frame) or, over a DEM, in WGS 84, and each box's
// footprint corners are mapped into the frame and bounded there.
//
// A MeshModel is immutable once made (register_boxes aside, which is part
// of making it) and may be read by any number of threads at once.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "horizon/common/control.hpp"
#include "horizon/common/error.hpp"
#include "horizon/geodesy/observer.hpp"
#include "horizon/mesh/local_frame.hpp"
#include "horizon/mesh/mesh_boxes.hpp"
#include "horizon/mesh/prepared_cache.hpp"
#include "horizon/mesh/prepared_mesh.hpp"
#include "horizon/mesh/tin_from_dem.hpp"
#include "horizon/terrain/dem.hpp"
#include "horizon/visibility/cull.hpp"

namespace horizon::mesh {

struct MeshModelOptions {
  GreedyOptions greedy;  // DEM input only
  PrepareOptions prepare;
  std::string cache_dir;  // "" = prepare without a disk cache
  // Called with the TIN (in its frame) once it is built or read, before the
  // preparation starts; an error it returns stops there. A server reserves
  // preparation_bytes() here.
  std::function<Status(const Tin&)> before_prepare;
};

// An upper bound on the memory a preparation of `vertices` vertices with
// `options` on `threads` threads (0: every core) holds at its peak, beside
// its input: the horizons' answer and slopes (8·s bytes a vertex), each
// thread's sorts, leaf arrays and hull buffer (about 270 bytes a vertex at
// k = 4), the groups' regions and walls (up to the group cap), and when
// built from a DEM the Delaunay triangulation of the greedy insertion.
// Measured peaks (`horizon mesh prepare` under /usr/bin/time, 2 threads,
// 16/4: 100 000 vertices 70 MB beside the process with the thesis's 1 000
// groups, a million 667 MB with 10 000) stay under it (108 MB, 1 080 MB).
std::uint64_t preparation_bytes(std::uint64_t vertices, const PrepareOptions& options, unsigned threads);

// A viewpoint placed on a model.
struct MeshEye {
  TinVertex local;      // in the prepared mesh's frame: what cull() takes
  TinVertex crs;        // in the source's CRS (a mesh file's frame), z absolute metres
  double ground = 0.0;  // the surface under it (the DEM's ground, or the mesh's); NaN when unknown
};

class MeshModel {
 public:
  // The TIN of `dem` (greedy insertion), prepared. Errors from the
  // insertion, the frame (a CRS PROJ cannot read), the preparation
  // (options, cancellation) pass through.
  static Result<MeshModel> from_dem(terrain::Dem dem, const MeshModelOptions& options,
                                    const RunControl* control = nullptr);
  // The TIN in an OBJ or PLY file, prepared.
  static Result<MeshModel> from_file(const std::string& path, const MeshModelOptions& options,
                                     const RunControl* control = nullptr);

  MeshModel(MeshModel&&) noexcept;
  MeshModel& operator=(MeshModel&&) noexcept;
  ~MeshModel();

  const PreparedMesh& prepared() const;
  // The TIN's vertices in the source's CRS, indexed as prepared().tin's.
  const std::vector<TinVertex>& crs_vertices() const;
  const LocalFrame& frame() const;
  // The DEM it was built from; null for a mesh file.
  const terrain::Dem* dem() const;
  // The TIN's fit to its DEM; nullopt for a mesh file.
  const std::optional<TinFit>& fit() const;
  const CacheUse& cache_use() const;
  // Wall time of the preparation (or of the cache load), seconds.
  double prepare_seconds() const;

  // Places a viewpoint. A DEM's: geodesy::resolve_point's rules and
  // errors (`what` names it). A mesh file's: spec.x, spec.y in its frame;
  // kInvalidArgument for WGS 84, kOutOfRange for a height above ground
  // off the mesh.
  Result<MeshEye> eye(const geodesy::PointSpec& spec, const char* what = "observer") const;

  // Registers boxes given in the source's CRS (a mesh file's frame), or in
  // WGS 84 over a DEM (converted as every query converts them, and wholly
  // on the DEM), replacing any registered before; kInvalidArgument naming
  // the first bad box (by index), or a WGS 84 box over a mesh file.
  Status register_boxes(std::span<const visibility::BoxSpec> boxes, unsigned threads = 0);
  // Null until register_boxes.
  const RegisteredBoxes* boxes() const;

  // The bytes the model holds (its vectors' capacities, the DEM's cells,
  // the surface index and the registered boxes): what a server accounts
  // for a resident model.
  std::uint64_t memory_bytes() const;

 private:
  struct Parts;
  explicit MeshModel(std::unique_ptr<Parts> parts);
  std::unique_ptr<Parts> p_;  // behind a pointer: the surface index refers to the TIN, which must not move
};

// The bytes a prepared mesh holds (its vectors' capacities).
std::uint64_t memory_bytes(const PreparedMesh& mesh);

}  // namespace horizon::mesh
