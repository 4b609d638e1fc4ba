// horizon/terrain/preview.hpp — PNG previews a person can look at.
//
// A grey hillshade of the DEM (sun from the north-west, 45 degrees up, slopes
// from true metric cell sizes) with the viewshed tinted over it: visible cells
// green, hidden cells darkened red, undetermined cells (code 2, from-region
// answers) amber, no-data/out-of-range cells left grey, and
// the observer marked with a yellow ring and dot. Written through OpenImageIO,
// atomically (temporary name + rename). Previews larger than `max_size` pixels
// on their longer side are box-downsampled.
#pragma once

#include <cstdint>
#include <optional>
#include <string>

#include "horizon/common/error.hpp"
#include "horizon/terrain/grid.hpp"

namespace horizon::terrain {

struct PreviewOptions {
  double metres_per_col = 1.0;  // ground size of a cell, for the hillshade
  double metres_per_row = 1.0;
  std::optional<double> observer_col;  // in the grids' own coordinates (cell centres at integers)
  std::optional<double> observer_row;
  int max_size = 2048;
};

// elevation and visibility must have the same size. visibility: 1 visible,
// 0 hidden, 2 undetermined, anything else = not computed. Pass an empty visibility grid for a
// plain hillshade.
Status write_viewshed_preview(const std::string& path, const Grid<float>& elevation,
                              const Grid<std::uint8_t>& visibility, const PreviewOptions& options);

}  // namespace horizon::terrain
