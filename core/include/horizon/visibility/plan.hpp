// horizon/visibility/plan.hpp — a query validated once into a plan, then run.
//
//   auto source = terrain::ElevationSource::open("dem.tif");
//   auto plan = visibility::plan_viewshed(**source, {.observer = spec, .options = options});
//   if (plan->cost.bytes > budget) ...                         // refuse before any work
//   auto run = visibility::run_viewshed(*plan, **source, &cache, &control, gpu);
//
// Planning reads no pixel: from the source's header alone it checks every
// option, places the observer (or the boxes, or the sight line's ends) in the
// source's grid, and finds the cells the query needs: the max-distance
// window (the boxes' reach, the line's bounding box) plus a 2-cell margin,
// clipped to the source. The plan names those cells, the source blocks under
// them, and the cost, so a caller (the daemon's admission, the CLI) decides
// before anything is read or allocated.
//
// Running reads exactly the planned cells (through the block cache when one
// is given), puts the observer on the ground there, and runs the engine on
// that window as on a whole DEM. Shifting a located point by the window's
// integer corner is exact in floating point and every algorithm works
// relative to the eye, so a run gives bit-identical answers to the same
// query on the whole raster, and a mosaic's answers equal those of the
// merged file (tests/visibility/test_plan.cpp holds both).
//
// Frames. Plans and runs say where things are in the *source's* grid
// (ViewshedRun::window, CullRun boxes); the engine structs inside a run
// (ViewshedResult::frame, the run's dem) are in the read window's grid.
#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include "horizon/common/control.hpp"
#include "horizon/common/error.hpp"
#include "horizon/geodesy/observer.hpp"
#include "horizon/gpu/context_pool.hpp"
#include "horizon/terrain/block_cache.hpp"
#include "horizon/terrain/source.hpp"
#include "horizon/visibility/cull.hpp"
#include "horizon/visibility/line_of_sight.hpp"
#include "horizon/visibility/viewshed.hpp"

namespace horizon::visibility {

// What a plan will cost, known before it runs.
struct Cost {
  std::uint64_t cells = 0;        // cells the algorithm answers (the output window)
  std::uint64_t read_cells = 0;   // source cells read (the window and its margin)
  std::uint64_t blocks = 0;       // source blocks under them
  std::uint64_t block_bytes = 0;  // their decoded size (what a cold cache decodes)
  // Engine working memory: the cells read, the OHF and the terrain crop, the
  // algorithm's own tables (the sweep's rays; exact: pyramid and ring
  // bounds; cull: the min-pyramid), per box and per profile sample. Not the
  // caller's encodings.
  std::uint64_t bytes = 0;
  // The radial sweep's rays (fast, conservative, and exact's lower bound):
  // about 8 x reach / ray_spacing, each with a table entry, each marching
  // through up to `reach` lines. A tiny ray_spacing makes them the cost.
  std::uint64_t sweep_rays = 0;
  std::uint64_t sweep_bytes = 0;  // their share of `bytes`
  // Rough compute time on one core, seconds (from the measured cost per cell
  // of each algorithm on the 12 M-cell benchmark; within a factor of ~3).
  double seconds = 0.0;
};

// The cells a query reads and what is under them.
struct ReadPlan {
  terrain::Window read;               // source cells
  std::vector<std::uint64_t> blocks;  // ElevationSource::blocks_in(read)
};

// Buffers a caller keeps between runs (one per thread: a daemon worker, a
// benchmark loop), so that a run writes into memory already mapped rather
// than taking a page fault per 4 KiB of a fresh allocation, which on a VM
// costs more than assembling the window itself. Runs without one allocate.
//
// A run reads its cells into `cells`; its OHF and terrain rasters take over
// `ohf` and `terrain`. A culling run hands those two back itself; a viewshed
// run's result holds them until the caller, done with it, recycle()s it. A
// run over its whole read window takes `cells` over as its terrain; its
// recycle() then makes the terrain buffer it displaces the next `cells`, so
// the two alternate. A kept buffer is backed by huge pages
// (back_with_huge_pages, common/large_allocator.hpp): the next runs' sweeps
// read it across rows without missing the TLB; the first keep of a buffer
// pays the kernel's collapse once (13-18 ms for 48 MB here, up to ~140 ms on
// a VM that had handed the memory back to its host).
// The fast sweep copies its east and west sectors' lines (their part of
// the window transposed, radial_ohf's column_buffer) into the terrain raster before
// the run fills it, or into the OHF raster of a mask_only run, so that copy
// takes no new pages either.
// The sweep's per-task scratch needs no workspace: it is kept by each thread
// of the engine's executor (common/parallel.hpp), which lives as long as the
// process. The pyramids are the exception: built per run, they are small
// (culling's min-pyramid builds only the blocks under the boxes, exact's
// max-pyramid stores 1/63 of its window).
struct Workspace {
  terrain::Grid<float> cells;        // the last run's read window
  terrain::Grid<float> ohf;          // a finished run's OHF raster
  terrain::Grid<float> terrain;      // a finished run's terrain raster
  terrain::Grid<std::uint8_t> mask;  // a finished mask_only run's mask
  // A workspace keeps at most this much per buffer between runs (a larger
  // buffer is freed when its run ends): 64 MiB, a 16 M-cell window.
  static constexpr std::uint64_t kMaxKeptBytes = 64ull << 20;

