// The per-request viewing geometry.
#include "horizon/visibility/view_frame.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "horizon/common/parallel.hpp"
#include "horizon/geodesy/crs.hpp"

namespace horizon::visibility {

double ViewFrame::farthest_distance2(const terrain::Window& cells) const {
  const double dx0 = (cells.col0 - observer_col) * metres_per_col;
  const double dx1 = (cells.col1 - 1 - observer_col) * metres_per_col;
  const double dy0 = (cells.row0 - observer_row) * metres_per_row;
  const double dy1 = (cells.row1 - 1 - observer_row) * metres_per_row;
  return std::max(dx0 * dx0, dx1 * dx1) + std::max(dy0 * dy0, dy1 * dy1);
}

bool ViewFrame::in_range(int col, int row) const {
  if (!std::isfinite(max_distance)) return true;
  const double dx = (col - observer_col) * metres_per_col;
  const double dy = (row - observer_row) * metres_per_row;
  return dx * dx + dy * dy <= max_distance * max_distance;
}

void reset_output(terrain::Grid<float>& ohf, const terrain::Window& window, unsigned threads) {
  size_output(ohf, window);
  // Row bands of at least 64 K cells each, filled in parallel.
  const std::size_t rows = static_cast<std::size_t>(ohf.height()), width = static_cast<std::size_t>(ohf.width());
  const std::size_t band = std::max<std::size_t>(1, (std::size_t{1} << 16) / std::max<std::size_t>(1, width));
  parallel_for((rows + band - 1) / band, threads, [&](std::size_t b) {
    const std::size_t r0 = b * band, r1 = std::min(rows, r0 + band);
    std::fill(ohf.data() + r0 * width, ohf.data() + r1 * width, std::numeric_limits<float>::quiet_NaN());
  });
}

Result<CellSizeMetres> metric_cell_size(const terrain::Georeference& georef, double x, double y,
                                        const std::string& source) {
  const auto& t = georef.transform;
  geodesy::GroundScale scale;  // metres per CRS unit; 1 when the DEM has no CRS
  if (georef.has_crs()) {
    auto crs = geodesy::Crs::of(georef);
    if (!crs.ok()) return crs.error();
    scale = crs->ground_scale({x, y});
  }
  CellSizeMetres m{std::abs(t.pixel_width) * scale.metres_per_x, std::abs(t.pixel_height) * scale.metres_per_y};
  if (!(m.per_col > 0) || !(m.per_row > 0) || !std::isfinite(m.per_col) || !std::isfinite(m.per_row))
    return make_error(ErrorCode::kDataError, "dem '" + source + "': cell size is not a positive finite length", "dem");
  return m;
}

Result<ViewFrame> make_view_frame(const terrain::Dem& dem, const geodesy::GridPoint& observer,
                                  const ViewshedOptions& options) {
  HORIZON_RETURN_IF_ERROR(validate_options(options));
  if (dem.width() < 2 || dem.height() < 2)
    return make_error(ErrorCode::kDataError,
                      "dem '" + dem.source + "': a viewshed needs at least 2x2 cells, the DEM has " +
                          std::to_string(dem.width()) + "x" + std::to_string(dem.height()),
                      "dem");
  if (!std::isfinite(observer.elevation) || !std::isfinite(observer.col) || !std::isfinite(observer.row))
    return make_error(ErrorCode::kInvalidArgument, "observer: position or eye elevation is not a finite number",
                      "observer");

  ViewFrame f;
  f.observer_col = observer.col;
  f.observer_row = observer.row;
  f.eye = observer.elevation;
  f.dem_width = dem.width();
  f.dem_height = dem.height();
  f.curvature = options.curvature_coefficient / (2.0 * geodesy::kEarthRadiusMetres);
  f.max_distance = options.max_distance;

  auto cell = metric_cell_size(dem.georef, observer.x, observer.y, dem.source);
  if (!cell.ok()) return cell.error();
  f.metres_per_col = cell->per_col;
  f.metres_per_row = cell->per_row;

  // Bounding box of the max-distance circle, clipped to the DEM; always holds
  // the cell nearest the observer.
  int c0 = 0, c1 = dem.width(), r0 = 0, r1 = dem.height();
  if (std::isfinite(f.max_distance)) {
    const double reach_c = f.max_distance / f.metres_per_col;
    const double reach_r = f.max_distance / f.metres_per_row;
    c0 = static_cast<int>(std::clamp(std::ceil(f.observer_col - reach_c), 0.0, double(dem.width())));
    c1 = static_cast<int>(std::clamp(std::floor(f.observer_col + reach_c) + 1, 0.0, double(dem.width())));
    r0 = static_cast<int>(std::clamp(std::ceil(f.observer_row - reach_r), 0.0, double(dem.height())));
    r1 = static_cast<int>(std::clamp(std::floor(f.observer_row + reach_r) + 1, 0.0, double(dem.height())));
    const int oc = std::clamp(static_cast<int>(std::lround(f.observer_col)), 0, dem.width() - 1);
    const int orow = std::clamp(static_cast<int>(std::lround(f.observer_row)), 0, dem.height() - 1);
    c0 = std::min(c0, oc);
    c1 = std::max(c1, oc + 1);
    r0 = std::min(r0, orow);
    r1 = std::max(r1, orow + 1);
  }
  f.window = {c0, r0, c1, r1};
  return f;
}

}  // namespace horizon::visibility
