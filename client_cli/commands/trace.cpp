// `horizon trace DEM --camera ... -o depth.tif --png view.png`: what a camera
// sees, per pixel (core/trace), one frame or a camera path.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <optional>

#include "commands/trace.hpp"

#include "commands/command.hpp"
#include "horizon/gpu/context_pool.hpp"
#include "horizon/imageio/imageio.hpp"
#include "horizon/terrain/block_cache.hpp"
#include "horizon/terrain/geotiff_writer.hpp"
#include "horizon/terrain/source.hpp"
#include "horizon/trace/products.hpp"
#include "horizon/trace/trace_plan.hpp"
#include "inputs.hpp"
#include "interrupt.hpp"
#include "output.hpp"
#include "remote/remote.hpp"

namespace horizon::cli {
namespace {

constexpr FlagSpec kFlags[] = {
    {"--camera", "", "X,Y", "Camera position in the DEM's CRS"},
    {"--lat", "", "LAT", "Camera latitude, WGS84 degrees (with --lon)"},
    {"--lon", "", "LON", "Camera longitude, WGS84 degrees (with --lat)"},
    {"--height", "", "M", "Camera height above the ground, metres (default 2)"},
    {"--altitude", "", "M", "Camera altitude, absolute metres (instead of --height)"},
    {"--yaw", "", "DEG", "Azimuth of the view's centre, degrees clockwise from grid north (default 0)"},
    {"--pitch", "", "DEG", "How far up the centre pixel looks, degrees in [-80, 80] (default 0); a lens shift"},
    {"--hfov", "", "DEG", "Horizontal field of view, degrees: (0, 170] perspective, (0, 360] cylindrical (default 60)"},
    {"--size", "", "WxH", "Frame size in pixels, each side 1..8192 (default 1024x768)"},
    {"--projection", "", "P", "'perspective' (a pinhole, default) or 'cylindrical' (a panorama, up to 360 degrees)"},
    {"--near", "", "M", "Near plane, metres ahead of the camera (default 1)"},
    {"--max-distance", "", "M", "Nothing farther than this many ground metres is terrain (default: the DEM's edge)"},
    {"--curvature", "", "C", "Curvature/refraction coefficient as GDAL's (default 0.85714; 0 disables)"},
    {"--nodata", "", "POLICY", "Voids: 'transparent' (default, never stop a ray) or 'fill:H' (terrain at H metres)"},
    {"--columns", "", "",
     "Exact mode: test column-line crossings too (a second tree), so every pixel meets R3's crossings; "
     "default: the paper's row crossings only"},
    {"--out", "-o", "DEPTH.tif", "Float32 TIFF image of each pixel's range in metres (NaN: sky)"},
    {"--png", "", "VIEW.png", "The terrain as the camera sees it, shaded"},
    {"--hits", "", "HITS.tif",
     "Float32 TIFF image, 3 bands: each pixel's hit column and row in the DEM's grid, and its elevation"},
    {"--footprint", "", "SEEN.tif", "GeoTIFF over the cells read: 1 where some pixel sees the cell, 0 not, 255 void"},
    {"--boxes", "", "FILE.csv",
     "Object boxes x_min,y_min,x_max,y_max,z_min,z_max (absolute metres): share of each seen"},
    {"--lonlat", "", "", "--boxes (and --path) positions are WGS84 lon,lat"},
    {"--edit", "", "XMIN,YMIN,XMAX,YMAX,=H|+H",
     "Change the terrain for this run: cells centred in the rectangle (DEM's CRS) set to H, or raised by +H/-H "
     "metres; repeatable, applied in order",
     true},
    {"--path", "", "FILE.csv",
     "Camera path: one frame a line, x,y,height,yaw[,pitch] (height above ground, or altitude with --altitude-path); "
     "prints per-frame times"},
    {"--altitude-path", "", "", "--path heights are absolute altitudes"},
    {"--frames", "", "DIR", "With --path: write each frame's shaded view as DIR/frame_NNNN.png"},
    {"--backend", "", "B",
     "'cpu' (default) or 'gpu': the paper's GL passes on an EGL context (pinhole and rows only; otherwise, or if "
     "the GPU fails, the CPU answers, with a warning)"},
    {"--threads", "", "N", "Worker threads (default 0 = all cores)"},
    {"--band", "", "N", "DEM band to read, 1-based (required when the file has several)"},
    kValidRangeFlag,
    {"--json", "", "", "Print the summary as a JSON document"},
    remote::kServerFlag,
    remote::kDeadlineFlag,
    remote::kCaFlag,
    remote::kClientCertFlag,
    remote::kTokenFileFlag,
};

constexpr std::string_view kProjections[] = {"perspective", "cylindrical"};
constexpr std::string_view kBackends[] = {"cpu", "gpu"};

// One --edit: a rectangle in the DEM's CRS and what happens to it.
using EditFlag = remote::TraceEditRect;

EditFlag parse_edit(const std::string& text) {
  const std::string where = "--edit: '" + text + "'";
  std::vector<std::string> parts;
  std::size_t start = 0;
  for (std::size_t comma; (comma = text.find(',', start)) != std::string::npos; start = comma + 1)
    parts.push_back(text.substr(start, comma - start));
  parts.push_back(text.substr(start));
  if (parts.size() != 5) throw UsageError(where + ": expected XMIN,YMIN,XMAX,YMAX,=H (or +H, -H)");
  double v[4];
  for (int i = 0; i < 4; ++i) {
    auto n = parse_finite(parts[static_cast<std::size_t>(i)]);
    if (!n) throw UsageError(where + ": '" + parts[static_cast<std::size_t>(i)] + "' is not a number");
    v[i] = *n;
  }
  if (v[0] > v[2] || v[1] > v[3]) throw UsageError(where + ": XMIN must not exceed XMAX, nor YMIN YMAX");
  const std::string& h = parts[4];
  if (h.empty() || (h[0] != '=' && h[0] != '+' && h[0] != '-'))
    throw UsageError(where + ": the height must start with '=' (set) or '+'/'-' (raise or lower), got '" + h + "'");
  auto height = parse_finite(h[0] == '-' ? std::string_view(h) : std::string_view(h).substr(1));
  if (!height) throw UsageError(where + ": '" + h + "' is not a height in metres");
  return {v[0],
          v[1],
          v[2],
          v[3],
          h[0] == '=' ? terrain::EditMode::kSet : terrain::EditMode::kRaise,
          static_cast<float>(*height)};
}

// The cells whose centres lie inside the rectangle (clipped to the DEM, and
// clamped before any cast, so a rectangle far off it is empty, not an
// overflow); kOutOfRange when none. The daemon converts a TraceCamera
// request's rectangles the same way (server/src/trace_translate.cpp).
Result<terrain::HeightEdit> edit_cells(const EditFlag& e, const terrain::DemHeader& h, std::size_t index) {
  const terrain::GeoTransform& t = h.georef.transform;
  const double c0 = t.col_at(e.x_min), c1 = t.col_at(e.x_max);
  const double r0 = t.row_at(e.y_min), r1 = t.row_at(e.y_max);
  const auto first = [](double v, int n) { return static_cast<int>(std::clamp(std::ceil(v), 0.0, double(n))); };
  const auto end = [](double v, int n) { return static_cast<int>(std::clamp(std::floor(v) + 1.0, 0.0, double(n))); };
  terrain::HeightEdit edit;
  edit.cells = {first(std::min(c0, c1), h.width), first(std::min(r0, r1), h.height), end(std::max(c0, c1), h.width),
                end(std::max(r0, r1), h.height)};
  if (edit.cells.empty())
    return make_error(
        ErrorCode::kOutOfRange,
        "--edit " + std::to_string(index + 1) + ": the rectangle holds no cell centre of '" + h.source + "'", "--edit");
  edit.heights = {e.height};
  edit.mode = e.mode;
  return edit;
}

struct Request {
  std::string dem_path;
  std::optional<std::string> depth_path, png_path, hits_path, footprint_path, frames_dir;
  trace::TraceQuery query;
  std::vector<std::uint64_t> box_ids;  // from the --boxes file's id column, one per box, or none
  std::vector<EditFlag> edits;
  std::optional<std::string> path_file;
  bool json = false;
  bool gpu = false;
};

// The one EGL context a --backend gpu run traces on, or why there is none
// (the CPU then answers, with a warning).
struct Gpu {
  std::unique_ptr<gpu::ContextPool> pool;
  std::optional<gpu::Lease> lease;
  std::string unavailable;
  gpu::Lease* get() { return lease ? &*lease : nullptr; }
};

void open_gpu(Gpu& g) {
  auto pool = gpu::ContextPool::create({.contexts = 1});
  if (!pool.ok()) {
    g.unavailable = pool.error().message;
    return;
  }
  g.pool = std::move(pool).value();
  auto lease = g.pool->borrow();
  if (lease.ok())
    g.lease.emplace(std::move(*lease));
  else
    g.unavailable = lease.error().message;
}

// "horizon: warning: GPU ... ; answered on the CPU" when the GPU was asked for and the CPU answered.
void warn_fallback(const trace::TraceStats& stats, const Gpu& g) {
  const std::string why = !g.unavailable.empty() ? g.unavailable : stats.gpu_fallback;
  if (!why.empty()) std::cerr << "horizon: warning: GPU not used (" << why << "); answered on the CPU\n";
}

std::pair<int, int> parse_size(const std::string& text) {
  const auto x = text.find('x');
  auto w = x == std::string::npos ? std::nullopt : parse_finite(std::string_view(text).substr(0, x));
  auto h = x == std::string::npos ? std::nullopt : parse_finite(std::string_view(text).substr(x + 1));
  if (!w || !h || *w != std::floor(*w) || *h != std::floor(*h) || *w < 1 || *h < 1 || *w > trace::kMaxSide ||
      *h > trace::kMaxSide)
    throw UsageError("--size: expected WIDTHxHEIGHT, whole pixels from 1 to " + std::to_string(trace::kMaxSide) +
                     " each, got '" + text + "'");
  return {static_cast<int>(*w), static_cast<int>(*h)};
}

Request parse_request(const Args& args) {
  Request r;
  r.dem_path = single_operand(args, "DEM");
  r.json = args.has("--json");
  r.path_file = args.text("--path");
  trace::CameraSpec& c = r.query.camera;
  if (!r.path_file) {
    c.position = point_from_flags(args, {"--camera", "--lat", "--lon"});
  } else if (args.has("--camera") || args.has("--lat") || args.has("--lon") || args.has("--yaw") ||
             args.has("--pitch")) {
    throw UsageError("--path gives every frame's position, yaw and pitch; drop --camera/--lat/--lon/--yaw/--pitch");
  }
  if (args.has("--height") && args.has("--altitude"))
    throw UsageError("--height and --altitude both set the camera; give one of them");
  if (auto altitude = args.number("--altitude")) {
    c.position.height = *altitude;
    c.position.height_mode = geodesy::HeightMode::kAbsolute;
  } else {
    c.position.height = args.non_negative("--height").value_or(2.0);
  }
  c.yaw = args.number("--yaw").value_or(0.0);
  c.pitch = args.number("--pitch").value_or(0.0);
  c.hfov = args.number("--hfov").value_or(60.0);
  std::tie(c.width, c.height) = parse_size(args.text("--size").value_or("1024x768"));
  if (auto p = args.choice("--projection", kProjections))
    c.projection = *p == "cylindrical" ? trace::Projection::kCylindrical : trace::Projection::kPerspective;
  if (Status s = trace::validate_camera(c); !s.ok())
    throw UsageError("--" + s.error().field + ": " + s.error().message.substr(s.error().message.find(':') + 2));

  trace::TraceOptions& o = r.query.options;
  o.near = args.non_negative("--near").value_or(o.near);
  if (auto d = args.non_negative("--max-distance")) o.max_distance = *d;
  o.curvature_coefficient = args.non_negative("--curvature").value_or(o.curvature_coefficient);
  if (auto policy = args.text("--nodata")) o.nodata = parse_nodata(*policy, o.nodata_fill_height);
  o.column_crossings = args.has("--columns");
  o.threads = args.non_negative_integer("--threads").value_or(0);
  r.gpu = args.choice("--backend", kBackends).value_or("cpu") == "gpu";
  throw_if_invalid_option(trace::validate_trace_options(o));
  for (const std::string& e : args.all("--edit")) r.edits.push_back(parse_edit(e));
  if (auto boxes = args.text("--boxes")) r.query.boxes = read_boxes_file(*boxes, args.has("--lonlat"), &r.box_ids);
  (void)source_options(args);

  r.depth_path = args.text("--out");
  r.png_path = args.text("--png");
  r.hits_path = args.text("--hits");
  r.footprint_path = args.text("--footprint");
  r.frames_dir = args.text("--frames");
  if (r.frames_dir && !r.path_file) throw UsageError("--frames writes a camera path's frames; give --path too");
  if (r.path_file && (r.depth_path || r.png_path || r.hits_path || r.footprint_path))
    throw UsageError("--path renders many frames: write them with --frames DIR, not -o/--png/--hits/--footprint");
  if (args.has("--altitude-path") && !r.path_file) throw UsageError("--altitude-path needs --path");
  const std::optional<std::string>* outputs[] = {&r.depth_path, &r.png_path, &r.hits_path, &r.footprint_path};
  for (std::size_t i = 0; i < 4; ++i)
    for (std::size_t k = i + 1; k < 4; ++k)
      if (*outputs[i] && *outputs[k] && same_file(**outputs[i], **outputs[k]))
        throw UsageError("'" + **outputs[i] + "' is given for two outputs; give each its own file");
  if (args.has("--server"))
    for (const char* flag : {"--path", "--frames", "--altitude-path", "--band", "--threads"})
      if (args.has(flag))
        throw UsageError(std::string(flag) +
                         " runs embedded only: with --server the daemon's configuration sets the dataset's band and "
                         "the threads a request uses, and a camera path (--path, --frames) is flown on a local DEM");
  if (!r.path_file && !r.depth_path && !r.png_path && !r.hits_path && !r.footprint_path && !r.json &&
      r.query.boxes.empty())
    throw UsageError("nothing to write: give -o DEPTH.tif, --png VIEW.png, --hits, --footprint, --boxes or --json");
  return r;
}

// A camera path: x, y, height (or altitude), yaw[, pitch] per line.
std::vector<trace::CameraSpec> read_path(const std::string& file, const trace::CameraSpec& base, bool lonlat,
                                         bool absolute) {
  std::ifstream in(file);
  if (!in) throw UsageError("--path: cannot open '" + file + "'");
  std::vector<trace::CameraSpec> frames;
  std::string line;
  int number = 0;
  while (std::getline(in, line)) {
    ++number;
    const CsvNumbers row = parse_csv_numbers(line);
    if (row.blank || (number == 1 && !row.numeric)) continue;
    const std::string where = "--path: '" + file + "' line " + std::to_string(number);
    if (row.values.size() != 4 && row.values.size() != 5)
      throw UsageError(where + ": expected x,y,height,yaw or x,y,height,yaw,pitch");
    trace::CameraSpec c = base;
    c.position.frame = lonlat ? geodesy::PointFrame::kWgs84 : geodesy::PointFrame::kDatasetCrs;
    c.position.x = row.values[0];
    c.position.y = row.values[1];
    c.position.height = row.values[2];
    c.position.height_mode = absolute ? geodesy::HeightMode::kAbsolute : geodesy::HeightMode::kAboveGround;
    if (!absolute && c.position.height < 0) throw UsageError(where + ": a height above ground must be >= 0");
    c.yaw = row.values[3];
    c.pitch = row.values.size() == 5 ? row.values[4] : 0.0;
    if (Status s = trace::validate_camera(c); !s.ok()) throw UsageError(where + ": " + s.error().message);
    frames.push_back(c);
  }
  if (frames.empty()) throw UsageError("--path: '" + file + "' holds no frames");
  return frames;
}

Json stats_json(const trace::TraceStats& s) {
  Json j;
  j["sub_frusta"] = s.sub_frusta;
  j["pixels"] = s.pixels;
  j["sky_pixels"] = s.sky_pixels;
  j["crossings"] = s.crossings;
  j["tree_texels"] = s.tree_texels;
  j["lines"] = s.max_lines;
  j["reads_per_pixel"] = s.reads_per_pixel;
  j["seconds"] = s.seconds;
  j["backend"] = s.backend;
  return j;
}

Status write_outputs(const Request& r, const trace::TraceRun& run) {
  if (r.depth_path) {
    const terrain::Grid<float> depth = trace::depth_image(run.frame);
    const terrain::Grid<float>* bands[] = {&depth};
    HORIZON_RETURN_IF_ERROR(terrain::write_tiff_image(*r.depth_path, bands));
  }
  if (r.hits_path) {
    const trace::HitImages hits = trace::hit_images(run.frame, run.window.col0, run.window.row0);
    const terrain::Grid<float>* bands[] = {&hits.col, &hits.row, &hits.elevation};
    HORIZON_RETURN_IF_ERROR(terrain::write_tiff_image(*r.hits_path, bands));
  }
  if (r.footprint_path)
    HORIZON_RETURN_IF_ERROR(
        terrain::write_geotiff(*r.footprint_path, trace::footprint(run.frame, run.view()), run.georef, 255.0));
  if (r.png_path) HORIZON_RETURN_IF_ERROR(trace::write_shaded_png(*r.png_path, run.frame, run.view()));
  return Status::Ok();
}

int run_frame(const Request& r, const terrain::ElevationSource& source) {
  const auto started = std::chrono::steady_clock::now();
  auto plan = trace::plan_trace(source, r.query, r.query.options.threads);
  if (!plan.ok()) return report_error(plan.error());
  InterruptScope interrupt;  // Ctrl-C cancels; nothing is written
  RunControl control;
  control.cancel = &interrupt.token();
  Gpu gpu;
  if (r.gpu) open_gpu(gpu);
  auto run = trace::run_trace(*plan, source, nullptr, &control, gpu.get());
  if (!run.ok()) return report_error(run.error());
  if (r.gpu) warn_fallback(run->frame.stats, gpu);
  const auto traced = std::chrono::steady_clock::now();
  if (Status s = write_outputs(r, *run); !s.ok()) return report_error(s.error());
  const terrain::Georeference& georef = source.header().georef;

  TraceReport report;
  report.dem = r.dem_path;
  report.eye = run->eye;
  report.eye_lonlat = lonlat_of(georef, run->eye.x, run->eye.y);
  report.geographic = is_geographic(georef);
  report.camera = r.query.camera;
  report.columns = r.query.options.column_crossings;
  report.stats = run->frame.stats;
  report.window = run->window;
  report.dem_cells = static_cast<std::uint64_t>(source.width()) * static_cast<std::uint64_t>(source.height());
  report.blocks = run->read.blocks;
  report.blocks_total = run->read.blocks_total;
  report.edited_cells = run->edited_cells;
  report.boxes = run->boxes;
  report.ids = r.box_ids;
  report.total_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
  report.write_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - traced).count();
  print_trace(report, r.json);
  return kExitOk;
}

int run_path(const Request& r, const Args& args, const terrain::ElevationSource& source) {
  const std::vector<trace::CameraSpec> frames =
      read_path(*r.path_file, r.query.camera, args.has("--lonlat"), args.has("--altitude-path"));
  if (r.frames_dir) {
    std::error_code ec;
    if (!std::filesystem::is_directory(*r.frames_dir, ec))
      return report_error(
          make_error(ErrorCode::kNotFound, "--frames: '" + *r.frames_dir + "' is not a directory", "--frames"));
  }
  // One cache for the path: a frame reads only the blocks the frames before it did not.
  terrain::BlockCache cache({.budget_bytes = 512ull << 20});
  InterruptScope interrupt;
  RunControl control;
  control.cancel = &interrupt.token();
  Gpu gpu;
  if (r.gpu) open_gpu(gpu);
  std::vector<double> trace_ms, frame_ms;
  std::optional<trace::TraceRun> last;  // its image storage serves the next frame
  Json per_frame = Json::array();
  for (std::size_t i = 0; i < frames.size(); ++i) {
    const auto started = std::chrono::steady_clock::now();
    trace::TraceQuery q = r.query;
    q.camera = frames[i];
    auto plan = trace::plan_trace(source, q, q.options.threads);
    if (!plan.ok()) return report_error(plan.error());
    auto run = trace::run_trace(*plan, source, &cache, &control, gpu.get(), last ? &*last : nullptr);
    if (!run.ok()) return report_error(run.error());
    if (r.gpu && i == 0) warn_fallback(run->frame.stats, gpu);
    const double frame = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count() * 1e3;
    trace_ms.push_back(run->frame.stats.seconds * 1e3);
    frame_ms.push_back(frame);
    if (r.frames_dir) {
      char name[32];
      std::snprintf(name, sizeof name, "frame_%04zu.png", i);
      if (Status s =
              trace::write_shaded_png((std::filesystem::path(*r.frames_dir) / name).string(), run->frame, run->view());
          !s.ok())
        return report_error(s.error());
    }
    per_frame.push_back({{"frame", i},
                         {"trace_ms", trace_ms.back()},
                         {"frame_ms", frame},
                         {"sky_pixels", run->frame.stats.sky_pixels},
                         {"crossings", run->frame.stats.crossings}});
    last = std::move(*run);
  }
  auto stats_of = [](std::vector<double> v) {
    std::sort(v.begin(), v.end());
    return std::array<double, 3>{v.front(), v[v.size() / 2], v.back()};
  };
  const auto t = stats_of(trace_ms), f = stats_of(frame_ms);
  if (r.json) {
    Json j;
    j["dem"] = r.dem_path;
    j["frames"] = frames.size();
    j["width"] = r.query.camera.width;
    j["height"] = r.query.camera.height;
    j["trace_ms"] = {{"min", t[0]}, {"median", t[1]}, {"max", t[2]}, {"max_over_min", t[2] / t[0]}};
    j["frame_ms"] = {{"min", f[0]}, {"median", f[1]}, {"max", f[2]}};
    j["per_frame"] = std::move(per_frame);
    print_json(j);
    return kExitOk;
  }
  std::cout << "Camera path over " << r.dem_path << ": " << frames.size() << " frames of " << r.query.camera.width
            << "x" << r.query.camera.height << '\n'
            << "  trace:      min " << fixed(t[0], 2) << " ms, median " << fixed(t[1], 2) << " ms, max "
            << fixed(t[2], 2) << " ms (slowest / fastest " << fixed(t[2] / t[0], 2) << ")\n"
            << "  frame:      min " << fixed(f[0], 2) << " ms, median " << fixed(f[1], 2) << " ms, max "
            << fixed(f[2], 2) << " ms (plan, read through the cache, trace, boxes)\n";
  if (r.frames_dir) std::cout << "  frames:     " << *r.frames_dir << "/frame_NNNN.png\n";
  return kExitOk;
}

int run_trace(const Args& args) {
  Request r = parse_request(args);
  for (const auto& [path, flag, ext] :
       {std::tuple{r.depth_path, "-o", ".tif"}, std::tuple{r.hits_path, "--hits", ".tif"},
        std::tuple{r.footprint_path, "--footprint", ".tif"}, std::tuple{r.png_path, "--png", ".png"}})
    if (path)
      if (auto s = check_output_path(*path, flag, r.dem_path, {ext, std::string_view(ext) == ".tif" ? ".tiff" : ext});
          !s.ok())
        return report_error(s.error());
  if (r.png_path || r.frames_dir)
    if (auto plugin = imageio::plugin_path(); !plugin.ok()) return report_error(plugin.error());
  if (args.has("--server"))  // DEM is a dataset name; the daemon traces, this writes the same files
    return remote::run_trace(args, {.dataset = r.dem_path,
                                    .depth_path = r.depth_path,
                                    .png_path = r.png_path,
                                    .hits_path = r.hits_path,
                                    .footprint_path = r.footprint_path,
                                    .camera = r.query.camera,
                                    .options = r.query.options,
                                    .boxes = r.query.boxes,
                                    .box_ids = r.box_ids,
                                    .edits = r.edits,
                                    .json = r.json,
                                    .gpu = r.gpu});
  auto source = terrain::ElevationSource::open(r.dem_path, source_options(args));
  if (!source.ok()) return report_error(source.error());
  for (std::size_t i = 0; i < r.edits.size(); ++i) {
    auto edit = edit_cells(r.edits[i], (*source)->header(), i);
    if (!edit.ok()) return report_error(edit.error());
    r.query.edits.push_back(std::move(*edit));
  }
  return r.path_file ? run_path(r, args, **source) : run_frame(r, **source);
}

}  // namespace

