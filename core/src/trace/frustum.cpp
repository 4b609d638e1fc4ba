// Sub-frusta and per-column ray constants (frustum.hpp).
#include "frustum.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>

#include "horizon/geodesy/crs.hpp"

namespace horizon::trace::detail {
namespace {

constexpr double kQuarter = std::numbers::pi / 2.0;

// The quadrant of an azimuth (radians, any value) and its angle off the
// quadrant's axis. The quadrant is chosen in grid terms: the family of
// lines the ray crosses more often per metre (on cells wider than tall,
// row lines win over a wider fan), so that a crossing moves at most one
// cell along its line from the last; phi is the metric angle, within 45
// degrees on square cells.
void quadrant_of(double azimuth, double per_col, double per_row, int& quadrant, double& phi) {
  const double grid = std::atan2(std::sin(azimuth) / per_col, std::cos(azimuth) / per_row);
  const double turns = std::floor((grid + kQuarter / 2.0) / kQuarter);
  quadrant = static_cast<int>(turns - 4.0 * std::floor(turns / 4.0));
  phi = std::remainder(azimuth - quadrant * kQuarter, 2.0 * std::numbers::pi);
}

// The lines of one family ahead of `eye` (its coordinate across the lines) in
// direction `step`, spaced `spacing` metres, `lines` of them in the view,
// up to ground distance `far`.
LineFamily family_ahead(LineAxis axis, double eye_across, double eye_along, int step, double spacing, double far,
                        const terrain::HeightView& view) {
  LineFamily f;
  f.axis = axis;
  f.step = step;
  const bool rows = axis == LineAxis::kRows;
  const int lines = rows ? view.height() : view.width();
  f.pos_count = rows ? view.width() : view.height();
  f.line_stride = rows ? view.stride() : 1;
  f.pos_stride = rows ? 1 : view.stride();
  f.eye_along = static_cast<float>(eye_along);
  double t0 = 0.0;
  if (step > 0) {
    f.first = static_cast<int>(std::floor(eye_across)) + 1;
    t0 = f.first - eye_across;
    f.count = std::max(0, lines - std::max(f.first, 0));
    if (f.first < 0) {  // the eye before the view: start at line 0
      t0 += -f.first;
      f.first = 0;
    }
  } else {
    f.first = static_cast<int>(std::ceil(eye_across)) - 1;
    t0 = eye_across - f.first;
    f.count = std::max(0, std::min(f.first, lines - 1) + 1);
    if (f.first > lines - 1) {
      t0 += f.first - (lines - 1);
      f.first = lines - 1;
    }
  }
  f.t0 = static_cast<float>(t0);
  if (std::isfinite(far)) {
    const double reach = std::floor(far / spacing - t0) + 1.0;
    f.count = static_cast<int>(std::clamp(reach, 0.0, static_cast<double>(f.count)));
  }
  return f;
}

}  // namespace

FrameGeometry make_frame_geometry(const Camera& camera, const terrain::HeightView& view, const TraceOptions& options) {
  FrameGeometry g;
  const int width = camera.spec.width;
  const auto n = static_cast<std::size_t>(width);
  g.eye_z = static_cast<float>(camera.eye.elevation);
  g.curvature = static_cast<float>(options.curvature_coefficient / (2.0 * geodesy::kEarthRadiusMetres));
  g.fill = options.nodata == visibility::NodataPolicy::kFill ? static_cast<float>(options.nodata_fill_height)
                                                             : terrain::HeightView::kTransparent;
  g.far = static_cast<float>(options.max_distance);
  g.cy = static_cast<float>(camera.cy);
  g.height = camera.spec.height;
  g.view_width = view.width();
  g.view_height = view.height();
  g.pos_per_t.resize(n);
  g.dist_per_t.resize(n);
  g.pos_per_t2.resize(n);
  g.dist_per_t2.resize(n);
  g.side.resize(n);
  g.near.resize(n);
  g.inv_focal_col.resize(n);

  const double mc = camera.metres_per_col, mr = camera.metres_per_row;
  const double eye_col = camera.eye.col, eye_row = camera.eye.row;
  for (int x = 0; x < width; ++x) {
    int quadrant = 0;
    double phi = 0.0;
    quadrant_of(camera.azimuth[static_cast<std::size_t>(x)], camera.metres_per_col, camera.metres_per_row, quadrant,
                phi);
    if (g.runs.empty() || g.runs.back().quadrant != quadrant) {
      Run run;
      run.x0 = x;
      run.quadrant = quadrant;
      const bool rows = quadrant % 2 == 0;
      // Quadrants 0 (north) and 3 (west) walk towards lower indices.
      const int step = quadrant == 0 || quadrant == 3 ? -1 : 1;
      const int along_sign = quadrant == 0 || quadrant == 1 ? 1 : -1;
      const double across = rows ? eye_row : eye_col, along = rows ? eye_col : eye_row;
      const double spacing = rows ? mr : mc, along_cell = rows ? mc : mr;
      const LineAxis axis = rows ? LineAxis::kRows : LineAxis::kColumns;
      const LineAxis other = rows ? LineAxis::kColumns : LineAxis::kRows;
      run.primary = family_ahead(axis, across, along, step, spacing, options.max_distance, view);
      // The other family, towards phi < 0 and phi > 0: its lines lie across
      // the primary family's "along" axis, and along them lies `across`.
      run.secondary[0] = family_ahead(other, along, across, -along_sign, along_cell, options.max_distance, view);
      run.secondary[1] = family_ahead(other, along, across, along_sign, along_cell, options.max_distance, view);
      g.runs.push_back(run);
    }
    Run& run = g.runs.back();
    run.x1 = x + 1;
    const bool rows = quadrant % 2 == 0;
    const int along_sign = quadrant == 0 || quadrant == 1 ? 1 : -1;
    const double spacing = rows ? mr : mc, along_cell = rows ? mc : mr;
    const auto i = static_cast<std::size_t>(x);
    g.pos_per_t[i] = static_cast<float>(along_sign * std::tan(phi) * spacing / along_cell);
    g.dist_per_t[i] = static_cast<float>(spacing / std::cos(phi));
    g.side[i] = phi > 0.0 ? 1 : 0;
    if (phi == 0.0) {
      g.pos_per_t2[i] = 0.0f;
      g.dist_per_t2[i] = std::numeric_limits<float>::infinity();
    } else {
      // Secondary crossing t2 (in along cells) lies along_cell * t2 / |tan phi|
      // metres ahead, i.e. that / spacing primary lines, in the primary step.
      g.pos_per_t2[i] = static_cast<float>(run.primary.step * along_cell / (std::abs(std::tan(phi)) * spacing));
      g.dist_per_t2[i] = static_cast<float>(along_cell / std::abs(std::sin(phi)));
    }
    g.near[i] = static_cast<float>(camera.near_distance(x, options.near));
    g.inv_focal_col[i] = static_cast<float>(1.0 / camera.focal_col[i]);
  }
  return g;
}

}  // namespace horizon::trace::detail
