// `horizon viewshed DEM --observers FILE ...` (or --observer repeated): many
// observers accumulated into one raster, and a per-observer table.
#include "commands/viewshed_many.hpp"

#include <unistd.h>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <iostream>

#include "commands/command.hpp"
#include "commands/viewshed_flags.hpp"
#include "horizon/imageio/imageio.hpp"
#include "horizon/terrain/geotiff_writer.hpp"
#include "horizon/terrain/height_view.hpp"
#include "horizon/terrain/preview.hpp"
#include "horizon/terrain/qgis_style.hpp"
#include "horizon/terrain/source.hpp"
#include "horizon/visibility/many_observers.hpp"
#include "horizon/visibility/viewshed_preview.hpp"
#include "inputs.hpp"
#include "interrupt.hpp"
#include "observers_file.hpp"
#include "output.hpp"
#include "progress.hpp"
#include "remote/remote.hpp"

namespace horizon::cli {
namespace {

constexpr std::string_view kAccumulations[] = {"count", "any", "all"};
constexpr std::string_view kManyAlgorithms[] = {"fast", "exact", "conservative", "r3"};

struct ManyRequest {
  std::string dem_path, out_path, accumulate = "count";
  std::optional<std::string> png_path, summary_path;
  std::vector<NamedObserver> observers;
  visibility::ManyObserversOptions options;
  GeoTiffFlags geotiff;
  std::string algorithm_name = "fast";
  bool json = false;
};

// "X,Y" of one --observer value.
geodesy::PointSpec point_of(const std::string& text, std::size_t index) {
  const CsvNumbers n = parse_csv_numbers(text);
  if (n.blank || !n.numeric || n.values.size() != 2)
    throw UsageError("--observer (" + std::to_string(index + 1) + "): expected X,Y, got '" + text + "'");
  geodesy::PointSpec p;
  p.x = n.values[0];
  p.y = n.values[1];
  return p;
}

ManyRequest parse_many(const Args& args) {
  // What places, or only makes sense for, one observer.
  for (std::string_view flag : {"--lat", "--lon"})
    if (args.has(flag))
      throw UsageError(std::string(flag) +
                       ": places one observer; with many, put WGS84 points in --observers FILE (a 'lon,lat' header "
                       "or GeoJSON)");
  for (std::string_view flag : {"--observer-x", "--observer-y"})
    if (args.has(flag))
      throw UsageError(args.typed(flag) +
                       ": places one observer; with many, repeat --observer X,Y or give "
                       "--observers FILE");
  for (std::string_view flag : {"--output", "--visible-value", "--hidden-value", "--out-of-range-value",
                                "--output-nodata", "--backend", "--gpu-method", "--gpu-propagation", "--full-read"})
    if (args.has(flag))
      throw UsageError(args.typed(flag) +
                       ": not with many observers (they run on the CPU and write the --accumulate raster)");

  ManyRequest r;
  r.dem_path = single_operand(args, "DEM");
  r.json = args.has("--json");
  if (args.has("--height") && args.has("--altitude"))
    throw UsageError(args.typed("--height") + " and --altitude both set the eyes; give one of them");
  const geodesy::HeightMode mode =
      args.has("--altitude") ? geodesy::HeightMode::kAbsolute : geodesy::HeightMode::kAboveGround;
  const double height =
      args.has("--altitude") ? *args.number("--altitude") : args.non_negative("--height").value_or(2.0);

  const geodesy::GroundSample ground = observer_ground(args);

  visibility::ViewshedOptions& o = r.options.viewshed;
  o = shared_viewshed_options(args);
  if (auto algorithm = args.choice("--algorithm", kManyAlgorithms)) r.algorithm_name = *algorithm;
  o.algorithm = *visibility::parse_algorithm(r.algorithm_name);
  // --threads is how many observers run at once; each viewshed runs on one.
  r.options.threads = o.threads;
  throw_if_invalid_option(visibility::validate_options(o), &args);
  if (auto a = args.choice("--accumulate", kAccumulations)) r.accumulate = *a;
  (void)source_options(args);
  r.geotiff = geotiff_flags(args);

  const std::vector<std::string> points = args.all("--observer");
  for (std::size_t i = 0; i < points.size(); ++i) {
    NamedObserver n;
    n.site.point = point_of(points[i], i);
    n.site.point.height = height;
    n.site.point.height_mode = mode;
    n.site.point.ground = ground;
    n.name = "--observer " + points[i];
    r.observers.push_back(std::move(n));
  }
  if (auto file = args.text("--observers")) {
    auto more = read_observers_file(*file, height, mode, 0.0);
    for (NamedObserver& n : more) n.site.point.ground = ground;
    r.observers.insert(r.observers.end(), std::make_move_iterator(more.begin()), std::make_move_iterator(more.end()));
  }

  auto out = args.text("--out");
  if (!out) throw UsageError("missing -o OUT.tif (the GeoTIFF to write)");
  r.out_path = *out;
  r.png_path = args.text("--png");
  r.summary_path = args.text("--summary");
  if (r.png_path && same_file(*r.png_path, r.out_path))
    throw UsageError("--png: '" + *r.png_path + "' is also the -o output; give two different files");
  if (r.summary_path &&
      (same_file(*r.summary_path, r.out_path) || (r.png_path && same_file(*r.summary_path, *r.png_path))))
    throw UsageError("--summary: '" + *r.summary_path + "' is also another output; give different files");
  return r;
}

// An engine error about observers[i], said with the observer's own name.
Error in_user_words(Error e, const std::vector<NamedObserver>& observers) {
  e.message = in_user_words(e.field, e.message, observers);
  return e;
}

// The per-observer table's lines, from the plan and the result.
std::vector<ObserverLine> summary_lines(const terrain::Dem& dem, const visibility::ManyObserversPlan& plan,
                                        const visibility::ManyObserversResult& res,
                                        const std::vector<NamedObserver>& observers) {
  std::vector<ObserverLine> lines;
  for (std::size_t i = 0; i < observers.size(); ++i) {
    const geodesy::GridPoint& p = plan.points[i];
    const visibility::ViewFrame& f = plan.frames[i];
    const visibility::ObserverSummary& s = res.observers[i];
    ObserverLine l;
    l.name = observers[i].name;
    l.x = p.x;
    l.y = p.y;
    l.ground = p.ground;
    l.eye = p.elevation;
    if (const auto ll = lonlat_of(dem, p.x, p.y)) {
      l.lon = ll->lon;
      l.lat = ll->lat;
    }
    if (std::isfinite(f.max_distance)) l.max_distance = f.max_distance;
    l.cells_answered = s.cells_answered;
    l.cells_visible = s.cells_visible;
    l.visible_km2 = static_cast<double>(s.cells_visible) * f.metres_per_col * f.metres_per_row / 1e6;
    l.seconds = s.seconds;
    lines.push_back(std::move(l));
  }
  return lines;
}

visibility::PreviewAccumulation preview_accumulation(const std::string& accumulate) {
  return accumulate == "any"   ? visibility::PreviewAccumulation::kAny
         : accumulate == "all" ? visibility::PreviewAccumulation::kAll
                               : visibility::PreviewAccumulation::kCount;
}

}  // namespace

bool wants_many_observers(const Args& args) {
  return args.count("--observer") > 1 || args.has("--observers");
}

void refuse_many_flags(const Args& args) {
  for (std::string_view flag : {"--accumulate", "--summary"})
    if (args.has(flag))
      throw UsageError(std::string(flag) + ": only with many observers (--observers FILE, or --observer repeated)");
}

int run_many_observers(const Args& args) {
  const ManyRequest r = parse_many(args);
  if (auto s = check_output_path(r.out_path, "-o", r.dem_path, {".tif", ".tiff"}); !s.ok())
    return report_error(s.error());
  if (r.summary_path)
    if (auto s = check_output_path(*r.summary_path, "--summary", r.dem_path, {".csv"}); !s.ok())
      return report_error(s.error());
  if (r.png_path) {
    if (auto s = check_output_path(*r.png_path, "--png", r.dem_path, {".png"}); !s.ok()) return report_error(s.error());
    if (auto plugin = imageio::plugin_path(); !plugin.ok()) return report_error(plugin.error());
  }

  if (args.has("--server"))  // DEM is a dataset name; the daemon computes
    return remote::run_viewshed_many(args, {.dataset = r.dem_path,
                                            .out_path = r.out_path,
                                            .accumulate = r.accumulate,
                                            .png_path = r.png_path,
                                            .summary_path = r.summary_path,
                                            .observers = r.observers,
                                            .options = r.options.viewshed,
                                            .format = r.geotiff.options.format,
                                            .creation_options = r.geotiff.creation_options,
                                            .algorithm_name = r.algorithm_name,
                                            .json = r.json});

  const auto started = std::chrono::steady_clock::now();
  auto source = terrain::ElevationSource::open(r.dem_path, source_options(args));
  if (!source.ok()) return report_error(source.error());
  auto dem = (*source)->read({0, 0, (*source)->width(), (*source)->height()}, nullptr);
  if (!dem.ok()) return report_error(dem.error());
  std::vector<visibility::ObserverSite> sites;
  sites.reserve(r.observers.size());
  for (const NamedObserver& o : r.observers) sites.push_back(o.site);
  auto plan = visibility::plan_many_observers(*dem, sites, r.options);
  if (!plan.ok()) return report_error(in_user_words(plan.error(), r.observers));

  InterruptScope interrupt;
  RunControl control;
  control.cancel = &interrupt.token();
  ProgressBar progress("horizon viewshed (" + std::to_string(sites.size()) + " observers)");
  control.progress = progress.callback();
  auto res = visibility::compute_many_observers(*dem, *plan, &control);
  progress.finish();
  if (!res.ok()) return report_error(in_user_words(res.error(), r.observers));

  terrain::Georeference georef = dem->georef;
  georef.transform = dem->georef.transform.shifted(res->window.col0, res->window.row0);
  const terrain::Grid<std::uint8_t> any = visibility::seen_from_any(*res);
  const terrain::Grid<std::uint8_t> all = visibility::seen_from_all(*res);
  std::uint32_t max_count = 0;
  for (std::uint32_t c : res->count.values()) max_count = std::max(max_count, c);
  const terrain::GeoTiffOptions& layout = r.geotiff.options;
  const Status written = terrain::write_with_style(
      r.out_path, visibility::many_observers_style(preview_accumulation(r.accumulate), max_count), [&] {
        return r.accumulate == "count"
                   ? terrain::write_geotiff(r.out_path, visibility::observer_count(*res), georef,
                                            double{visibility::kNoCount}, layout)
                   : terrain::write_geotiff(r.out_path, r.accumulate == "all" ? all : any, georef,
                                            double{visibility::kNoAnswer}, visibility::code_colour_table(), layout);
      });
  if (!written.ok()) return report_error(written.error());
  double preview_seconds = 0.0;
  if (r.png_path) {
    const auto drawing = std::chrono::steady_clock::now();
    const terrain::Grid<float> crop = terrain::copy_cells(terrain::HeightView(dem->elevation).sub(res->window));
    const visibility::PreviewCaption caption{.dem = visibility::dem_label(r.dem_path), .algorithm = r.algorithm_name};
    if (auto s = visibility::write_many_observers_picture(*r.png_path, *plan, *res, crop,
                                                          preview_accumulation(r.accumulate), caption);
        !s.ok())
      return report_error(s.error());
    preview_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - drawing).count();
  }
  if (r.summary_path)
    if (auto s =
            write_observer_summary(*r.summary_path, summary_lines(*dem, *plan, *res, r.observers), is_geographic(*dem));
        !s.ok())
      return report_error(s.error());
  const double total_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();

