// `horizon viewshed DEM ...`: flags -> ViewshedOptions, result -> GeoTIFF, PNG, summary.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <iostream>
#include <memory>
#include <optional>
#include <string_view>
#include <vector>

#include "commands/command.hpp"
#include "commands/viewshed_flags.hpp"
#include "commands/viewshed_many.hpp"
#include "commands/viewshed_raster.hpp"
#include "horizon/common/kernels.hpp"
#include "horizon/common/parallel.hpp"
#include "horizon/gpu/context_pool.hpp"
#include "horizon/imageio/imageio.hpp"
#include "horizon/terrain/dem_reader.hpp"
#include "horizon/terrain/geotiff_writer.hpp"
#include "horizon/terrain/preview.hpp"
#include "horizon/terrain/qgis_style.hpp"
#include "horizon/terrain/source.hpp"
#include "horizon/visibility/plan.hpp"
#include "horizon/visibility/viewshed.hpp"
#include "horizon/visibility/viewshed_preview.hpp"
#include "inputs.hpp"
#include "interrupt.hpp"
#include "output.hpp"
#include "progress.hpp"
#include "remote/remote.hpp"

namespace horizon::cli {
namespace {

constexpr FlagSpec kFlags[] = {
    {"--observer", "", "X,Y", "Observer in the DEM's CRS (metres or degrees, as the DEM); repeat for many observers",
     true},
    {"--observer-x", "-ox", "X", "Observer x in the DEM's CRS (with --observer-y): gdal_viewshed's spelling"},
    {"--observer-y", "-oy", "Y", "Observer y in the DEM's CRS (with --observer-x)"},
    {"--observers", "", "FILE",
     "Many observers: CSV x,y[,height[,max_distance]] (a 'lon,lat' header for WGS84) or GeoJSON points"},
    {"--accumulate", "", "KIND",
     "Many observers: 'count' (UInt32 observers seeing each cell, default), 'any' or 'all' (UInt8 1/0/255)"},
    {"--summary", "", "FILE.csv", "Many observers: a table of each observer's visible cells, area and time"},
    {"--lat", "", "LAT", "Observer latitude, WGS84 degrees (with --lon)"},
    {"--lon", "", "LON", "Observer longitude, WGS84 degrees (with --lat)"},
    {"--height", "-oz", "M", "Observer eye height above the ground, metres (default 2)"},
    {"--altitude", "", "M", "Observer eye altitude, absolute metres (instead of --height)"},
    {"--observer-ground", "", "HOW",
     "The ground --height stands on: 'bilinear' (default: between the four nearest cell centres, the surface "
     "sight lines are tested against) or 'cell' (the value of the observer's cell, as gdal_viewshed and "
     "r.viewshed take it)"},
    {"--target-height", "-tz", "M", "Height above ground of the points looked at, metres (default 0)"},
    {"--max-distance", "-md", "M", "Ground distance limit, metres; 0 or 'none': no limit (default: the whole DEM)"},
    {"--curvature", "-cc", "C",
     "GDAL's curvature coefficient: 1 - refraction (default 0.85714; 0: a flat earth, 1: no refraction)"},
    {"--refraction", "", "K",
     "GRASS r.viewshed's refraction coefficient instead of --curvature, in [-1, 1] (0.14286 = --curvature "
     "0.85714)"},
    {"--azimuth", "", "START,END",
     "Field of view: degrees clockwise from grid north, START clockwise to END (300,60 wraps through north; "
     "default: all round). r.viewshed's direction_range A,B counts counter-clockwise from east: it is 90-B,90-A "
     "here"},
    {"--min-distance", "", "M", "Field of view: cells nearer than M ground metres are out of range (default 0)"},
    {"--pitch", "", "MIN,MAX",
     "Field of view: the ground's angle above the horizontal as the eye sees it, degrees in [-90, 90]; cells "
     "outside are out of range (default -90,90)"},
    {"--nodata", "", "POLICY", "Voids: 'transparent' (default, never block) or 'fill:H' (terrain at H metres)"},
    {"--algorithm", "", "ALG",
     "'fast' (radial occlusion height field, default), 'exact' (R3's answers, faster), 'conservative' (never hides "
     "what R3 sees) or 'r3' (the exact reference, slow)"},
    {"--ray-spacing", "", "S", "fast: ray spacing in cells, (0, 4], default 1; smaller is slower, closer to r3"},
    {"--backend", "", "B",
     "Where fast runs: 'auto' (default; the CPU here: the GPU is chosen by measured speed in horizond), 'cpu' or 'gpu' "
     "(fast only; if the GPU fails the CPU answers, with a warning)"},
    {"--gpu-method", "", "M", "On the GPU: 'fragment' (render passes, default) or 'compute' (compute shaders)"},
    {"--gpu-propagation", "", "P",
     "On the GPU: 'log-step' (shift doubling, log2 N passes, default) or 'one-step' (N one-cell passes); same result"},
    {"--threads", "", "N", "Worker threads (default 0 = all cores)"},
    {"--isa", "", "SET",
     "Cap the CPU's SIMD kernels at 'scalar', 'avx2' or 'avx512' (default: the best it has); same answers, "
     "other times"},
    {"--output", "-om", "KIND",
     "Raster written: 'visible' (default), 'boolean', 'ohf', 'min-target-height', 'vertical-angle' or "
     "'elevation-difference' (gdal_viewshed's NORMAL, DEM, GROUND: visible, ohf, min-target-height)"},
    {"--visible-value", "-vv", "N", "visible: the code of visible cells, 0-255 (default 1)"},
    {"--hidden-value", "-iv", "N", "visible: the code of hidden cells (default 0)"},
    {"--out-of-range-value", "-ov", "N",
     "visible: the code of cells beyond --max-distance or outside the field of view (default 255)"},
    {"--output-nodata", "-a_nodata", "V",
     "The value of cells without an answer (voids; in float rasters every one) and the file's nodata: a code for "
     "visible and boolean (default 255), a number or 'nan' for the others (default: the DEM's nodata, else NaN)"},
    {"--out", "-o", "OUT.tif", "GeoTIFF to write (required)"},
    {"--format", "-f -of", "FORMAT",
     "The GeoTIFF's layout: 'GTiff' (default) or 'COG' (Cloud-Optimised, with overviews), as GDAL names them"},
    {"--co", "-co", "NAME=VALUE",
     "A creation option as GDAL's GTiff and COG drivers spell it (COMPRESS=ZSTD, PREDICTOR=2, TILED=NO, "
     "BLOCKSIZE=256, BIGTIFF=YES, ...); repeatable",
     true},
    {"--png", "", "PREVIEW.png",
     "Also write a PNG preview: the result over a hillshade (a colour ramp for ohf, min-target-height and count), "
     "with a title, legend, scale bar and north arrow"},
    {"--band", "-b", "N", "DEM band to read, 1-based (required when the file has several)"},
    kValidRangeFlag,
    {"--json", "", "", "Print the summary as a JSON document"},
    remote::kServerFlag,
    remote::kDeadlineFlag,
    remote::kCaFlag,
    remote::kClientCertFlag,
    remote::kTokenFileFlag,
    {"--full-read", "", "",
     "Read the whole DEM even with --max-distance (by default only the tiles within reach are read)"},
};

constexpr std::string_view kAlgorithms[] = {"fast", "exact", "conservative", "r3"};
constexpr std::string_view kBackends[] = {"auto", "cpu", "gpu"};
constexpr std::string_view kGpuMethods[] = {"fragment", "compute"};
constexpr std::string_view kGpuPropagations[] = {"log-step", "one-step"};
constexpr std::string_view kKernelSets[] = {"scalar", "avx2", "avx512"};

// --isa caps this process's kernels (common/kernels.hpp). With --server the
// daemon computes, on its own machine's kernels.
void apply_kernel_cap(const Args& args) {
  const auto isa = args.choice("--isa", kKernelSets);
  if (!isa) return;
  if (args.has("--server")) throw UsageError("--isa caps this machine's kernels; with --server the daemon computes");
  limit_kernel_set(*parse_kernel_set(*isa));
}

struct Request {
  std::string dem_path;
  std::string out_path;
  std::optional<std::string> png_path;
  geodesy::PointSpec observer;
  visibility::ViewshedOptions options;
  GeoTiffFlags geotiff;
  RasterFlags raster;
  std::string algorithm_name = "fast";
  bool json = false;
  bool full_read = false;
};

// Every flag is read and checked here, before the DEM is opened.
Request parse_request(const Args& args) {
  Request r;
  r.dem_path = single_operand(args, "DEM");
  r.json = args.has("--json");
  r.full_read = args.has("--full-read");

  r.observer = observer_point(args);
  if (args.has("--height") && args.has("--altitude"))
    throw UsageError(args.typed("--height") + " and --altitude both set the eye; give one of them");
  if (auto altitude = args.number("--altitude")) {
    r.observer.height = *altitude;
    r.observer.height_mode = geodesy::HeightMode::kAbsolute;
  } else {
    r.observer.height = args.non_negative("--height").value_or(2.0);
    r.observer.height_mode = geodesy::HeightMode::kAboveGround;
  }
  r.observer.ground = observer_ground(args);

  r.options = shared_viewshed_options(args);
  visibility::ViewshedOptions& o = r.options;
  if (auto algorithm = args.choice("--algorithm", kAlgorithms)) r.algorithm_name = *algorithm;
  o.algorithm = *visibility::parse_algorithm(r.algorithm_name);
  if (auto backend = args.choice("--backend", kBackends)) o.backend = *visibility::parse_backend(*backend);
  // Either flag names the variant (the other at its default); neither: the device's measured fastest.
  const auto method = args.choice("--gpu-method", kGpuMethods);
  const auto propagation = args.choice("--gpu-propagation", kGpuPropagations);
  if (method || propagation) {
    o.gpu.emplace();
    if (method) o.gpu->method = *visibility::parse_gpu_method(*method);
    if (propagation) o.gpu->log_step = *propagation == "log-step";
  }
  r.raster = raster_flags(args);
  // Only the visible/hidden raster is written: exact may skip finding R3's OHF.
  o.visibility_only = !visibility::needs_heights(r.raster.output);
  // A code raster needs only the mask: the fast sweep then codes the cells itself.
  o.mask_only = visibility::is_code_raster(r.raster.output);
  (void)source_options(args);  // a malformed --band or --valid-range is a usage error before any reading
  // The engine owns the ranges (max distance > 0, curvature in [0, 2], ...);
  // asking it now makes a bad value a usage error that names the flag.
  throw_if_invalid_option(visibility::validate_options(o), &args);
  r.geotiff = geotiff_flags(args);

  auto out = args.text("--out");
  if (!out) throw UsageError("missing -o OUT.tif (the GeoTIFF to write)");
  r.out_path = *out;
  r.png_path = args.text("--png");
  if (r.png_path && same_file(*r.png_path, r.out_path))
    throw UsageError("--png: '" + *r.png_path + "' is also the -o output; give two different files");
  return r;
}

// Where a run's wall time went, in seconds, from the process's first look
// at the DEM to its summary (--json "phases"; the text summary's last line).
// What the process spends starting and exiting lies outside: a whole-process
// timing minus total_seconds gives it (docs/benchmarks.md, "Where the whole
// process goes").
struct Phases {
  double open = 0.0;     // the DEM's header opened and the request planned on it
  double read = 0.0;     // the planned blocks decoded (the engine's SourceReadStats)
  double compute = 0.0;  // the algorithm (WorkStats::seconds)
  double mask = 0.0;     // the output raster's values and the counts' codes (none left when the sweep coded them)
  double encode = 0.0;   // the GeoTIFF (and COG overviews) encoded and written, its style beside it
  double preview = 0.0;  // the PNG, when asked for
};

double seconds_since(std::chrono::steady_clock::time_point since) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - since).count();
}

