// ComputeViewshed with many observers: the union of their windows sized
// from the dataset's header and bounded before a cell is read, then read
// once and accumulated by the engine (visibility/many_observers.hpp).
#include "viewshed_many_call.hpp"

#include <algorithm>
#include <chrono>
#include <cstring>
#include <string>
#include <vector>

#include "horizon/common/parallel.hpp"
#include "horizon/geodesy/observer.hpp"
#include "horizon/terrain/height_view.hpp"
#include "horizon/visibility/many_observers.hpp"
#include "horizon/visibility/viewshed_preview.hpp"
#include "raster_files.hpp"
#include "translate.hpp"
#include "viewshed_output.hpp"

namespace horizon::server {
namespace {

// The masks' GeoTIFFs carry the previews' colours, as the CLI's do.
const terrain::ColourTable kCodeColours = visibility::code_colour_table();

std::string site_name(int i) {
  return "observers[" + std::to_string(i) + "]";
}

// Engine errors name "observers[i]..." as the request does; the shared
// options' fields take the "options." prefix.
Error as_request_field(Error e) {
  if (e.field.starts_with("observers")) return e;
  return rename_field(std::move(e), "options.");
}

terrain::Window merged(const terrain::Window& a, const terrain::Window& b) {
  if (a.empty()) return b;
  return {std::min(a.col0, b.col0), std::min(a.row0, b.row0), std::max(a.col1, b.col1), std::max(a.row1, b.row1)};
}

template <class T>
void copy_rows(const terrain::Grid<T>& grid, std::string& out) {
  out.resize(grid.size() * sizeof(T));
  if (!out.empty()) std::memcpy(out.data(), grid.data(), out.size());
}

}  // namespace

grpc::Status compute_many_viewshed(CallScope& scope, const v1::ViewshedRequest& req, ViewshedParts& out) {
  auto dataset = scope.dataset(req.dataset());
  if (!dataset.ok()) return scope.status_of(dataset.error());
  const Dataset& d = **dataset;
  const ServerEnv& env = scope.env();
  const terrain::DemHeader& h = d.header();
  const int n = req.observers_size();
  scope.record().boxes = static_cast<std::uint64_t>(n);
  if (static_cast<std::uint64_t>(n) > env.config.limits.max_observers)
    return scope.status_of(make_error(
        ErrorCode::kResourceExhausted,
        "observers: " + std::to_string(n) +
            " observers, more than limits.max_observers = " + std::to_string(env.config.limits.max_observers),
        "observers"));
  if (req.has_observer())
    return scope.status_of(
        make_error(ErrorCode::kInvalidArgument, "observer: give one observer or many observers, not both", "observer"));
  if (req.raster() != v1::RASTER_KIND_UNSPECIFIED && req.raster() != v1::RASTER_KIND_VISIBLE)
    return scope.status_of(make_error(ErrorCode::kInvalidArgument,
                                      "raster: many observers give the accumulate raster (leave raster unset)",
                                      "raster"));
  if (!v1::Accumulation_IsValid(req.accumulate()))
    return scope.status_of(make_error(ErrorCode::kInvalidArgument, "accumulate: unknown value", "accumulate"));
  auto geotiff_options = to_many_geotiff_options(req);
  if (!geotiff_options.ok()) return scope.status_of(geotiff_options.error());
  auto shared = to_viewshed_options(req.options(), 1);
  if (!shared.ok()) return scope.status_of(shared.error());
  scope.record().algorithm = std::string(visibility::algorithm_name(shared->algorithm));
  visibility::ManyObserversOptions options{.viewshed = *shared, .threads = env.config.engine_threads};

  // Each observer located on the header and its reach's cells bounded: the
  // union window and the work, before any read.
  std::vector<visibility::ObserverSite> sites(static_cast<std::size_t>(n));
  std::vector<geodesy::GridPoint> located_points;  // in the dataset's grid
  located_points.reserve(sites.size());
  terrain::Window window;
  std::uint64_t largest = 0, work = 0;
  for (int i = 0; i < n; ++i) {
    const v1::ObserverSite& in = req.observers(i);
    const std::string name = site_name(i);
    if (!in.has_point())
      return scope.status_of(make_error(ErrorCode::kInvalidArgument, name + ".point: required", name + ".point"));
    auto spec = to_point_spec(in.point(), name + ".point");
    if (!spec.ok()) return scope.status_of(spec.error());
    visibility::ObserverSite& site = sites[static_cast<std::size_t>(i)];
    site.point = *spec;
    site.max_distance = in.max_distance();
    if (!(std::isfinite(site.max_distance) && site.max_distance >= 0))
      return scope.status_of(make_error(ErrorCode::kInvalidArgument,
                                        name + ".max_distance: must be a finite number of metres >= 0",
                                        name + ".max_distance"));
    auto located = geodesy::locate_point(h.georef, h.width, h.height, *spec, (name + ".point").c_str(), d.name);
    if (!located.ok()) return scope.status_of(located.error());
    located_points.push_back(*located);
    const double reach = site.max_distance > 0 ? site.max_distance : shared->max_distance;
    const terrain::Window w = geodesy::cells_within(h.georef, h.width, h.height, *located, reach, 2);
    window = merged(window, w);
    largest = std::max(largest, w.cell_count());
    work += w.cell_count();
  }
  const std::uint64_t cells = window.cell_count();
  scope.record().cells = cells;
  if (cells > env.config.limits.max_cells)
    return scope.status_of(
        make_error(ErrorCode::kResourceExhausted,
                   "observers: their windows span " + std::to_string(cells) +
                       " cells, more than limits.max_cells = " + std::to_string(env.config.limits.max_cells) +
                       "; give smaller reaches (observers[].max_distance, options.max_distance) or closer observers",
                   "observers"));
  // The window's elevations (4 bytes a cell), the count and answered
  // rasters (5), the encodings; per thread one viewshed's buffers (9).
  const unsigned threads =
      std::min<unsigned>(resolve_thread_count(env.config.engine_threads), static_cast<unsigned>(std::max(n, 1)));
  const bool laid_out = geotiff_options->format == terrain::TiffFormat::kCog ||
                        geotiff_options->compression == terrain::TiffCompression::kNone;
  const std::uint64_t per_cell =
      4 + 5 + MemoryBudget::kEncodingBytesPerCell + (laid_out ? MemoryBudget::kLayoutBytesPerCell : 0);
  const std::uint64_t bytes = cells * per_cell + threads * largest * 9;
  if (auto s = scope.reserve(
          bytes, "this viewshed of " + std::to_string(n) + " observers (" + std::to_string(work) + " cells of work)");
      !s.ok())
    return scope.status_of(s.error());

  terrain::SourceReadStats read;
  auto dem = d.source->read(window, &env.cache, scope.control(), &read, env.config.engine_threads);
  if (!dem.ok()) return scope.status_of(dem.error());
  // Each site's ground, with a void named by its cell in the dataset's grid
  // (the plan below would name the window's).
  const terrain::Window& got = read.window;
  for (std::size_t i = 0; i < sites.size(); ++i) {
    geodesy::GridPoint p = located_points[i];
    p.col -= got.col0;
    p.row -= got.row0;
    const std::string name = "observers[" + std::to_string(i) + "].point";
    auto placed = geodesy::place_on_ground(*dem, p, sites[i].point, name.c_str(), got.col0, got.row0);
    if (!placed.ok()) return scope.status_of(placed.error());
  }
  auto plan = visibility::plan_many_observers(*dem, sites, options);
  if (!plan.ok()) return scope.status_of(as_request_field(plan.error()));
  auto res = visibility::compute_many_observers(*dem, *plan, scope.control());
  if (!res.ok()) return scope.status_of(as_request_field(res.error()));

  // The raster asked for, georeferenced in the dataset's grid.
  terrain::Georeference georef = h.georef;
  georef.transform = h.georef.transform.shifted(got.col0 + res->window.col0, got.row0 + res->window.row0);
  const auto any = visibility::seen_from_any(*res);
  const bool count = req.accumulate() == v1::ACCUMULATION_COUNT;
  const terrain::Grid<std::uint8_t> mask =
      req.accumulate() == v1::ACCUMULATION_ALL ? visibility::seen_from_all(*res) : any;
  const double nodata = count ? double{visibility::kNoCount} : double{visibility::kNoAnswer};
  terrain::Grid<std::uint32_t> counts;
  if (count) counts = visibility::observer_count(*res);
  out.row_bytes = static_cast<std::size_t>(res->window.width()) * (count ? sizeof(std::uint32_t) : 1);
  if (req.include_raster()) {
    if (count)
      copy_rows(counts, out.raster);
    else
      copy_rows(mask, out.raster);
  }
  if (req.include_geotiff()) {
    auto bytes_or = count ? geotiff_bytes(env.scratch, counts, georef, nodata, *geotiff_options)
                          : geotiff_bytes(env.scratch, mask, georef, nodata, &kCodeColours, *geotiff_options);
    if (!bytes_or.ok()) return scope.status_of(bytes_or.error());
    out.geotiff = std::move(*bytes_or);
  }
  if (req.include_png()) {
    const auto drawing = std::chrono::steady_clock::now();
    const terrain::Grid<float> crop = terrain::copy_cells(terrain::HeightView(dem->elevation).sub(res->window));
    const visibility::PreviewCaption caption{.dem = req.dataset(), .algorithm = scope.record().algorithm};
    const visibility::PreviewAccumulation shown = count ? visibility::PreviewAccumulation::kCount
                                                  : req.accumulate() == v1::ACCUMULATION_ALL
                                                      ? visibility::PreviewAccumulation::kAll
                                                      : visibility::PreviewAccumulation::kAny;
    auto png = png_bytes(env.scratch, [&](const std::string& p) {
      return visibility::write_many_observers_picture(p, *plan, *res, crop, shown, caption);
    });
    if (!png.ok()) return scope.status_of(png.error());
    out.png = std::move(*png);
    out.summary.set_preview_seconds(std::chrono::duration<double>(std::chrono::steady_clock::now() - drawing).count());
  }
  if (auto s = check_control(scope.control()); !s.ok()) return scope.status_of(s.error());

  v1::ViewshedHeader& header = out.header;
  header.set_width(res->window.width());
  header.set_height(res->window.height());
  const terrain::Window in_source{got.col0 + res->window.col0, got.row0 + res->window.row0, got.col0 + res->window.col1,
                                  got.row0 + res->window.row1};
  fill_window(in_source, *header.mutable_window());
  fill_transform(georef.transform, *header.mutable_transform());
  header.set_epsg(georef.epsg);
  header.set_raster(v1::RASTER_KIND_VISIBLE);
  header.set_sample_type(count ? v1::SAMPLE_TYPE_UINT32 : v1::SAMPLE_TYPE_UINT8);
  header.set_nodata(nodata);
  header.set_cell_size_x_m(plan->frames[0].metres_per_col);
  header.set_cell_size_y_m(plan->frames[0].metres_per_row);
  header.set_algorithm(scope.record().algorithm);
  header.set_backend("cpu");

  std::uint64_t seen = 0, hidden = 0, all = 0;
  const auto all_mask = visibility::seen_from_all(*res);
  for (std::size_t i = 0; i < any.size(); ++i) {
    seen += any.values()[i] == visibility::kVisible;
    hidden += any.values()[i] == visibility::kHidden;
    all += all_mask.values()[i] == visibility::kVisible;
  }
  v1::ViewshedSummary& summary = out.summary;
  summary.set_visible_cells(seen);
  summary.set_hidden_cells(hidden);
  summary.set_evaluated_cells(seen + hidden);
  summary.set_visible_area_km2(static_cast<double>(seen) * plan->frames[0].metres_per_col *
                               plan->frames[0].metres_per_row / 1e6);
  summary.set_seen_by_all_cells(all);
  v1::WorkStats& stats = *summary.mutable_stats();
  stats.set_seconds(res->seconds);
  stats.set_backend("cpu");
  stats.set_cells_evaluated(plan->work_cells);
  stats.set_dem_cells(static_cast<std::uint64_t>(h.width) * static_cast<std::uint64_t>(h.height));
  for (int i = 0; i < n; ++i) {
    const auto k = static_cast<std::size_t>(i);
    v1::ObserverSummary* o = summary.add_observers();
    geodesy::GridPoint p = plan->points[k];
    p.col += got.col0;  // in the dataset's grid
    p.row += got.row0;
    fill_point(p, h.georef, *o->mutable_point());
    o->set_answered_cells(res->observers[k].cells_answered);
    o->set_visible_cells(res->observers[k].cells_visible);
    o->set_seconds(res->observers[k].seconds);
    const visibility::ViewFrame& f = plan->frames[k];
    o->set_visible_area_km2(static_cast<double>(res->observers[k].cells_visible) * f.metres_per_col * f.metres_per_row /
                            1e6);
    if (std::isfinite(f.max_distance)) o->set_max_distance(f.max_distance);
  }
  return grpc::Status::OK;
}

}  // namespace horizon::server