  std::uint64_t seen_any = 0, seen_all = 0, answered = 0;
  for (std::size_t i = 0; i < any.size(); ++i) {
    seen_any += any.values()[i] == visibility::kVisible;
    seen_all += all.values()[i] == visibility::kVisible;
    answered += any.values()[i] != visibility::kNoAnswer;
  }
  if (r.json) {
    Json j;
    j["dem"] = r.dem_path;
    j["output"] = r.out_path;
    j["accumulate"] = r.accumulate;
    j["png"] = r.png_path ? Json(*r.png_path) : Json(nullptr);
    j["style"] = terrain::qml_path_for(r.out_path);
    j["summary"] = r.summary_path ? Json(*r.summary_path) : Json(nullptr);
    j["algorithm"] = r.algorithm_name;
    j["observers"] = sites.size();
    j["window"] = to_json(res->window);
    j["cells_answered"] = answered;
    j["cells_seen_by_any"] = seen_any;
    j["cells_seen_by_all"] = seen_all;
    j["max_count"] = max_count;
    j["work_cells"] = plan->work_cells;
    j["threads"] = plan->threads;
    j["planned_bytes"] = plan->bytes;
    j["compute_seconds"] = res->seconds;
    j["preview_seconds"] = r.png_path ? Json(preview_seconds) : Json(nullptr);
    j["total_seconds"] = total_seconds;
    print_json(j);
    return kExitOk;
  }
  std::cout << "Viewshed of " << r.dem_path << " from " << with_separators(sites.size()) << " observers\n"
            << "  answered:   " << with_separators(answered) << " cells (window " << res->window.width() << "x"
            << res->window.height() << ")\n"
            << "  seen:       " << with_separators(seen_any) << " by at least one, " << with_separators(seen_all)
            << " by all; at most " << max_count << " observers see one cell\n"
            << "  work:       " << with_separators(plan->work_cells) << " cells over all observers, " << plan->threads
            << " threads, " << fixed(static_cast<double>(plan->bytes) / (1 << 20), 1) << " MiB planned\n"
            << "  algorithm:  " << r.algorithm_name << '\n'
            << "  compute:    " << fixed(res->seconds, 3) << " s (" << fixed(total_seconds, 3) << " s in all)\n"
            << "  wrote:      " << r.out_path << " (" << r.accumulate << "), its QGIS style "
            << terrain::qml_path_for(r.out_path) << '\n';
  if (r.png_path) std::cout << "  preview:    " << *r.png_path << " (" << fixed(preview_seconds, 3) << " s)\n";
  if (r.summary_path) std::cout << "  summary:    " << *r.summary_path << '\n';
  return kExitOk;
}

}  // namespace horizon::cli