// The raster asked for, written atomically by the engine's writer, and its
// QGIS style beside it (terrain::write_with_style): codes with the
// previews' colour table in the file, or a ramp over the values written.
// `mask` is the result in the default codes (visibility_mask), written as
// it is when those are the codes asked for.
Status write_output(const Request& r, const terrain::Dem& dem, const visibility::ViewshedRun& run,
                    const terrain::Grid<std::uint8_t>& mask, Phases& phases) {
  const visibility::ViewshedResult& result = run.result;
  const terrain::Georeference& georef = run.georef;
  const RasterFlags& raster = r.raster;
  auto at = std::chrono::steady_clock::now();
  if (visibility::is_code_raster(raster.output)) {
    const visibility::ValueCodes& codes = raster.codes;
    std::optional<terrain::Grid<std::uint8_t>> recoded;
    if (codes != visibility::ValueCodes{})
      recoded = visibility::visibility_codes(result, r.options.target_height, codes, r.options.threads);
    const terrain::Grid<std::uint8_t>& values = recoded ? *recoded : mask;
    phases.mask += seconds_since(at);
    at = std::chrono::steady_clock::now();
    HORIZON_RETURN_IF_ERROR(terrain::write_with_style(r.out_path, visibility::visibility_style(codes), [&] {
      return terrain::write_geotiff(r.out_path, values, georef, static_cast<double>(codes.nodata),
                                    visibility::code_colour_table(codes), r.geotiff.options);
    }));
    phases.encode = seconds_since(at);
    return Status::Ok();
  }
  const terrain::Grid<float> values = visibility::float_raster(result, raster.output, r.options.target_height);
  phases.mask += seconds_since(at);
  at = std::chrono::steady_clock::now();
  const std::optional<double> nodata = raster.output_nodata ? raster.output_nodata : dem.nodata;
  HORIZON_RETURN_IF_ERROR(terrain::write_with_style(
      r.out_path, visibility::viewshed_style(visibility::preview_raster(raster.output), values),
      [&] { return terrain::write_geotiff(r.out_path, values, georef, nodata, r.geotiff.options); }));
  phases.encode = seconds_since(at);
  return Status::Ok();
}

