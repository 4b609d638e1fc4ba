// horizon/visibility/many_observers.hpp — viewsheds from many observers at
// once, accumulated: how many observers see each cell (GDAL's ACCUM), seen
// from any or from all of them, and each observer's own summary.
//
//   std::vector<visibility::ObserverSite> towers = ...;  // points, heights, reaches
//   auto plan = visibility::plan_many_observers(dem, towers, {.viewshed = {.target_height = 2}});
//   // check plan->bytes and plan->work_cells against the caller's limits
//   auto many = visibility::compute_many_observers(dem, *plan);
//   auto any = visibility::seen_from_any(*many);   // 1 / 0 / 255
//
// Each observer's viewshed is the single-observer engine's (compute_viewshed
// with the shared options and the site's own max_distance), so the count at
// a cell is exactly the number of observers whose visibility_mask says 1
// there: an observer's cells beyond its reach, or on voids, count as not
// seen by it. Cells no observer answers (beyond every reach, void) are the
// no-answer code of every raster.
//
// Shared work and memory. The DEM is decoded once and read by every
// observer; observers run in parallel, one thread each (a viewshed's own
// threads stay 1), each thread keeping its OHF and terrain buffers from one
// observer to the next. The answer is accumulated as each observer finishes
// (a relaxed atomic add per visible cell), so memory is the window's rasters
// (5 bytes a cell) plus one viewshed's buffers per thread, whatever the
// number of observers. Progress moves one observer at a time.
//
// Cost, known from the plan before any work: `work_cells`, the sum of the
// observers' window cells (the time), and `bytes` (the memory).
#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include "horizon/common/control.hpp"
#include "horizon/common/error.hpp"
#include "horizon/geodesy/observer.hpp"
#include "horizon/terrain/dem.hpp"
#include "horizon/terrain/grid.hpp"
#include "horizon/visibility/options.hpp"
#include "horizon/visibility/view_frame.hpp"

namespace horizon::visibility {

struct ObserverSite {
  geodesy::PointSpec point;   // position and eye height (above ground or absolute)
  double max_distance = 0.0;  // ground metres, > 0; 0: the options' max_distance
};

struct ManyObserversOptions {
  // Shared by every observer: algorithm, target height, curvature, nodata,
  // and the max_distance of sites that give none. threads and backend are
  // ignored (one CPU thread per observer).
  ViewshedOptions viewshed;
  unsigned threads = 0;  // observers run at once; 0: all hardware threads
};

struct ManyObserversPlan {
  std::vector<ObserverSite> sites;
  std::vector<geodesy::GridPoint> points;  // each site resolved on the DEM
  std::vector<ViewFrame> frames;           // each site's geometry and window
  ManyObserversOptions options;
  terrain::Window window;        // the union of the observers' windows
  std::uint64_t cells = 0;       // window.cell_count()
  std::uint64_t work_cells = 0;  // sum of the observers' window cells
  std::uint64_t bytes = 0;       // held by the run, bound
  unsigned threads = 1;          // resolved
};

// Checks the options and resolves every site: errors name the site,
// "observers[3]" (off the DEM: kOutOfRange; on a void with a height above
// ground: kFailedPrecondition), "observers[3].max_distance" (negative or
// not finite); no sites: kInvalidArgument "observers".
Result<ManyObserversPlan> plan_many_observers(const terrain::Dem& dem, std::span<const ObserverSite> sites,
                                              const ManyObserversOptions& options);

struct ObserverSummary {
  std::uint64_t cells_answered = 0;  // cells of its window with an answer (in reach, not void)
  std::uint64_t cells_visible = 0;   // of those, the cells it sees
  double seconds = 0.0;              // its viewshed's wall time
};

struct ManyObserversResult {
  terrain::Window window;                  // in the DEM's grid; the rasters are window-sized
  terrain::Grid<std::uint32_t> count;      // observers that see each cell
  terrain::Grid<std::uint8_t> answered;    // 1 where some observer has an answer, else 0
  std::vector<ObserverSummary> observers;  // in site order
  std::uint64_t observer_count = 0;
  double seconds = 0.0;
};

Result<ManyObserversResult> compute_many_observers(const terrain::Dem& dem, const ManyObserversPlan& plan,
                                                   const RunControl* control = nullptr);

// No-answer codes of the rasters below.
inline constexpr std::uint32_t kNoCount = 0xFFFFFFFFu;

// The count, kNoCount where no observer answers.
terrain::Grid<std::uint32_t> observer_count(const ManyObserversResult& result);
// 1 seen by at least one observer / 0 by none / 255 no answer.
terrain::Grid<std::uint8_t> seen_from_any(const ManyObserversResult& result);
// 1 seen by every observer / 0 not / 255 no answer.
terrain::Grid<std::uint8_t> seen_from_all(const ManyObserversResult& result);

}  // namespace horizon::visibility
