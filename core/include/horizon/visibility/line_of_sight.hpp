// horizon/visibility/line_of_sight.hpp — one sight line, explained.
//
// Uses the R3 definition (see r3.hpp): the segment from `from` to `to` is
// tested at every grid row and column crossing strictly between them. The
// answer carries the first crossing where terrain rises above the sight line
// (if any) and the full terrain profile at the crossings, so a client can plot
// it.
#pragma once

#include <optional>
#include <vector>

#include "horizon/common/error.hpp"
#include "horizon/geodesy/observer.hpp"
#include "horizon/terrain/dem.hpp"

namespace horizon::visibility {

struct LosOptions {
  double curvature_coefficient = 0.85714;  // as ViewshedOptions
};

struct ProfileSample {
  double distance = 0.0;   // ground metres from `from`
  double col = 0.0, row = 0.0;
  double x = 0.0, y = 0.0; // dataset CRS
  double terrain = 0.0;    // metres, curvature-lowered as seen from `from`; NaN on a void
  double sight_line = 0.0; // height of the straight sight line there, metres
};

struct LosResult {
  bool visible = true;
  double distance = 0.0;                        // ground metres from -> to
  double clearance = 0.0;                       // min(sight_line - terrain) over the profile; +inf if empty
  std::optional<ProfileSample> first_block;     // first crossing with terrain above the sight line
  std::vector<ProfileSample> profile;           // every crossing, ordered by distance
};

Result<LosResult> line_of_sight(const terrain::Dem& dem, const geodesy::GridPoint& from,
                                const geodesy::GridPoint& to, const LosOptions& options = {});

}  // namespace horizon::visibility