// The request planned on the DEM's header (nothing decoded yet): with a
// finite --max-distance only the cells within reach (and a 2-cell margin)
// will be read, only the tiles or strips under them (--full-read: all).
Result<visibility::ViewshedPlan> plan_for(const Request& r, const terrain::ElevationSource& source) {
  auto plan = visibility::plan_viewshed(source, {r.observer, r.options});
  if (!plan.ok()) return plan.error();
  if (r.full_read) {
    plan->read.read = terrain::Window{0, 0, source.width(), source.height()};
    plan->read.blocks = source.blocks_in(plan->read.read);
  }
  return plan;
}

// The GL context the fast algorithm may run on, or why there is none.
struct Gpu {
  std::unique_ptr<gpu::ContextPool> pool;
  std::string unavailable;  // set when --backend gpu found no EGL display or context
};

// One context when fast is asked to run on the GPU (--backend gpu). Auto
// stays on the CPU here: it takes the GPU only from the size at which the
// GPU was measured faster (visibility::calibrate, about a second, which horizond
// pays once at start), and a one-shot command has no such measurement.
Gpu open_gpu(const visibility::ViewshedOptions& o) {
  Gpu gpu;
  if (o.algorithm != visibility::Algorithm::kRadial || o.backend != visibility::Backend::kGpu) return gpu;
  auto pool = gpu::ContextPool::create({.contexts = 1});
  if (pool.ok())
    gpu.pool = std::move(pool).value();
  else
    gpu.unavailable = pool.error().message;
  return gpu;
}

