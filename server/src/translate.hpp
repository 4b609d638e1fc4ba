// translate.hpp — protobuf messages to and from the engine's plain structs.
// Nothing here computes; every check of a request field that the engine does
// not already make (enum values, required messages) happens here, with the
// field's API path in the Error ("observer", "options.algorithm").
#pragma once

#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "datasets.hpp"
#include "horizon/common/error.hpp"
#include "horizon/geodesy/observer.hpp"
#include "horizon/region/region_plan.hpp"
#include "horizon/v1/datasets.pb.h"
#include "horizon/v1/visibility.pb.h"
#include "horizon/visibility/cull.hpp"
#include "horizon/visibility/line_of_sight.hpp"
#include "horizon/visibility/options.hpp"
#include "horizon/visibility/viewshed.hpp"

namespace horizon::server {

// Point -> PointSpec; `field` is its API path ("observer", "lines[2].from").
Result<geodesy::PointSpec> to_point_spec(const v1::Point& point, const std::string& field);
Result<geodesy::PointFrame> to_frame(v1::Frame frame, const std::string& field);
Result<visibility::Algorithm> to_algorithm(v1::Algorithm algorithm, const std::string& field);
v1::Algorithm to_proto_algorithm(visibility::Algorithm algorithm);
v1::BoxState to_proto_box_state(visibility::Visibility state);
// Unspecified reads as the default (auto, fragment); an unknown value is kInvalidArgument naming `field`.
Result<visibility::Backend> to_backend(v1::Backend backend, const std::string& field);
Result<visibility::GpuMethod> to_gpu_method(v1::GpuMethod method, const std::string& field);

// Viewshed options (checked by the engine's validate_options, errors renamed to API paths).
Result<visibility::ViewshedOptions> to_viewshed_options(const v1::ViewshedOptions& options, unsigned threads);
// The curvature field shared by LineOfSight and CullBoxes ("curvature").
Result<double> to_curvature(bool has, double value);
// A CullBoxes request's algorithm, curvature and conservative flag.
Result<visibility::CullOptions> to_cull_options(const v1::CullBoxesRequest& request, unsigned threads);
// A CullBoxes request's boxes, each frame checked ("boxes[i].frame"). The
// caller bounds boxes_size() by limits.max_boxes first.
Result<std::vector<visibility::BoxSpec>> to_boxes(const v1::CullBoxesRequest& request);
Result<std::vector<visibility::BoxSpec>> to_boxes(const google::protobuf::RepeatedPtrField<v1::Box>& boxes);
// A RegionVisibility request as an engine query: the region (required,
// "region.height_mode" checked), boxes or cells, options (0 = default;
// errors renamed to the API fields). The caller bounds boxes_size() first.
Result<region::RegionQuery> to_region_query(const v1::RegionVisibilityRequest& request, unsigned threads);
v1::RegionVerdict to_proto_verdict(region::Verdict verdict);
void fill_region_stats(const region::RegionStats& s, v1::RegionStats& out);
// A sight line's two ends, both required; `prefix` is its API path
// ("lines[3].", naming "lines[3].from").
Result<std::pair<geodesy::PointSpec, geodesy::PointSpec>> to_line_ends(const v1::SightLine& line,
                                                                       const std::string& prefix);

// An engine error's field renamed to the API path: core names options by their
// C++ members ("curvature_coefficient") and WGS84 coordinates "lon"/"lat";
// `prefix` is prepended to point fields ("lines[3].").
Error rename_field(Error error, std::string_view options_prefix, std::string_view point_prefix = {});

void fill_dataset(const Dataset& d, const terrain::BlockCache& cache, v1::Dataset& out);
// `p` in the grid of the raster `georef` describes (col/row as given; lon/lat from its CRS).
void fill_point(const geodesy::GridPoint& p, const terrain::Georeference& georef, v1::ResolvedPoint& out);
void fill_transform(const terrain::GeoTransform& t, v1::GeoTransform& out);
void fill_window(const terrain::Window& w, v1::Window& out);
void fill_stats(const visibility::WorkStats& s, v1::WorkStats& out);
void fill_sample(const visibility::ProfileSample& s, v1::ProfileSample& out);

}  // namespace horizon::server
