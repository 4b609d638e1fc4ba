// One explained sight line, by R3's crossing rule (see r3.hpp and crossings.hpp).
#include "horizon/visibility/line_of_sight.hpp"
#include "horizon/visibility/viewshed.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

#include "crossings.hpp"
#include "horizon/visibility/view_frame.hpp"

namespace horizon::visibility {

Result<LosResult> line_of_sight(const terrain::Dem& dem, const geodesy::GridPoint& from,
                                const geodesy::GridPoint& to, const LosOptions& options) {
  if (!std::isfinite(options.curvature_coefficient) || options.curvature_coefficient < 0 ||
      options.curvature_coefficient > 2)
    return make_error(ErrorCode::kInvalidArgument, "curvature_coefficient: must be a finite number in [0, 2]",
                      "curvature_coefficient");
  if (!std::isfinite(from.elevation)) return make_error(ErrorCode::kInvalidArgument, "from: elevation is not finite", "from");
  if (!std::isfinite(to.elevation)) return make_error(ErrorCode::kInvalidArgument, "to: elevation is not finite", "to");

  // Same frame as a viewshed from `from` (metric cell sizes at `from`).
  ViewshedOptions frame_options;
  frame_options.curvature_coefficient = options.curvature_coefficient;
  auto frame = make_view_frame(dem, from, frame_options);
  if (!frame.ok()) return frame.error();
  const ViewFrame& f = *frame;

  LosResult out;
  out.distance = f.distance(to.col, to.row);
  out.clearance = std::numeric_limits<double>::infinity();
  const double target = to.elevation - f.curvature * out.distance * out.distance;
  const auto& gt = dem.georef.transform;

  detail::for_each_crossing(dem.elevation, from.col, from.row, to.col, to.row,
                            [&](double t, double col, double row, double terrain) {
                              ProfileSample s;
                              s.distance = t * out.distance;
                              s.col = col;
                              s.row = row;
                              s.x = gt.x_at(col);
                              s.y = gt.y_at(row);
                              s.terrain = terrain - f.curvature * s.distance * s.distance;
                              s.sight_line = f.eye + (target - f.eye) * t;
                              out.profile.push_back(s);
                            });
  std::sort(out.profile.begin(), out.profile.end(),
            [](const ProfileSample& a, const ProfileSample& b) { return a.distance < b.distance; });
  for (const ProfileSample& s : out.profile) {
    if (std::isnan(s.terrain)) continue;  // voids never block
    out.clearance = std::min(out.clearance, s.sight_line - s.terrain);
    // Blocking is judged for the target raised by kTieTolerance, as the
    // viewshed does (viewshed.hpp), so an exact graze never decides.
    const double lift = out.distance > 0 ? kTieTolerance * s.distance / out.distance : 0.0;
    if (s.terrain > s.sight_line + lift && !out.first_block) out.first_block = s;
  }
  out.visible = !out.first_block.has_value();
  return out;
}

}  // namespace horizon::visibility