void print_trace(const TraceReport& r, bool json) {
  const trace::TraceStats& st = r.stats;
  if (json) {
    Json j;
    j["dem"] = r.dem;
    j["camera"] = to_json(r.eye, r.eye_lonlat);
    j["yaw"] = r.camera.yaw;
    j["pitch"] = r.camera.pitch;
    j["hfov"] = r.camera.hfov;
    j["projection"] = trace::projection_name(r.camera.projection);
    j["width"] = r.camera.width;
    j["height"] = r.camera.height;
    j["mode"] = r.columns ? "rows+columns" : "rows";
    j["gpu_fallback"] = st.gpu_fallback.empty() ? Json(nullptr) : Json(st.gpu_fallback);
    j["trace"] = stats_json(st);
    j["read"] = {{"window", to_json(r.window)},
                 {"cells", r.window.cell_count()},
                 {"dem_cells", r.dem_cells},
                 {"blocks", r.blocks},
                 {"blocks_total", r.blocks_total}};
    j["edited_cells"] = r.edited_cells;
    Json boxes = Json::array();
    for (std::size_t i = 0; i < r.boxes.size(); ++i) {
      const trace::BoxView& b = r.boxes[i];
      Json box = {{"pixels", b.pixels}, {"visible_pixels", b.visible}, {"fraction", b.fraction()}};
      if (!r.ids.empty()) box["id"] = r.ids[i];
      boxes.push_back(std::move(box));
    }
    j["boxes"] = std::move(boxes);
    j["seconds"] = {{"total", r.total_seconds}, {"trace", st.seconds}, {"write", r.write_seconds}};
    if (!r.server.empty()) j["server"] = {{"address", r.server}};
    print_json(j);
    return;
  }
  std::cout << "Camera trace over " << r.dem << (r.server.empty() ? "" : " on " + r.server) << '\n'
            << "  camera:     x " << coordinate(r.eye.x, r.geographic) << ", y " << coordinate(r.eye.y, r.geographic)
            << ", eye " << fixed(r.eye.elevation, 1) << " m (ground " << fixed(r.eye.ground, 1) << " m)\n"
            << "  view:       yaw " << fixed(r.camera.yaw, 1) << ", pitch " << fixed(r.camera.pitch, 1) << ", "
            << fixed(r.camera.hfov, 1) << " degrees " << trace::projection_name(r.camera.projection) << ", "
            << r.camera.width << "x" << r.camera.height << " pixels\n"
            << "  mode:       " << (r.columns ? "rows and columns (exact)" : "rows (the paper's)") << ", "
            << st.sub_frusta << " sub-frust" << (st.sub_frusta == 1 ? "um" : "a") << ", on the "
            << (st.backend == "gpu" ? "GPU" : "CPU") << '\n'
            << "  sky:        " << with_separators(st.sky_pixels) << " of " << with_separators(st.pixels) << " pixels\n"
            << "  work:       " << with_separators(st.crossings) << " crossings over " << st.max_lines << " lines, "
            << st.reads_per_pixel << " reads a pixel\n"
            << "  read:       " << with_separators(r.window.cell_count()) << " of " << with_separators(r.dem_cells)
            << " cells, " << r.blocks << " of " << r.blocks_total << " blocks\n";
  if (r.edited_cells) std::cout << "  edited:     " << with_separators(r.edited_cells) << " cells\n";
  for (std::size_t i = 0; i < r.boxes.size(); ++i) {
    const trace::BoxView& b = r.boxes[i];
    std::cout << "  box " << (r.ids.empty() ? i + 1 : r.ids[i]) << ":      "
              << (b.pixels ? fixed(100.0 * b.fraction(), 1) + " % of " + with_separators(b.pixels) + " pixels seen"
                           : std::string("not in the frame"))
              << '\n';
  }
  std::cout << "  time:       " << fixed(st.seconds * 1e3, 1) << " ms trace, " << fixed(r.total_seconds, 3)
            << " s in all\n";
}

