// The raster of one observer's viewshed, from its flags (viewshed_raster.hpp).
#include "commands/viewshed_raster.hpp"

#include <cmath>
#include <string>
#include <string_view>

#include "inputs.hpp"

namespace horizon::cli {
namespace {

// Ours, then gdal_viewshed's -om spellings.
constexpr std::string_view kOutputs[] = {
    "visible", "boolean", "ohf",   "min-target-height", "vertical-angle", "elevation-difference",
    "NORMAL",  "DEM",     "GROUND"};

std::string_view our_name(std::string_view typed) {
  if (typed == "NORMAL") return "visible";
  if (typed == "DEM") return "ohf";
  if (typed == "GROUND") return "min-target-height";
  return typed;
}

std::uint8_t code(const Args& args, std::string_view flag, double value) {
  if (!(value >= 0 && value <= 255 && std::floor(value) == value))
    throw UsageError(args.typed(flag) + ": expected a code, a whole number in [0, 255], got '" + *args.text(flag) +
                     "'");
  return static_cast<std::uint8_t>(value);
}

}  // namespace

RasterFlags raster_flags(const Args& args) {
  RasterFlags r;
  if (auto typed = args.choice("--output", kOutputs)) r.name = our_name(*typed);
  r.output = *visibility::parse_output(r.name);
  const bool codes = visibility::is_code_raster(r.output);

  for (std::string_view flag : {"--visible-value", "--hidden-value", "--out-of-range-value"})
    if (args.has(flag) && r.output != visibility::ViewshedOutput::kVisibility)
      throw UsageError(args.typed(flag) + ": codes only the visible raster (--output visible), not " + r.name +
                       (r.output == visibility::ViewshedOutput::kBoolean ? " (r.viewshed's 1 and 0)" : ""));
  if (r.output == visibility::ViewshedOutput::kBoolean) r.codes = visibility::kBooleanCodes;
  if (auto v = args.number("--visible-value")) r.codes.visible = code(args, "--visible-value", *v);
  if (auto v = args.number("--hidden-value")) r.codes.hidden = code(args, "--hidden-value", *v);
  if (auto v = args.number("--out-of-range-value")) r.codes.out_of_range = code(args, "--out-of-range-value", *v);

  if (auto text = args.text("--output-nodata")) {
    if (codes) {
      r.output_nodata = code(args, "--output-nodata", args.number("--output-nodata").value());
      r.codes.nodata = static_cast<std::uint8_t>(*r.output_nodata);
    } else if (*text == "nan" || *text == "NaN") {
      r.output_nodata = std::nan("");
    } else {
      const auto v = parse_finite(*text);
      if (!v || std::abs(*v) > 3.4028234663852886e38)
        throw UsageError(args.typed("--output-nodata") + ": expected a float32 value or 'nan' for the " + r.name +
                         " raster, got '" + *text + "'");
      r.output_nodata = *v;
    }
  }
  // gdal_viewshed's own -vv is 255, our nodata unless -a_nodata moves it: say so.
  if (r.codes.visible == r.codes.nodata && !r.output_nodata && args.has("--visible-value"))
    throw UsageError(args.typed("--visible-value") + ": " + std::to_string(r.codes.visible) +
                     " is also the nodata code (255 by default); give --output-nodata (-a_nodata) another one");
  throw_if_invalid_option(visibility::validate_value_codes(r.codes), &args);
  return r;
}

}  // namespace horizon::cli
