// `horizon viewshed DATASET --server HOST:PORT --observers FILE ...`: the
// daemon accumulates every observer's viewshed (ComputeViewshed with
// observers); this writes its GeoTIFF and PNG bytes, the --summary table
// from its per-observer lines, and prints embedded mode's report.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>
#include <iostream>

#include "commands/command.hpp"
#include "horizon/terrain/qgis_style.hpp"
#include "horizon/visibility/many_observers.hpp"
#include "horizon/visibility/viewshed_preview.hpp"
#include "output.hpp"
#include "progress.hpp"
#include "remote/client.hpp"
#include "remote/files.hpp"
#include "remote/module_abi.hpp"

namespace horizon::cli::remote {
namespace {

// The daemon names observers[i]; the user knows them by their file line or flag.
grpc::Status in_user_words(const grpc::Status& status, const std::vector<NamedObserver>& observers) {
  const std::string& m = status.error_message();
  return {status.error_code(), cli::in_user_words(m, m, observers), status.error_details()};
}

}  // namespace

int impl::run_viewshed_many(const Args& args, const ManyViewshedInputs& in) {
  Client client(args);
  const auto started = std::chrono::steady_clock::now();

  v1::Dataset dataset;
  if (auto s = client.get_dataset(in.dataset, dataset); !s.ok()) return report_status(s, client.address());

  v1::ViewshedRequest request;
  request.set_dataset(in.dataset);
  for (const NamedObserver& o : in.observers) {
    v1::ObserverSite* site = request.add_observers();
    *site->mutable_point() = to_proto_point(o.site.point);
    site->set_max_distance(o.site.max_distance);
  }
  fill_options(in.options, *request.mutable_options());
  request.set_accumulate(in.accumulate == "any"   ? v1::ACCUMULATION_ANY
                         : in.accumulate == "all" ? v1::ACCUMULATION_ALL
                                                  : v1::ACCUMULATION_COUNT);
  request.set_geotiff_format(to_proto_format(in.format));
  for (const std::string& item : in.creation_options) request.add_creation_options(item);
  request.set_include_geotiff(true);
  request.set_include_png(in.png_path.has_value());
  request.set_include_progress(true);  // the daemon's progress drives the bar, as embedded mode's does
  request.set_include_raster(in.accumulate == "count");  // for the largest count

  auto context = client.context();
  auto reader = client.visibility().ComputeViewshed(context.get(), request);
  v1::ViewshedResponse message;
  v1::ViewshedHeader header;
  v1::ViewshedSummary summary;
  std::string geotiff, png;
  std::uint32_t max_count = 0;
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
    if (message.has_raster_chunk()) {
      const std::string& d = message.raster_chunk().data();
      for (std::size_t k = 0; k + 4 <= d.size(); k += 4) {
        std::uint32_t v;
        std::memcpy(&v, d.data() + k, 4);
        if (v != visibility::kNoCount) max_count = std::max(max_count, v);
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
  if (auto s = reader->Finish(); !s.ok()) return report_status(in_user_words(s, in.observers), client.address());
  if (summary.observers_size() != static_cast<int>(in.observers.size()))
    return report_error(make_error(ErrorCode::kDataError, "the daemon's summary does not have a line per observer"));

  const visibility::PreviewAccumulation accumulation = in.accumulate == "any" ? visibility::PreviewAccumulation::kAny
                                                       : in.accumulate == "all"
                                                           ? visibility::PreviewAccumulation::kAll
                                                           : visibility::PreviewAccumulation::kCount;
  if (auto s = terrain::write_with_style(in.out_path, visibility::many_observers_style(accumulation, max_count),
                                         [&] { return write_file_atomic(in.out_path, geotiff); });
      !s.ok())
    return report_error(s.error());
  if (in.png_path)
    if (auto s = write_file_atomic(*in.png_path, png); !s.ok()) return report_error(s.error());
  if (in.summary_path) {
    std::vector<ObserverLine> lines;
    for (int i = 0; i < summary.observers_size(); ++i) {
      const v1::ObserverSummary& o = summary.observers(i);
      ObserverLine l;
      l.name = in.observers[static_cast<std::size_t>(i)].name;
      l.x = o.point().x();
      l.y = o.point().y();
      if (const auto ll = to_lonlat(o.point())) {
        l.lon = ll->lon;
        l.lat = ll->lat;
      }
      l.ground = o.point().ground();
      l.eye = o.point().elevation();
      if (o.has_max_distance()) l.max_distance = o.max_distance();
      l.cells_answered = o.answered_cells();
      l.cells_visible = o.visible_cells();
      l.visible_km2 = o.visible_area_km2();
      l.seconds = o.seconds();
      lines.push_back(std::move(l));
    }
    if (auto s = write_observer_summary(*in.summary_path, lines, dataset.geographic()); !s.ok())
      return report_error(s.error());
  }
  const double total_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();

  const terrain::Window window{header.window().col0(), header.window().row0(), header.window().col1(),
                               header.window().row1()};
  const std::uint64_t seen_any = summary.visible_cells(), seen_all = summary.seen_by_all_cells();
  const std::uint64_t answered = summary.evaluated_cells();
  const visibility::WorkStats stats = to_stats(summary.stats());
  if (in.json) {
    Json j;
    j["dem"] = in.dataset;
    j["output"] = in.out_path;
    j["accumulate"] = in.accumulate;
    j["png"] = in.png_path ? Json(*in.png_path) : Json(nullptr);
    j["style"] = terrain::qml_path_for(in.out_path);
    j["summary"] = in.summary_path ? Json(*in.summary_path) : Json(nullptr);
    j["algorithm"] = in.algorithm_name;
    j["observers"] = in.observers.size();
    j["window"] = to_json(window);
    j["cells_answered"] = answered;
    j["cells_seen_by_any"] = seen_any;
    j["cells_seen_by_all"] = seen_all;
    j["max_count"] = in.accumulate == "count" ? Json(max_count) : Json(nullptr);
    j["work_cells"] = stats.cells_evaluated;
    j["compute_seconds"] = stats.seconds;
    j["preview_seconds"] = in.png_path ? Json(summary.preview_seconds()) : Json(nullptr);
    j["total_seconds"] = total_seconds;
    j["server"] = {{"address", client.address()}, {"backend", header.backend()}};
    print_json(j);
    return kExitOk;
  }
  std::cout << "Viewshed of " << in.dataset << " on " << client.address() << " from "
            << with_separators(in.observers.size()) << " observers\n"
            << "  answered:   " << with_separators(answered) << " cells (window " << window.width() << "x"
            << window.height() << ")\n"
            << "  seen:       " << with_separators(seen_any) << " by at least one, " << with_separators(seen_all)
            << " by all";
  if (in.accumulate == "count") std::cout << "; at most " << max_count << " observers see one cell";
  std::cout << '\n'
            << "  work:       " << with_separators(stats.cells_evaluated) << " cells over all observers\n"
            << "  algorithm:  " << in.algorithm_name << '\n'
            << "  compute:    " << fixed(stats.seconds, 3) << " s on the daemon (" << fixed(total_seconds, 3)
            << " s in all)\n"
            << "  wrote:      " << in.out_path << " (" << in.accumulate << "), its QGIS style "
            << terrain::qml_path_for(in.out_path) << '\n';
  if (in.png_path)
    std::cout << "  preview:    " << *in.png_path << " (" << fixed(summary.preview_seconds(), 3)
              << " s on the daemon)\n";
  if (in.summary_path) std::cout << "  summary:    " << *in.summary_path << '\n';
  return kExitOk;
}

}  // namespace horizon::cli::remote
