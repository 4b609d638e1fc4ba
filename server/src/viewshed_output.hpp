// viewshed_output.hpp — what a ViewshedRequest asks to be written: the
// raster (its kind), a visible raster's value codes, the value of cells
// without an answer, and the GeoTIFF's format and creation options. Checked
// here, each error naming the request's field ("codes.visible",
// "output_nodata", "creation_options").
#pragma once

#include <optional>

#include "horizon/common/error.hpp"
#include "horizon/terrain/geotiff_options.hpp"
#include "horizon/v1/visibility.pb.h"
#include "horizon/visibility/viewshed_outputs.hpp"

namespace horizon::server {

struct ViewshedOutputSpec {
  v1::RasterKind kind = v1::RASTER_KIND_VISIBLE;  // never unspecified
  visibility::ViewshedOutput output = visibility::ViewshedOutput::kVisibility;
  // The uint8 rasters' codes (RASTER_KIND_BOOLEAN: r.viewshed's, with the
  // request's nodata); codes.nodata is also their GeoTIFF's nodata.
  visibility::ValueCodes codes;
  // The float rasters' no-answer value, when the request gives one.
  std::optional<double> float_nodata;
  terrain::GeoTiffOptions geotiff;
};

// One observer's request (`raster`, `codes`, `output_nodata`,
// `geotiff_format`, `creation_options`).
Result<ViewshedOutputSpec> to_output_spec(const v1::ViewshedRequest& request);

// A many-observer request's GeoTIFF options; `raster` other than visible,
// `codes` and `output_nodata` are refused (they are one observer's).
Result<terrain::GeoTiffOptions> to_many_geotiff_options(const v1::ViewshedRequest& request);

}  // namespace horizon::server
