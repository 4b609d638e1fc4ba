// The from-region tests' region: a box over grid cells of a DEM.
#pragma once

#include <algorithm>

#include "horizon/region/region.hpp"
#include "horizon/terrain/dem.hpp"

namespace horizon::testing {

// A region over grid cells [c0, c1] x [r0, r1] of `dem` (its CRS's
// coordinates of those cell centres), heights [z0, z1] in `mode`.
inline region::RegionSpec region_over(const terrain::Dem& dem, double c0, double r0, double c1, double r1, double z0,
                                      double z1, geodesy::HeightMode mode = geodesy::HeightMode::kAbsolute) {
  const auto& t = dem.georef.transform;
  region::RegionSpec s;
  s.x_min = std::min(t.x_at(c0), t.x_at(c1));
  s.x_max = std::max(t.x_at(c0), t.x_at(c1));
  s.y_min = std::min(t.y_at(r0), t.y_at(r1));
  s.y_max = std::max(t.y_at(r0), t.y_at(r1));
  s.z_min = z0;
  s.z_max = z1;
  s.height_mode = mode;
  return s;
}

}  // namespace horizon::testing
