// horizon/visibility/view_frame.hpp — the geometry shared by every viewshed
// algorithm, computed once per request.
//
// All algorithms work in continuous grid coordinates (cell centres at
// integers) relative to the observer, with ground distances in metres:
//   d(col, row) = sqrt(dx^2 + dy^2), dx = (col - observer_col) * metres_per_col,
//                                    dy = (row - observer_row) * metres_per_row
// The metric cell sizes are taken at the observer (for geographic DEMs they
// differ east-west and north-south; across a 1-degree tile the east-west size
// varies by ~1 %, which is far inside the distances where curvature matters).
// Curvature and refraction lower a point at distance d by curvature * d^2.
#pragma once
#include <cmath>
#include <string>

#include "horizon/common/error.hpp"
#include "horizon/geodesy/observer.hpp"
#include "horizon/terrain/dem.hpp"
#include "horizon/visibility/options.hpp"

namespace horizon::visibility {

struct ViewFrame {
  double observer_col = 0.0, observer_row = 0.0;  // grid coordinates of the eye
  double eye = 0.0;                               // absolute eye elevation, metres
  double metres_per_col = 1.0, metres_per_row = 1.0;
  double curvature = 0.0;     // metres of drop per metre^2 of distance: coefficient / (2 R)
  double max_distance = 0.0;  // metres (may be +infinity)
  terrain::Window window;     // cells within max_distance, clipped to the DEM
  int dem_width = 0, dem_height = 0;

  // Ground distance in metres from the eye to the centre of cell (col, row).
  // Every algorithm (R3 included) takes its distances here, so they agree to
  // the bit. A plain square root: ground distances on one DEM are far from
  // the range where squaring overflows or underflows, which std::hypot
  // guards against at several times the cost (a fifth of the exact
  // visibility-only search's time was spent in it).
  double distance(double col, double row) const {
    const double dx = (col - observer_col) * metres_per_col, dy = (row - observer_row) * metres_per_row;
    return std::sqrt(dx * dx + dy * dy);
  }
  // True when cell (col, row)'s centre lies within max_distance.
  bool in_range(int col, int row) const;
  // Squared ground distance in metres from the eye to the farthest cell
  // centre of the non-empty window `cells`: one of its corner centres.
  double farthest_distance2(const terrain::Window& cells) const;
};

// Sizes `out` (an OHF, a mask) to `window`, reusing its storage when it is
// large enough (no new pages); its contents are then unspecified.
template <class T>
void size_output(terrain::Grid<T>& out, const terrain::Window& window) {
  if (out.width() == window.width() && out.height() == window.height()) return;
  if (out.capacity() >= window.cell_count())
    out.reshape(window.width(), window.height());  // the storage kept: no new pages
  else
    out = terrain::Grid<T>(window.width(), window.height(), terrain::kUninitialized);
}

// Sizes `ohf` to the frame's window and fills it with NaN ("no answer") on
// `threads` threads (0: one per core), reusing its storage when it is large
// enough: a caller computing many viewsheds (a daemon, a benchmark) then
// pays no page faults.
void reset_output(terrain::Grid<float>& ohf, const terrain::Window& window, unsigned threads = 1);

// Ground metres per column and per row at CRS point (x, y): the cell size
// times the CRS's point scale there (1 m per unit without a CRS). kDataError
// naming `source` when not a positive finite length.
struct CellSizeMetres {
  double per_col = 1.0, per_row = 1.0;
};
Result<CellSizeMetres> metric_cell_size(const terrain::Georeference& georef, double x, double y,
                                        const std::string& source);

// Builds the frame for an observer already resolved against `dem`.
Result<ViewFrame> make_view_frame(const terrain::Dem& dem, const geodesy::GridPoint& observer,
                                  const ViewshedOptions& options);

}  // namespace horizon::visibility
