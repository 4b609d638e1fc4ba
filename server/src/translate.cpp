#include "translate.hpp"

#include <algorithm>
#include <cmath>

#include "horizon/geodesy/crs.hpp"

namespace horizon::server {
namespace {

Error invalid(const std::string& field, const std::string& what) {
  return make_error(ErrorCode::kInvalidArgument, field + ": " + what, field);
}

}  // namespace

Result<geodesy::PointFrame> to_frame(v1::Frame frame, const std::string& field) {
  switch (frame) {
    case v1::FRAME_UNSPECIFIED:
    case v1::FRAME_DATASET_CRS:
      return geodesy::PointFrame::kDatasetCrs;
    case v1::FRAME_WGS84:
      return geodesy::PointFrame::kWgs84;
    default:
      return invalid(field, "unknown frame value " + std::to_string(static_cast<int>(frame)));
  }
}

Result<geodesy::PointSpec> to_point_spec(const v1::Point& point, const std::string& field) {
  geodesy::PointSpec spec;
  auto frame = to_frame(point.frame(), field + ".frame");
  if (!frame.ok()) return frame.error();
  spec.frame = *frame;
  spec.x = point.x();
  spec.y = point.y();
  spec.height = point.height();
  switch (point.height_mode()) {
    case v1::HEIGHT_MODE_UNSPECIFIED:
    case v1::HEIGHT_MODE_ABOVE_GROUND:
      spec.height_mode = geodesy::HeightMode::kAboveGround;
      if (std::isfinite(spec.height) && spec.height < 0)
        return invalid(field + ".height", "a height above ground must be >= 0 metres");
      break;
    case v1::HEIGHT_MODE_ABSOLUTE:
      spec.height_mode = geodesy::HeightMode::kAbsolute;
      break;
    default:
      return invalid(field + ".height_mode", "unknown value " + std::to_string(static_cast<int>(point.height_mode())));
  }
  switch (point.ground()) {
    case v1::GROUND_SAMPLE_UNSPECIFIED:
    case v1::GROUND_SAMPLE_BILINEAR:
      spec.ground = geodesy::GroundSample::kBilinear;
      break;
    case v1::GROUND_SAMPLE_CELL:
      spec.ground = geodesy::GroundSample::kCell;
      break;
    default:
      return invalid(field + ".ground", "unknown value " + std::to_string(static_cast<int>(point.ground())));
  }
  return spec;
}

Result<visibility::Algorithm> to_algorithm(v1::Algorithm algorithm, const std::string& field) {
  switch (algorithm) {
    case v1::ALGORITHM_UNSPECIFIED:
    case v1::ALGORITHM_FAST:
      return visibility::Algorithm::kRadial;
    case v1::ALGORITHM_EXACT:
      return visibility::Algorithm::kExact;
    case v1::ALGORITHM_CONSERVATIVE:
      return visibility::Algorithm::kConservative;
    case v1::ALGORITHM_R3:
      return visibility::Algorithm::kR3;
    default:
      return invalid(field, "unknown algorithm value " + std::to_string(static_cast<int>(algorithm)));
  }
}

v1::Algorithm to_proto_algorithm(visibility::Algorithm algorithm) {
  switch (algorithm) {
    case visibility::Algorithm::kRadial:
      return v1::ALGORITHM_FAST;
    case visibility::Algorithm::kExact:
      return v1::ALGORITHM_EXACT;
    case visibility::Algorithm::kConservative:
      return v1::ALGORITHM_CONSERVATIVE;
    case visibility::Algorithm::kR3:
      return v1::ALGORITHM_R3;
  }
  return v1::ALGORITHM_UNSPECIFIED;
}

v1::BoxState to_proto_box_state(visibility::Visibility state) {
  switch (state) {
    case visibility::Visibility::kSeen:
      return v1::BOX_STATE_VISIBLE;
    case visibility::Visibility::kOccluded:
      return v1::BOX_STATE_HIDDEN;
    case visibility::Visibility::kUndetermined:
      return v1::BOX_STATE_UNDETERMINED;
    case visibility::Visibility::kOutOfRange:
      return v1::BOX_STATE_OUT_OF_RANGE;
  }
  return v1::BOX_STATE_UNSPECIFIED;
}

Result<visibility::Backend> to_backend(v1::Backend backend, const std::string& field) {
  switch (backend) {
    case v1::BACKEND_UNSPECIFIED:
    case v1::BACKEND_AUTO:
      return visibility::Backend::kAuto;
    case v1::BACKEND_CPU:
      return visibility::Backend::kCpu;
    case v1::BACKEND_GPU:
      return visibility::Backend::kGpu;
    default:
      return invalid(field, "unknown backend value " + std::to_string(static_cast<int>(backend)));
  }
}

Result<visibility::GpuMethod> to_gpu_method(v1::GpuMethod method, const std::string& field) {
  switch (method) {
    case v1::GPU_METHOD_UNSPECIFIED:
    case v1::GPU_METHOD_FRAGMENT:
      return visibility::GpuMethod::kFragment;
    case v1::GPU_METHOD_COMPUTE:
      return visibility::GpuMethod::kCompute;
    default:
      return invalid(field, "unknown GPU method value " + std::to_string(static_cast<int>(method)));
  }
}

Error rename_field(Error error, std::string_view options_prefix, std::string_view point_prefix) {
  std::string& f = error.field;
  if (f.empty()) return error;
  if (f == "curvature_coefficient") {
    f = std::string(options_prefix) + "curvature";
  } else if (f == "target_height" || f == "max_distance" || f == "nodata_fill_height" || f == "ray_spacing" ||
             f == "algorithm" || f == "backend" || f == "gpu_method" || f == "azimuth_start" || f == "azimuth_end" ||
             f == "min_distance" || f == "pitch_min" || f == "pitch_max") {
    f = std::string(options_prefix) + f;
  } else if (f.starts_with("observer") || f.starts_with("from") || f.starts_with("to")) {
    // WGS84 points are x = longitude, y = latitude in the API.
    if (f.ends_with(".lon")) f.replace(f.size() - 3, 3, "x");
    if (f.ends_with(".lat")) f.replace(f.size() - 3, 3, "y");
    f = std::string(point_prefix) + f;
  }
  return error;
}

Result<visibility::NodataPolicy> to_nodata_policy(v1::NodataPolicy policy, const std::string& field) {
  switch (policy) {
    case v1::NODATA_POLICY_UNSPECIFIED:
    case v1::NODATA_POLICY_TRANSPARENT:
      return visibility::NodataPolicy::kTransparent;
    case v1::NODATA_POLICY_FILL:
      return visibility::NodataPolicy::kFill;
    default:
      return invalid(field, "unknown value " + std::to_string(static_cast<int>(policy)));
  }
}

Result<visibility::ViewshedOptions> to_viewshed_options(const v1::ViewshedOptions& in, unsigned threads) {
  visibility::ViewshedOptions o;
  o.target_height = in.target_height();
  // 0 is no limit, as gdal_viewshed's -md 0.
  if (in.has_max_distance() && in.max_distance() != 0.0) o.max_distance = in.max_distance();
  if (in.has_curvature()) o.curvature_coefficient = in.curvature();
  if (in.has_refraction()) {
    if (in.has_curvature())
      return invalid("options.refraction", "give refraction (GRASS's coefficient) or curvature (GDAL's), not both");
    if (!std::isfinite(in.refraction()) || in.refraction() < -1.0 || in.refraction() > 1.0)
      return invalid("options.refraction", "must be in [-1, 1] (0.14286 = standard refraction, 1 = flat earth), got " +
                                               number_text(in.refraction()));
    o.curvature_coefficient = visibility::curvature_from_refraction(in.refraction());
  }
  visibility::FieldOfView& view = o.field_of_view;
  view.azimuth_start = in.azimuth_start();
  view.azimuth_end = in.azimuth_end();
  view.min_distance = in.min_distance();
  if (in.has_pitch_min()) view.pitch_min = in.pitch_min();
  if (in.has_pitch_max()) view.pitch_max = in.pitch_max();
  auto nodata = to_nodata_policy(in.nodata(), "options.nodata");
  if (!nodata.ok()) return nodata.error();
  o.nodata = *nodata;
  o.nodata_fill_height = in.nodata_fill_height();
  auto algorithm = to_algorithm(in.algorithm(), "options.algorithm");
  if (!algorithm.ok()) return algorithm.error();
  o.algorithm = *algorithm;
  if (in.has_ray_spacing()) o.radial.ray_spacing = in.ray_spacing();
  auto backend = to_backend(in.backend(), "options.backend");
  if (!backend.ok()) return backend.error();
  o.backend = *backend;
  auto method = to_gpu_method(in.gpu_method(), "options.gpu_method");
  if (!method.ok()) return method.error();
  if (in.gpu_method() != v1::GPU_METHOD_UNSPECIFIED || in.has_gpu_log_step()) {
    o.gpu.emplace();  // a named variant; neither field: the pool's measured fastest
    o.gpu->method = *method;
    if (in.has_gpu_log_step()) o.gpu->log_step = in.gpu_log_step();
  }
  o.threads = threads;
  if (auto s = visibility::validate_options(o); !s.ok()) return rename_field(s.error(), "options.");
  return o;
}

Result<double> to_curvature(bool has, double value) {
  visibility::ViewshedOptions check;
  if (has) check.curvature_coefficient = value;
  if (auto s = visibility::validate_options(check); !s.ok()) return rename_field(s.error(), "");
  return check.curvature_coefficient;
}

Result<visibility::CullOptions> to_cull_options(const v1::CullBoxesRequest& request, unsigned threads) {
  visibility::CullOptions options;
  auto algorithm = to_algorithm(request.algorithm(), "algorithm");
  if (!algorithm.ok()) return algorithm.error();
  options.viewshed.algorithm = *algorithm;
  auto curvature = to_curvature(request.has_curvature(), request.curvature());
  if (!curvature.ok()) return curvature.error();
  options.viewshed.curvature_coefficient = *curvature;
  auto nodata = to_nodata_policy(request.nodata(), "nodata");
  if (!nodata.ok()) return nodata.error();
  options.viewshed.nodata = *nodata;
  options.viewshed.nodata_fill_height = request.nodata_fill_height();
  if (auto s = visibility::validate_options(options.viewshed); !s.ok()) return rename_field(s.error(), "");
  options.viewshed.threads = threads;
  options.conservative = request.conservative();
  return options;
}

Result<std::vector<visibility::BoxSpec>> to_boxes(const v1::CullBoxesRequest& request) {
  return to_boxes(request.boxes());
}

Result<std::vector<visibility::BoxSpec>> to_boxes(const google::protobuf::RepeatedPtrField<v1::Box>& in_boxes) {
  std::vector<visibility::BoxSpec> boxes(static_cast<std::size_t>(in_boxes.size()));
  for (int i = 0; i < in_boxes.size(); ++i) {
    const v1::Box& in = in_boxes.Get(i);
    auto frame = to_frame(in.frame(), "boxes[" + std::to_string(i) + "].frame");
    if (!frame.ok()) return frame.error();
    boxes[static_cast<std::size_t>(i)] = {*frame,     in.x_min(), in.y_min(), in.x_max(),
                                          in.y_max(), in.z_min(), in.z_max()};
  }
  return boxes;
}

Result<region::RegionQuery> to_region_query(const v1::RegionVisibilityRequest& request, unsigned threads) {
  if (!request.has_region()) return invalid("region", "required");
  region::RegionQuery q;
  const v1::Region& r = request.region();
  auto frame = to_frame(r.frame(), "region.frame");
  if (!frame.ok()) return frame.error();
  q.region.frame = *frame;
  q.region.x_min = r.x_min();
  q.region.y_min = r.y_min();
  q.region.x_max = r.x_max();
  q.region.y_max = r.y_max();
  q.region.z_min = r.z_min();
  q.region.z_max = r.z_max();
  switch (r.height_mode()) {
    case v1::HEIGHT_MODE_UNSPECIFIED:
    case v1::HEIGHT_MODE_ABOVE_GROUND:
      q.region.height_mode = geodesy::HeightMode::kAboveGround;
      break;
    case v1::HEIGHT_MODE_ABSOLUTE:
      q.region.height_mode = geodesy::HeightMode::kAbsolute;
      break;
    default:
      return invalid("region.height_mode", "unknown value " + std::to_string(static_cast<int>(r.height_mode())));
  }
  q.cells = request.cells();
  if (q.cells && request.boxes_size() > 0) return invalid("cells", "give boxes or cells, not both");
  if (!q.cells) {
    auto boxes = to_boxes(request.boxes());
    if (!boxes.ok()) return boxes.error();
    q.boxes = std::move(*boxes);
  }
  region::RegionOptions& o = q.options;
  if (request.max_distance() != 0.0) o.max_distance = request.max_distance();
  if (!q.cells && request.max_distance() != 0.0) return invalid("max_distance", "only for cells");
  o.target_height = request.target_height();
  if (request.face_resolution() != 0)
    o.face_resolution = static_cast<int>(std::min<std::uint32_t>(request.face_resolution(), 1u << 30));
  if (request.footprint_splits() != 0)
    o.footprint_splits = static_cast<int>(std::min<std::uint32_t>(request.footprint_splits(), 1u << 30));
  auto curvature = to_curvature(request.has_curvature(), request.curvature());
  if (!curvature.ok()) return curvature.error();
  o.curvature_coefficient = *curvature;
  auto nodata = to_nodata_policy(request.nodata(), "nodata");
  if (!nodata.ok()) return nodata.error();
  o.nodata = *nodata;
  o.nodata_fill_height = request.nodata_fill_height();
  o.threads = threads;
  if (auto s = region::validate_region_options(o); !s.ok()) return rename_field(s.error(), "");
  return q;
}

v1::RegionVerdict to_proto_verdict(region::Verdict verdict) {
  switch (verdict) {
    case region::Verdict::kAlwaysHidden:
      return v1::REGION_VERDICT_ALWAYS_HIDDEN;
    case region::Verdict::kAlwaysVisible:
      return v1::REGION_VERDICT_ALWAYS_VISIBLE;
    case region::Verdict::kUndetermined:
      return v1::REGION_VERDICT_UNDETERMINED;
  }
  return v1::REGION_VERDICT_UNSPECIFIED;
}

void fill_region_stats(const region::RegionStats& s, v1::RegionStats& out) {
  out.set_seconds(s.seconds);
  out.set_walls_swept(s.walls_swept);
  out.set_wall_nodes_read(s.wall_nodes_read);
  out.set_pyramid_cells_read(s.pyramid_cells_read);
  out.set_items(s.items);
  out.set_always_hidden(s.always_hidden);
  out.set_always_visible(s.always_visible);
  out.set_undetermined(s.undetermined);
}

Result<std::pair<geodesy::PointSpec, geodesy::PointSpec>> to_line_ends(const v1::SightLine& line,
                                                                       const std::string& prefix) {
  if (!line.has_from() || !line.has_to()) {
    const std::string field = prefix + (line.has_from() ? "to" : "from");
    return make_error(ErrorCode::kInvalidArgument, field + ": required", field);
  }
  auto from = to_point_spec(line.from(), prefix + "from");
  if (!from.ok()) return from.error();
  auto to = to_point_spec(line.to(), prefix + "to");
  if (!to.ok()) return to.error();
  return std::pair{*from, *to};
}

void fill_transform(const terrain::GeoTransform& t, v1::GeoTransform& out) {
  out.set_origin_x(t.origin_x);
  out.set_pixel_width(t.pixel_width);
  out.set_origin_y(t.origin_y);
  out.set_pixel_height(t.pixel_height);
}

void fill_window(const terrain::Window& w, v1::Window& out) {
  out.set_col0(w.col0);
  out.set_row0(w.row0);
  out.set_col1(w.col1);
  out.set_row1(w.row1);
}

void fill_stats(const visibility::WorkStats& s, v1::WorkStats& out) {
  out.set_dem_cells(s.dem_cells);
  out.set_window_cells(s.window_cells);
  out.set_cells_evaluated(s.cells_evaluated);
  out.set_terrain_samples(s.terrain_samples);
  out.set_rays(s.rays);
  out.set_seconds(s.seconds);
  out.set_backend(s.backend);
  out.set_gpu_fallback(s.gpu_fallback);
  out.set_device_seconds(s.device_seconds);
  out.set_gpu_variant(s.gpu_variant);
}

void fill_sample(const visibility::ProfileSample& s, v1::ProfileSample& out) {
  out.set_distance(s.distance);
  out.set_col(s.col);
  out.set_row(s.row);
  out.set_x(s.x);
  out.set_y(s.y);
  out.set_terrain(s.terrain);
  out.set_sight_line(s.sight_line);
}

void fill_point(const geodesy::GridPoint& p, const terrain::Georeference& georef, v1::ResolvedPoint& out) {
  out.set_x(p.x);
  out.set_y(p.y);
  if (georef.has_crs()) {
    if (auto crs = geodesy::Crs::of(georef); crs.ok()) {
      if (auto ll = crs->to_lonlat({p.x, p.y}); ll.ok()) {
        out.set_lon(ll->lon);
        out.set_lat(ll->lat);
      }
    }
  }
  out.set_col(p.col);
  out.set_row(p.row);
  out.set_ground(p.ground);
  out.set_elevation(p.elevation);
}

void fill_dataset(const Dataset& d, const terrain::BlockCache& cache, v1::Dataset& out) {
  const terrain::DemHeader& dem = d.header();
  out.set_name(d.name);
  out.set_source(d.file);
  out.set_format(dem.format);
  out.set_width(dem.width);
  out.set_height(dem.height);
  out.set_epsg(dem.georef.epsg);
  out.set_crs_name(d.crs_name);
  out.set_crs_wkt(d.crs_wkt);
  out.set_geographic(d.geographic);
  const auto& t = dem.georef.transform;
  fill_transform(t, *out.mutable_transform());
  const double x0 = t.origin_x, x1 = t.origin_x + dem.width * t.pixel_width;
  const double y0 = t.origin_y, y1 = t.origin_y + dem.height * t.pixel_height;
  auto* e = out.mutable_extent();
  e->set_x_min(std::min(x0, x1));
  e->set_x_max(std::max(x0, x1));
  e->set_y_min(std::min(y0, y1));
  e->set_y_max(std::max(y0, y1));
  if (d.lonlat) {
    auto* ll = out.mutable_extent_lonlat();
    ll->set_west(d.lonlat->west);
    ll->set_south(d.lonlat->south);
    ll->set_east(d.lonlat->east);
    ll->set_north(d.lonlat->north);
  }
  out.set_cell_size_x_m(d.cell_size_x_m);
  out.set_cell_size_y_m(d.cell_size_y_m);
  if (dem.nodata) out.set_nodata(*dem.nodata);
  if (d.stats.valid_cells) {
    out.set_elevation_min(d.stats.min);
    out.set_elevation_max(d.stats.max);
  }
  out.set_valid_cells(d.stats.valid_cells);
  out.set_void_cells(d.stats.nodata_cells);
  out.set_resident_bytes(cache.resident_bytes_of(d.source->id()));
}

}  // namespace horizon::server
