// horizon/visibility/viewshed_outputs.hpp — the rasters a viewshed can be
// written as, by the names the CLI and the API give them, and the ones that
// are not in viewshed.hpp: the visible raster with the caller's value codes
// (gdal_viewshed's -vv -iv -ov -a_nodata), and GRASS r.viewshed's vertical
// angle and elevation difference.
//
// Every one derives from the result's OHF by the rule of viewshed.hpp (a
// target of height h is visible when h >= min_target_height_at(ohf, z)), so
// none can disagree with another. A cell of the window is, in this order:
//   no data       its ground is a void (NodataPolicy::kTransparent);
//   out of range  no answer otherwise: beyond max_distance, or outside the
//                 field of view (field_of_view.hpp);
//   visible / hidden at the target height.
#pragma once

#include <cstdint>
#include <optional>
#include <string_view>

#include "horizon/common/error.hpp"
#include "horizon/terrain/grid.hpp"
#include "horizon/visibility/viewshed.hpp"

namespace horizon::visibility {

enum class ViewshedOutput {
  kVisibility,           // "visible": uint8 codes (ValueCodes; 1 / 0 / 255 by default)
  kBoolean,              // "boolean": uint8, r.viewshed -b: 1 visible, 0 hidden or out of range, 255 no data
  kOhf,                  // "ohf": float32, ohf_raster()
  kMinTargetHeight,      // "min-target-height": float32, min_target_height()
  kVerticalAngle,        // "vertical-angle": float32, vertical_angle_raster() (r.viewshed's default output)
  kElevationDifference,  // "elevation-difference": float32, elevation_difference_raster() (r.viewshed -e)
};

std::string_view output_name(ViewshedOutput output);
std::optional<ViewshedOutput> parse_output(std::string_view name);
// A uint8 raster of codes (visible, boolean); the others are float32.
bool is_code_raster(ViewshedOutput output);
// Needs the OHF's heights (ohf, min-target-height); the others need only
// visible/hidden at the target height (ViewshedOptions::visibility_only).
bool needs_heights(ViewshedOutput output);

// The codes of a uint8 visibility raster. The file's nodata tag is `nodata`.
struct ValueCodes {
  std::uint8_t visible = kVisible;
  std::uint8_t hidden = kHidden;
  std::uint8_t out_of_range = kNoAnswer;
  std::uint8_t nodata = kNoAnswer;
  bool operator==(const ValueCodes&) const = default;
};

// r.viewshed -b's: out of range reads as hidden (0), voids stay no data.
inline constexpr ValueCodes kBooleanCodes{.visible = 1, .hidden = 0, .out_of_range = 0, .nodata = kNoAnswer};

// The visible code must differ from the three others (or visible cells would
// read as hidden, out of range or transparent); those may share a value
// (hidden as no data is r.viewshed's default). Field "visible_value".
Status validate_value_codes(const ValueCodes& codes);

// The visible raster in `codes`: window-sized, every cell one of the four;
// rows on `threads` threads (0 = all hardware threads); the classes' counts
// in `counts` when given. A result holding its mask and no OHF
// (ViewshedOptions::mask_only) is recoded from the mask and its ground: it
// answers at its own target height only, which `target_height` must be.
terrain::Grid<std::uint8_t> visibility_codes(const ViewshedResult& result, double target_height,
                                             const ValueCodes& codes, unsigned threads = 1,
                                             AnswerCounts* counts = nullptr);

// r.viewshed's vertical angle to each visible target, degrees from straight
// down: 0 straight down, 90 level, 180 straight up, i.e.
//   90 + atan2(z + target_height - curvature * d^2 - eye, d)
// (d the ground distance to the cell centre); the cell the eye stands in
// (r.viewshed's undefined angle) is 180. NaN where not visible.
terrain::Grid<float> vertical_angle_raster(const ViewshedResult& result, double target_height);

// r.viewshed -e's elevation difference of each visible cell: its ground
// minus the eye's elevation, metres (no curvature, no target height). NaN
// where not visible. (GRASS 8.2 subtracts the observer's height above the
// ground once more than it says; this raster is the difference it documents.)
terrain::Grid<float> elevation_difference_raster(const ViewshedResult& result, double target_height);

// The raster `output` names, as float32 (kOhf .. kElevationDifference).
terrain::Grid<float> float_raster(const ViewshedResult& result, ViewshedOutput output, double target_height);

}  // namespace horizon::visibility