const Command& trace_command() {
  static const Command command{
      "trace",
      "Render what a camera sees over a DEM, per pixel: depth, hits, a shaded view, boxes seen",
      "horizon trace DEM (--camera X,Y | --lat LAT --lon LON) [--yaw DEG] [--pitch DEG] [--hfov DEG] [--size WxH]\n"
      "       [-o DEPTH.tif] [--png VIEW.png] [--hits HITS.tif] [--footprint SEEN.tif] [--boxes FILE.csv] [options]\n"
      "       horizon trace DEM --path CAMERAS.csv [--frames DIR] [options]",
      "Traces every pixel's ray over the terrain by silhouette partitioning (no\n"
      "preprocessing, a fixed number of reads a pixel): each screen column's\n"
      "crossings with the DEM's row lines, a tree of their silhouettes, and a\n"
      "binary search down it per pixel. Vertical lines stay vertical: pitch is a\n"
      "lens shift. The paper's method tests row crossings only and can miss a\n"
      "ridge only a column line catches; --columns tests both (R3's crossings).\n"
      "The ground under the camera is bilinear between cell centres. Voids never\n"
      "stop a ray unless --nodata fill:H. Only the cells inside the view's wedge\n"
      "are read. --edit changes the terrain for this run only (a crater, a berm):\n"
      "the trace needs no preprocessing, so an edited frame costs what any does.",
      kFlags,
      "  horizon trace data/dem/rainier_summit_srtm3_400x400.tif --lat 46.80 --lon -121.73 --height 30 \\\n"
      "      --yaw 20 --pitch 5 --hfov 70 --size 960x540 --png view.png -o depth.tif\n"
      "  horizon trace data/dem/everest_summit_voids_srtm3_300x300.tif --lat 27.9881 --lon 86.925 --altitude 8850 \\\n"
      "      --projection cylindrical --hfov 360 --pitch -10 --size 1440x240 --png panorama.png\n"
      "  horizon trace data/dem/rainier_summit_srtm3_400x400.tif --path examples/rainier_cameras.csv --lonlat \\\n"
      "      --size 512x512 --json\n"
      "  horizon trace rainier --server localhost:50051 --lat 46.70 --lon -121.90 --height 800 --yaw 40 \\\n"
      "      -o depth.tif --png view.png     # a horizond dataset: the same files, traced by the daemon\n",
      run_trace,
  };
  return command;
}

}  // namespace horizon::cli
