// viewshed_raster.hpp — the raster one observer's `horizon viewshed` writes,
// read from its flags: --output (gdal_viewshed's -om), the visible raster's
// value codes (-vv -iv -ov) and the value of cells without an answer
// (-a_nodata). Many observers write their --accumulate raster instead and
// refuse these flags.
//
//   visible               uint8 codes: visible, hidden, out of range (beyond
//                         reach or outside the field of view), no data (a
//                         void); 1 / 0 / 255 / 255 unless -vv -iv -ov -a_nodata
//   boolean               uint8, r.viewshed -b: 1 visible, 0 hidden or out of
//                         range, 255 (or -a_nodata) on voids
//   ohf, min-target-height, vertical-angle (r.viewshed's default),
//   elevation-difference (r.viewshed -e)
//                         float32; no answer is -a_nodata when given, else
//                         the DEM's nodata, else NaN
// gdal_viewshed's -om NORMAL, DEM and GROUND are visible, ohf and
// min-target-height.
#pragma once

#include <optional>
#include <string>

#include "args.hpp"
#include "horizon/visibility/viewshed_outputs.hpp"

namespace horizon::cli {

struct RasterFlags {
  visibility::ViewshedOutput output = visibility::ViewshedOutput::kVisibility;
  std::string name = "visible";  // output_name(output), whichever spelling was typed
  // The uint8 rasters' codes (boolean: r.viewshed's, with -a_nodata as its
  // nodata); codes.nodata is their file's nodata.
  visibility::ValueCodes codes;
  // -a_nodata as given (a code, or a float32 value or NaN): the daemon
  // applies it as this command does.
  std::optional<double> output_nodata;
};

// Throws UsageError naming the flag as typed: a code outside 0-255, a code
// for a raster that has none, a visible code shared with another.
RasterFlags raster_flags(const Args& args);

}  // namespace horizon::cli