int run_viewshed(const Args& args) {
  apply_kernel_cap(args);
  if (wants_many_observers(args)) return run_many_observers(args);
  refuse_many_flags(args);
  const Request r = parse_request(args);
  if (auto s = check_output_path(r.out_path, "-o", r.dem_path, {".tif", ".tiff"}); !s.ok())
    return report_error(s.error());
  if (r.png_path) {
    if (auto s = check_output_path(*r.png_path, "--png", r.dem_path, {".png"}); !s.ok()) return report_error(s.error());
    // The preview needs the OpenImageIO plugin: find out now, before computing or writing anything.
    if (auto plugin = imageio::plugin_path(); !plugin.ok()) return report_error(plugin.error());
  }
  if (args.has("--server"))  // DEM is a dataset name; the daemon computes
    return remote::run_viewshed(args, {.dataset = r.dem_path,
                                       .out_path = r.out_path,
                                       .png_path = r.png_path,
                                       .observer = r.observer,
                                       .options = r.options,
                                       .format = r.geotiff.options.format,
                                       .creation_options = r.geotiff.creation_options,
                                       .raster = r.raster,
                                       .algorithm_name = r.algorithm_name,
                                       .json = r.json});

  const auto started = std::chrono::steady_clock::now();
  auto source = terrain::ElevationSource::open(r.dem_path, source_options(args));
  if (!source.ok()) return report_error(source.error());
  auto plan = plan_for(r, **source);
  if (!plan.ok()) return report_error(plan.error());
  Phases phases;
  phases.open = seconds_since(started);

  const Gpu gpu = open_gpu(r.options);
  InterruptScope interrupt;  // Ctrl-C cancels the computation; nothing is written
  RunControl control;
  control.cancel = &interrupt.token();
  ProgressBar progress("horizon viewshed");
  control.progress = progress.callback();
  // No cache: a one-shot run reads the planned cells straight from the file.
  auto run = visibility::run_viewshed(*plan, **source, nullptr, &control, gpu.pool.get());
  progress.finish();
  if (!run.ok()) return report_error(run.error());
  const terrain::Dem* const dem = &run->dem;
  const geodesy::GridPoint observer = run->observer_in_source();
  const terrain::SourceReadStats& read = run->read;
  visibility::ViewshedResult* const result = &run->result;
  // No pool: the engine only knows it had none; say why there was none.
  if (!gpu.unavailable.empty()) result->stats.gpu_fallback = gpu.unavailable;
  warn_gpu_fallback(result->stats);

  phases.read = read.seconds;
  phases.compute = result->stats.seconds;
  // The default codes, for the counts and the picture (whatever codes the file has).
  const auto masking = std::chrono::steady_clock::now();
  const terrain::Grid<std::uint8_t>& mask = visibility::ensure_mask(*result, r.options.threads);
  const visibility::AnswerCounts counts = result->mask_counts;
  phases.mask = seconds_since(masking);
  if (auto s = write_output(r, *dem, *run, mask, phases); !s.ok()) return report_error(s.error());
  if (r.png_path) {
    const auto drawing = std::chrono::steady_clock::now();
    const auto crs = geodesy::Crs::of(dem->georef);  // none: grid coordinates
    const visibility::PreviewCaption caption{.dem = visibility::dem_label(r.dem_path),
                                             .algorithm = r.algorithm_name,
                                             .crs = crs.ok() ? std::optional(*crs) : std::nullopt,
                                             .x = observer.x,
                                             .y = observer.y,
                                             .ground = observer.ground};
    if (auto s = visibility::write_viewshed_picture(*r.png_path, *result, visibility::preview_raster(r.raster.output),
                                                    mask, caption);
        !s.ok())
      return report_error(s.error());
    phases.preview = seconds_since(drawing);
  }
  const double total_seconds = seconds_since(started);

  const std::uint64_t visible = counts.visible, hidden = counts.hidden;
  const std::uint64_t evaluated = visible + hidden;
  const visibility::ViewFrame& f = result->frame;
  const visibility::WorkStats& stats = result->stats;
  const terrain::Window& window = run->window;  // in the file's grid
  // A single file reports its own tiles or strips; a mosaic its blocks.
  const bool one_file = read.file.blocks_total > 0;
  const std::uint64_t blocks_read = one_file ? read.file.blocks_read : read.blocks;
  const std::uint64_t blocks_total = one_file ? read.file.blocks_total : read.blocks_total;
  const std::string block_kind = !one_file ? "block" : read.file.tiled ? "tile" : "strip";
  const int block_width = one_file ? read.file.block_width : (*source)->files().front().block_width;
  const int block_height = one_file ? read.file.block_height : (*source)->files().front().block_height;
  const double area_km2 = static_cast<double>(visible) * f.metres_per_col * f.metres_per_row / 1e6;
  const double percent = evaluated ? 100.0 * static_cast<double>(visible) / static_cast<double>(evaluated) : 0.0;
  // Where the JSON or the text (a projected DEM's) shows the observer in
  // WGS 84; a geographic DEM's text needs no conversion, and converting is
  // the first use of the CRS's transformation (crs.hpp: milliseconds).
  const bool geographic = is_geographic(*dem);
  const auto observer_lonlat =
      r.json || !geographic ? lonlat_of(*dem, observer.x, observer.y) : std::optional<geodesy::LonLat>();

  if (r.json) {
    Json j;
    j["dem"] = r.dem_path;
    j["output"] = r.out_path;
    j["output_kind"] = r.raster.name;
    j["codes"] = visibility::is_code_raster(r.raster.output) ? to_json(r.raster.codes) : Json(nullptr);
    j["png"] = r.png_path ? Json(*r.png_path) : Json(nullptr);
    j["style"] = terrain::qml_path_for(r.out_path);
    j["algorithm"] = r.algorithm_name;
    j["observer"] = to_json(observer, observer_lonlat);
    j["options"] = viewshed_options_json(r.observer, r.options, args.text("--nodata").value_or("transparent"));
    j["window"] = to_json(window);
    j["cell_size_m"] = {{"x", f.metres_per_col}, {"y", f.metres_per_row}};
    j["visible_cells"] = visible;
    j["hidden_cells"] = hidden;
    j["evaluated_cells"] = evaluated;
    j["visible_area_km2"] = area_km2;
    j["visible_percent"] = percent;
    j["stats"] = to_json(stats);
    j["kernels"] = std::string(kernel_set_name(kernel_set()));
    j["preview_seconds"] = r.png_path ? Json(phases.preview) : Json(nullptr);
    j["read"] = {{"window", to_json(read.window)},
                 {"block", block_kind},
                 {"block_size", {block_width, block_height}},
                 {"blocks_read", blocks_read},
                 {"blocks_total", blocks_total},
                 {"files", read.files},
                 {"cells_decoded", read.cells_decoded},
                 {"seconds", read.seconds}};
    j["total_seconds"] = total_seconds;
    j["phases"] = {{"open", phases.open},
                   {"read", phases.read},
                   {"compute", phases.compute},
                   {"mask", phases.mask},
                   {"encode", phases.encode},
                   {"preview", r.png_path ? Json(phases.preview) : Json(nullptr)},
                   {"other", total_seconds - phases.open - phases.read - phases.compute - phases.mask - phases.encode -
                                 phases.preview}};
    print_json(j);
    return kExitOk;
  }

  std::cout << "Viewshed of " << r.dem_path << '\n'
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
            << with_separators(stats.dem_cells) << " in the DEM (window " << f.window.width() << "x"
            << f.window.height() << ")\n"
            << "  read:       " << blocks_read << " of " << blocks_total << " " << block_kind << "s (" << block_width
            << "x" << block_height << "), cells " << read.window.col0 << ".." << read.window.col1 << " x "
            << read.window.row0 << ".." << read.window.row1 << ", " << fixed(read.seconds, 3) << " s\n"
            << "  algorithm:  " << r.algorithm_name
            << (r.options.algorithm == visibility::Algorithm::kRadial
                    ? " (radial occlusion height field, ray spacing " + fixed(r.options.radial.ray_spacing, 2) + ")"
                    : std::string(""))
            << (stats.backend == "gpu" ? " on the GPU" : "") << '\n'
            << "  compute:    " << fixed(stats.seconds, 3) << " s (" << fixed(total_seconds, 3) << " s in all)\n"
            << "  wrote:      " << r.out_path << " (" << r.raster.name << "), its QGIS style "
            << terrain::qml_path_for(r.out_path) << '\n';
  if (r.png_path) std::cout << "  preview:    " << *r.png_path << " (" << fixed(phases.preview, 3) << " s)\n";
  std::cout << "  phases:     open " << fixed(phases.open, 3) << ", read " << fixed(phases.read, 3) << ", compute "
            << fixed(phases.compute, 3) << ", mask " << fixed(phases.mask, 3) << ", encode " << fixed(phases.encode, 3)
            << (r.png_path ? ", preview " + fixed(phases.preview, 3) : std::string()) << " s\n";
  return kExitOk;
}

}  // namespace