  // Takes back a finished viewshed's rasters for the next run to fill.
  void recycle(ViewshedResult&& done);
  // Frees any buffer above kMaxKeptBytes.
  void trim();
  // The bytes its buffers hold (their capacities), what a daemon's memory
  // budget counts for a worker between calls.
  std::uint64_t kept_bytes() const;
};

// The most rays one sector of the radial sweep may march (its tables are
// indexed by int, and 2^28 rays are already 3 GiB of tables).
inline constexpr std::uint64_t kMaxSweepRays = std::uint64_t{1} << 28;

// Adds to `cost` the radial sweep's rays over `output` at options'
// ray_spacing (their tables' bytes and their steps' time), or
// kResourceExhausted naming ray_spacing when a sector would need more than
// kMaxSweepRays. Every plan that runs the sweep calls it.
Status add_sweep_cost(const ViewshedOptions& options, const terrain::Window& output, Cost& cost);

// ---- viewsheds ----------------------------------------------------------

struct ViewshedQuery {
  geodesy::PointSpec observer;
  ViewshedOptions options;
};

struct ViewshedPlan {
  ViewshedQuery query;
  geodesy::GridPoint observer;  // located in the source's grid (ground and elevation not yet known)
  terrain::Window output;       // the cells the OHF will cover, in the source's grid
  ReadPlan read;
  Cost cost;
};

// Errors: the options' (validate_options: field named), the observer's
// (locate_point: "observer.lon", kOutOfRange outside the source), and
// kResourceExhausted naming "ray_spacing" when the sweep would need more than
// kMaxSweepRays rays a sector.
Result<ViewshedPlan> plan_viewshed(const terrain::ElevationSource& source, const ViewshedQuery& query);

struct ViewshedRun {
  terrain::Dem dem;             // the cells read (elevations released after the run: result.terrain holds the crop)
  geodesy::GridPoint observer;  // on the ground, in dem's grid
  ViewshedResult result;        // frame in dem's grid; stats.dem_cells = the source's cells
  terrain::Window window;       // result.frame.window in the source's grid
  // The output rasters' georeference: the source's transform shifted once to
  // `window`'s corner (shifting the read window's origin again would round
  // differently in the last bit).
  terrain::Georeference georef;
  terrain::SourceReadStats read;
  // observer in the source's grid.
  geodesy::GridPoint observer_in_source() const;
};

// Reads the planned cells (`cache` may be null: read the files directly),
// places the observer (kDataError on a void under an above-ground eye) and
// computes. NodataPolicy::kFill is applied as the kernels read the cells
// (elevation_view). `gpu` and `policy` as compute_viewshed.
Result<ViewshedRun> run_viewshed(const ViewshedPlan& plan, const terrain::ElevationSource& source,
                                 terrain::BlockCache* cache, const RunControl* control = nullptr,
                                 gpu::ContextPool* gpu = nullptr, const BackendPolicy* policy = nullptr,
                                 Workspace* workspace = nullptr);

// ---- culling ------------------------------------------------------------

struct CullQuery {
  geodesy::PointSpec observer;
  std::vector<BoxSpec> boxes;
  CullOptions options;
};

struct CullBoxesPlan {
  CullQuery query;
  geodesy::GridPoint observer;           // located in the source's grid
  std::vector<BoxFootprint> footprints;  // in the source's grid
  ViewshedOptions viewshed;              // algorithm chosen, max_distance = the boxes' reach
  ReadPlan read;
  Cost cost;
};

// The bytes each box holds from its conversion to the end of its run: its
// spec, its footprint and its answer (part of a CullBoxesPlan's cost). A
// caller can hold `boxes * kCullBytesPerBox` before it converts a request's
// boxes, so that the conversion and the plan are paid for before they run.
inline constexpr std::uint64_t kCullBytesPerBox = sizeof(BoxSpec) + sizeof(BoxFootprint) + sizeof(BoxVisibility);

// Errors as plan_cull (boxes named by index) and plan_viewshed (observer).
Result<CullBoxesPlan> plan_cull_boxes(const terrain::ElevationSource& source, CullQuery query);

struct CullBoxesRun {
  CullResult result;            // result.window in the source's grid
  geodesy::GridPoint observer;  // on the ground, in the source's grid
  terrain::SourceReadStats read;
};

Result<CullBoxesRun> run_cull_boxes(const CullBoxesPlan& plan, const terrain::ElevationSource& source,
                                    terrain::BlockCache* cache, const RunControl* control = nullptr,
                                    gpu::ContextPool* gpu = nullptr, const BackendPolicy* policy = nullptr,
                                    Workspace* workspace = nullptr);

// ---- one sight line -----------------------------------------------------

struct LineQuery {
  geodesy::PointSpec from, to;
  LosOptions options;
};

struct LinePlan {
  LineQuery query;
  geodesy::GridPoint from, to;  // located in the source's grid
  ReadPlan read;                // the line's bounding box and margin
  Cost cost;
};

Result<LinePlan> plan_line(const terrain::ElevationSource& source, const LineQuery& query);

struct LineRun {
  LosResult result;             // profile positions in the source's grid
  geodesy::GridPoint from, to;  // on the ground, in the source's grid
  terrain::SourceReadStats read;
};

Result<LineRun> run_line(const LinePlan& plan, const terrain::ElevationSource& source, terrain::BlockCache* cache,
                         const RunControl* control = nullptr);

}  // namespace horizon::visibility
