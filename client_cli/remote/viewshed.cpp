// `horizon viewshed DATASET --server HOST:PORT ...`: the daemon computes, this
// writes its GeoTIFF (and PNG) bytes and prints embedded mode's summary.
#include <chrono>
#include <cmath>
#include <cstring>
#include <iostream>
#include <limits>

#include "commands/command.hpp"
#include "horizon/terrain/qgis_style.hpp"
#include "horizon/visibility/viewshed_preview.hpp"
#include "output.hpp"
#include "progress.hpp"
#include "remote/client.hpp"
#include "remote/files.hpp"
#include "remote/module_abi.hpp"

namespace horizon::cli::remote {

int impl::run_viewshed(const Args& args, const ViewshedInputs& in) {
  Client client(args);
  const auto started = std::chrono::steady_clock::now();

  v1::Dataset dataset;
  if (auto s = client.get_dataset(in.dataset, dataset); !s.ok()) return report_status(s, client.address());

  v1::ViewshedRequest request;
  request.set_dataset(in.dataset);
  *request.mutable_observer() = to_proto_point(in.observer);
  v1::ViewshedOptions& o = *request.mutable_options();
  fill_options(in.options, o);
  o.set_backend(to_proto_backend(in.options.backend));
  if (in.options.gpu) {  // absent: the daemon's measured fastest variant
    o.set_gpu_method(to_proto_gpu_method(in.options.gpu->method));
    o.set_gpu_log_step(in.options.gpu->log_step);
  }
  const RasterFlags& raster = in.raster;
  request.set_raster(to_proto_raster(raster.output));
  if (raster.output == visibility::ViewshedOutput::kVisibility) {
    v1::ValueCodes& codes = *request.mutable_codes();
    codes.set_visible(raster.codes.visible);
    codes.set_hidden(raster.codes.hidden);
    codes.set_out_of_range(raster.codes.out_of_range);
  }
  if (raster.output_nodata) request.set_output_nodata(*raster.output_nodata);
  request.set_geotiff_format(to_proto_format(in.format));
  for (const std::string& item : in.creation_options) request.add_creation_options(item);
  request.set_include_geotiff(true);
  request.set_include_raster(!visibility::is_code_raster(raster.output));  // the values' range, for the QGIS style
  request.set_include_png(in.png_path.has_value());
  request.set_include_progress(true);  // the daemon's progress drives the bar, as embedded mode's does

  auto context = client.context();
  auto reader = client.visibility().ComputeViewshed(context.get(), request);
  v1::ViewshedResponse message;
  v1::ViewshedHeader header;
  v1::ViewshedSummary summary;
  std::string geotiff, png;
  double low = std::numeric_limits<double>::infinity(), high = -low;
  ProgressBar progress("horizon viewshed on " + client.address());
  while (reader->Read(&message)) {
    if (message.has_progress()) {
      progress.update(message.progress().fraction());
      continue;
    }
    if (message.has_header()) {
      progress.finish();
      header = message.header();
    }
    if (message.has_summary()) summary = message.summary();
    if (message.has_raster_chunk() && header.sample_type() == v1::SAMPLE_TYPE_FLOAT32) {
      const std::string& d = message.raster_chunk().data();
      for (std::size_t k = 0; k + 4 <= d.size(); k += 4) {
        float v;
        std::memcpy(&v, d.data() + k, 4);
        if (std::isfinite(v)) {
          low = std::min(low, double{v});
          high = std::max(high, double{v});
        }
      }
    }
    if (message.has_file_chunk()) {
      const v1::FileChunk& c = message.file_chunk();
      std::string& file = c.kind() == v1::FileChunk::KIND_PNG ? png : geotiff;
      if (c.offset() != file.size()) {
        context->TryCancel();
        reader->Finish();
        return report_error(make_error(ErrorCode::kDataError, "the daemon sent file bytes out of order"));
      }
      file += c.data();
    }
  }
  if (auto s = reader->Finish(); !s.ok()) return report_status(s, client.address());

  if (!std::isfinite(low)) low = high = 0.0;
  const std::string style = visibility::is_code_raster(raster.output)
                                ? visibility::visibility_style(raster.codes)
                                : visibility::viewshed_style(visibility::preview_raster(raster.output), low, high);
  if (auto s = terrain::write_with_style(in.out_path, style, [&] { return write_file_atomic(in.out_path, geotiff); });
      !s.ok())
    return report_error(s.error());
  if (in.png_path)
    if (auto s = write_file_atomic(*in.png_path, png); !s.ok()) return report_error(s.error());
  const double total_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();

  const geodesy::GridPoint observer = to_grid_point(header.observer());
  const auto observer_lonlat = to_lonlat(header.observer());
  const visibility::WorkStats stats = to_stats(summary.stats());
  warn_gpu_fallback(stats);  // the daemon's GPU failed or it has none; its CPU answered
  const terrain::Window window{header.window().col0(), header.window().row0(), header.window().col1(),
                               header.window().row1()};
  const std::uint64_t visible = summary.visible_cells(), hidden = summary.hidden_cells();
  const std::uint64_t evaluated = summary.evaluated_cells();
  const double area_km2 = summary.visible_area_km2();
  const double percent = evaluated ? 100.0 * static_cast<double>(visible) / static_cast<double>(evaluated) : 0.0;

  if (in.json) {
    Json j;
    j["dem"] = in.dataset;
    j["output"] = in.out_path;
    j["output_kind"] = raster.name;
    j["codes"] = visibility::is_code_raster(raster.output) ? to_json(raster.codes) : Json(nullptr);
    j["png"] = in.png_path ? Json(*in.png_path) : Json(nullptr);
    j["style"] = terrain::qml_path_for(in.out_path);
    j["algorithm"] = in.algorithm_name;
    j["observer"] = to_json(observer, observer_lonlat);
    j["options"] = viewshed_options_json(in.observer, in.options, args.text("--nodata").value_or("transparent"));
    j["window"] = to_json(window);
    j["cell_size_m"] = {{"x", header.cell_size_x_m()}, {"y", header.cell_size_y_m()}};
    j["visible_cells"] = visible;
    j["hidden_cells"] = hidden;
    j["evaluated_cells"] = evaluated;
    j["visible_area_km2"] = area_km2;
    j["visible_percent"] = percent;
    j["stats"] = to_json(stats);
    j["server"] = {{"address", client.address()}, {"backend", header.backend()}};
    j["preview_seconds"] = in.png_path ? Json(summary.preview_seconds()) : Json(nullptr);
    j["total_seconds"] = total_seconds;
    print_json(j);
    return kExitOk;
  }

  const bool geographic = dataset.geographic();
  std::cout << "Viewshed of " << in.dataset << " on " << client.address() << '\n'
            << "  observer:   x " << coordinate(observer.x, geographic) << ", y " << coordinate(observer.y, geographic);
  if (observer_lonlat && !geographic)
    std::cout << " (lon " << fixed(observer_lonlat->lon, 6) << ", lat " << fixed(observer_lonlat->lat, 6) << ")";
  std::cout << ", eye " << fixed(observer.elevation, 1) << " m ("
            << (std::isnan(observer.ground) ? std::string("ground: no data")
                                            : "ground " + fixed(observer.ground, 1) + " m")
            << ")\n"
            << "  visible:    " << with_separators(visible) << " cells, " << fixed(area_km2, 3) << " km² ("
            << fixed(percent, 1) << " % of " << with_separators(evaluated) << " evaluated)\n"
            << "  evaluated:  " << with_separators(stats.cells_evaluated) << " cells of "
            << with_separators(stats.dem_cells) << " in the DEM (window " << window.width() << "x" << window.height()
            << ")\n"
            << "  algorithm:  " << in.algorithm_name
            << (in.options.algorithm == visibility::Algorithm::kRadial
                    ? " (radial occlusion height field, ray spacing " + fixed(in.options.radial.ray_spacing, 2) + ")"
                    : std::string(""))
            << (stats.backend == "gpu" ? " on the GPU" : "") << '\n'
            << "  compute:    " << fixed(stats.seconds, 3) << " s on the daemon (" << fixed(total_seconds, 3)
            << " s in all)\n"
            << "  wrote:      " << in.out_path << " (" << raster.name << "), its QGIS style "
            << terrain::qml_path_for(in.out_path) << '\n';
  if (in.png_path)
    std::cout << "  preview:    " << *in.png_path << " (" << fixed(summary.preview_seconds(), 3)
              << " s on the daemon)\n";
  return kExitOk;
}

}  // namespace horizon::cli::remote