const Command& viewshed_command() {
  static const Command command{
      "viewshed",
      "Compute what an observer can see and write it as a GeoTIFF (and a PNG preview)",
      "horizon viewshed DEM (--observer X,Y... | -ox X -oy Y | --lat LAT --lon LON | --observers FILE) -o OUT.tif "
      "[options]",
      "Computes the viewshed of one observer over DEM and writes a georeferenced raster\n"
      "covering the cells within --max-distance:\n"
      "  visible            uint8: 1 visible, 0 hidden, 255 out of range or void (nodata 255);\n"
      "                     -vv -iv -ov -a_nodata set the four codes, as gdal_viewshed's\n"
      "  boolean            uint8, r.viewshed -b: 1 visible, 0 hidden or out of range, 255 void\n"
      "  ohf                float32: lowest visible elevation above each cell, metres\n"
      "  min-target-height  float32: lowest visible height above the ground, metres\n"
      "  vertical-angle     float32, r.viewshed's: degrees from straight down to each visible\n"
      "                     target (90 level)\n"
      "  elevation-difference  float32, r.viewshed -e: each visible cell's ground minus the eye\n"
      "Float rasters use -a_nodata, else the DEM's nodata value (NaN when it has none).\n"
      "Cells outside the field of view (--azimuth, --min-distance, --pitch) have no answer,\n"
      "as those beyond --max-distance; nearer terrain outside it still hides. gdal_viewshed's\n"
      "flags are accepted as spelled (-ox -oy -oz -tz -md -cc -om -vv -iv -ov -a_nodata -b\n"
      "-f -co), and --refraction takes r.viewshed's coefficient. --format COG writes a\n"
      "Cloud-Optimised GeoTIFF with overviews; --co sets GDAL's creation options. Outputs\n"
      "are written to a temporary name and renamed, so a failed run leaves nothing behind.\n\n"
      "Many observers (--observers FILE, or --observer more than once) run in parallel on\n"
      "the CPU, each with its own height and reach, and write one --accumulate raster:\n"
      "  count              uint32: how many observers see each cell (nodata 4294967295)\n"
      "  any | all          uint8: 1 seen by at least one / by every observer, 0 not, 255 none\n"
      "A CSV line is x,y[,height[,max_distance]]; GeoJSON points carry \"height\",\n"
      "\"max_distance\" and \"name\" properties. --height and --max-distance fill what a\n"
      "line leaves out; --summary writes each observer's visible cells and area.",
      kFlags,
      "  horizon viewshed data/dem/rainier_summit_srtm3_400x400.tif --lat 46.75 --lon -121.6767 \\\n"
      "      --max-distance 15000 -o out/rainier.tif --png out/rainier.png\n"
      "  horizon viewshed data/dem/ecuador_andes_utm17s_10m_383x415.tif --observer 713900,9558950 --height 30 \\\n"
      "      --max-distance 2000 --output min-target-height -o out/mth.tif --png out/mth.png --json\n"
      "  horizon viewshed data/dem/everest_summit_voids_srtm3_300x300.tif --lat 27.9881 --lon 86.925 \\\n"
      "      --altitude 8850 -md 8000 -vv 255 -iv 0 -ov 128 -a_nodata 64 -o out/codes.tif --png out/codes.png\n"
      "  horizon viewshed data/dem/ecuador_andes_utm17s_10m_383x415.tif -ox 713900 -oy 9558950 -oz 30 -md 0 \\\n"
      "      --observer-ground cell --azimuth 300,60 -f COG -co COMPRESS=ZSTD -o out/north.tif --png out/north.png\n"
      "  horizon viewshed data/dem/rainier_summit_srtm3_400x400.tif --observers examples/rainier_towers.csv \\\n"
      "      --accumulate count -o out/count.tif --png out/count.png --summary out/towers_seen.csv\n",
      run_viewshed,
  };
  return command;
}

}  // namespace horizon::cli
