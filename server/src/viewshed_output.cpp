#include "viewshed_output.hpp"

#include <cmath>
#include <string>
#include <vector>

namespace horizon::server {
namespace {

Error invalid(const std::string& field, const std::string& what) {
  return make_error(ErrorCode::kInvalidArgument, field + ": " + what, field);
}

Result<visibility::ViewshedOutput> output_of(v1::RasterKind kind) {
  switch (kind) {
    case v1::RASTER_KIND_UNSPECIFIED:
    case v1::RASTER_KIND_VISIBLE:
      return visibility::ViewshedOutput::kVisibility;
    case v1::RASTER_KIND_BOOLEAN:
      return visibility::ViewshedOutput::kBoolean;
    case v1::RASTER_KIND_OHF:
      return visibility::ViewshedOutput::kOhf;
    case v1::RASTER_KIND_MIN_TARGET_HEIGHT:
      return visibility::ViewshedOutput::kMinTargetHeight;
    case v1::RASTER_KIND_VERTICAL_ANGLE:
      return visibility::ViewshedOutput::kVerticalAngle;
    case v1::RASTER_KIND_ELEVATION_DIFFERENCE:
      return visibility::ViewshedOutput::kElevationDifference;
    default:
      return invalid("raster", "unknown value " + std::to_string(static_cast<int>(kind)));
  }
}

Result<std::uint8_t> code(const std::string& field, double value) {
  if (!(value >= 0 && value <= 255 && std::floor(value) == value))
    return invalid(field, "must be a whole number in [0, 255] (a UInt8 code), got " + number_text(value));
  return static_cast<std::uint8_t>(value);
}

Result<terrain::GeoTiffOptions> geotiff_options(const v1::ViewshedRequest& r) {
  terrain::TiffFormat format = terrain::TiffFormat::kGTiff;
  switch (r.geotiff_format()) {
    case v1::GEOTIFF_FORMAT_UNSPECIFIED:
    case v1::GEOTIFF_FORMAT_GTIFF:
      break;
    case v1::GEOTIFF_FORMAT_COG:
      format = terrain::TiffFormat::kCog;
      break;
    default:
      return invalid("geotiff_format", "unknown value " + std::to_string(static_cast<int>(r.geotiff_format())));
  }
  const std::vector<std::string> items(r.creation_options().begin(), r.creation_options().end());
  return terrain::parse_creation_options(format, items);
}

}  // namespace

Result<ViewshedOutputSpec> to_output_spec(const v1::ViewshedRequest& r) {
  ViewshedOutputSpec spec;
  auto output = output_of(r.raster());
  if (!output.ok()) return output.error();
  spec.output = *output;
  spec.kind = r.raster() == v1::RASTER_KIND_UNSPECIFIED ? v1::RASTER_KIND_VISIBLE : r.raster();
  const bool codes_raster = visibility::is_code_raster(spec.output);
  if (r.has_codes() && spec.output != visibility::ViewshedOutput::kVisibility)
    return invalid("codes", "only for RASTER_KIND_VISIBLE (RASTER_KIND_BOOLEAN's codes are r.viewshed's 1 and 0)");
  if (spec.output == visibility::ViewshedOutput::kBoolean) spec.codes = visibility::kBooleanCodes;
  const v1::ValueCodes& c = r.codes();
  for (auto [has, value, target, field] :
       {std::tuple{c.has_visible(), c.visible(), &spec.codes.visible, "codes.visible"},
        std::tuple{c.has_hidden(), c.hidden(), &spec.codes.hidden, "codes.hidden"},
        std::tuple{c.has_out_of_range(), c.out_of_range(), &spec.codes.out_of_range, "codes.out_of_range"}}) {
    if (!has) continue;
    auto v = code(field, static_cast<double>(value));
    if (!v.ok()) return v.error();
    *target = *v;
  }
  if (r.has_output_nodata()) {
    if (codes_raster) {
      auto v = code("output_nodata", r.output_nodata());
      if (!v.ok()) return v.error();
      spec.codes.nodata = *v;
    } else {
      const double v = r.output_nodata();
      if (std::isinf(v) || (std::isfinite(v) && std::abs(v) > 3.4028234663852886e38))
        return invalid("output_nodata", "must be a float32 value or NaN, got " + number_text(v));
      spec.float_nodata = v;
    }
  }
  if (Status s = visibility::validate_value_codes(spec.codes); !s.ok()) {
    Error e = s.error();
    e.field = "codes.visible";
    e.message = "codes.visible" + e.message.substr(e.message.find(':'));
    return e;
  }
  auto geotiff = geotiff_options(r);
  if (!geotiff.ok()) return geotiff.error();
  spec.geotiff = *geotiff;
  return spec;
}

Result<terrain::GeoTiffOptions> to_many_geotiff_options(const v1::ViewshedRequest& r) {
  if (r.has_codes()) return invalid("codes", "one observer's visible raster only; not with observers");
  if (r.has_output_nodata()) return invalid("output_nodata", "one observer's raster only; not with observers");
  return geotiff_options(r);
}

}  // namespace horizon::server
