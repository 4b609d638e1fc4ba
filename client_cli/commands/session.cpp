// `horizon session DEM --path POSES.csv --boxes BOXES.csv ...`: a flight
// path through a clip-map session (core/clipmap/session.hpp).
#include "commands/session.hpp"

#include <algorithm>
#include <cctype>
#include <chrono>
#include <fstream>
#include <iostream>
#include <memory>
#include <string_view>
#include <thread>

#include "commands/command.hpp"
#include "horizon/clipmap/clipmap_updater.hpp"
#include "horizon/terrain/block_cache.hpp"
#include "horizon/terrain/source.hpp"
#include "horizon/terrain/source_pyramid.hpp"
#include "inputs.hpp"
#include "interrupt.hpp"
#include "output.hpp"
#include "remote/remote.hpp"

namespace horizon::cli {
namespace {

constexpr FlagSpec kFlags[] = {
    {"--path", "", "POSES.csv",
     "The flight, one pose a line: x,y,height[,east_m_s,north_m_s] (DEM CRS, or lon,lat with --lonlat); "
     "'#' comments"},
    {"--boxes", "", "BOXES.csv", "Boxes as for `horizon cull`: x_min,y_min,x_max,y_max,z_min,z_max"},
    {"--lonlat", "", "", "The poses' and boxes' x/y are WGS84 longitude/latitude"},
    {"--absolute", "", "", "Pose heights are absolute altitudes (default: above the ground)"},
    {"--conservative", "", "", "Never report hidden a box R3 sees (min levels for occluders)"},
    {"--exact", "", "", "R3's answers from the full-resolution terrain at every pose (no clip-map; slow)"},
    {"--viewshed-radius", "", "METRES", "Also count the cells seen and hidden within this distance at every pose"},
    {"--backend", "", "B",
     "Where the trace runs: cpu (default) or gpu (a GL context: the same answers; Mesa llvmpipe where there is "
     "no GPU, which is slower than the CPU). Not with --exact"},
    {"--levels", "", "L", "Clip-map levels, 1..10 (default: the fewest that cover the dataset)"},
    {"--level-size", "", "N", "Samples per side of a level, a power of two in [64, 4096] (default 1024)"},
    {"--subtile", "", "T", "Sub-tile side, a power of two in [8, N/2] (default 64)"},
    {"--rays", "", "R", "Azimuths traced around the eye, [64, 65536] (default 1024)"},
    {"--rate", "", "HZ", "Send poses at this rate, not waiting for answers (default: each after the last answer)"},
    {"--every-pose", "", "", "Print a line for every pose"},
    {"--json", "", "", "Print a JSON document with every pose"},
    {"--session-id", "", "ID",
     "With --server: the session's id (1-64 of A-Z a-z 0-9 _ -), sent as horizon-session-id for balancer affinity"},
    {"--band", "", "N", "DEM band to read, 1-based"},
    kValidRangeFlag,
    remote::kServerFlag,
    remote::kDeadlineFlag,
    remote::kCaFlag,
    remote::kClientCertFlag,
    remote::kTokenFileFlag,
};

// The poses file; errors name the file and line.
std::vector<clipmap::SessionPose> read_poses(const std::string& path, bool lonlat, bool absolute) {
  std::ifstream in(path);
  if (!in) throw UsageError("--path: cannot open '" + path + "'");
  std::vector<clipmap::SessionPose> poses;
  std::string line;
  int number = 0;
  while (std::getline(in, line)) {
    ++number;
    const CsvNumbers row = parse_csv_numbers(line);
    if (row.blank || (number == 1 && !row.numeric)) continue;  // a blank line, a comment, a header
    const std::vector<double>& v = row.values;
    if (v.size() != 3 && v.size() != 5)
      throw UsageError("--path: '" + path + "' line " + std::to_string(number) +
                       ": expected x,y,height or x,y,height,east_m_s,north_m_s");
    clipmap::SessionPose p;
    p.position.frame = lonlat ? geodesy::PointFrame::kWgs84 : geodesy::PointFrame::kDatasetCrs;
    p.position.x = v[0];
    p.position.y = v[1];
    p.position.height = v[2];
    p.position.height_mode = absolute ? geodesy::HeightMode::kAbsolute : geodesy::HeightMode::kAboveGround;
    if (v.size() == 5) {
      p.east_per_s = v[3];
      p.north_per_s = v[4];
    }
    p.seq = poses.size() + 1;
    poses.push_back(p);
  }
  if (poses.empty()) throw UsageError("--path: '" + path + "' holds no poses");
  return poses;
}

// A shape or ray count the engine refuses, as a usage error naming the flag.
template <class T>
void throw_if_bad_shape(const Result<T>& checked) {
  if (checked.ok() || checked.error().code != ErrorCode::kInvalidArgument) return;
  std::string message = checked.error().message;
  for (const auto& [field, flag] :
       {std::pair{"clipmap.levels", "--levels"}, std::pair{"clipmap.level_size", "--level-size"},
        std::pair{"clipmap.subtile", "--subtile"}, std::pair{"rays", "--rays"}})
    if (message.rfind(field, 0) == 0) message.replace(0, std::string(field).size(), flag);
  throw UsageError(message);
}

// Waits until the next pose is due at `rate` (0: no wait).
void pace(std::chrono::steady_clock::time_point start, std::size_t index, double rate) {
  if (rate <= 0.0) return;
  std::this_thread::sleep_until(start + std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                                            std::chrono::duration<double>(static_cast<double>(index) / rate)));
}

int run_embedded(const Args& args, SessionPlayback& playback, bool json, bool every_pose) {
  const auto started = std::chrono::steady_clock::now();
  auto source = terrain::ElevationSource::open(playback.dataset, source_options(args));
  if (!source.ok()) return report_error(source.error());
  terrain::BlockCache::Options cache_options;
  cache_options.budget_bytes = 256ull << 20;
  terrain::BlockCache cache(cache_options);
  clipmap::SessionOptions& o = playback.options;
  if (o.shape.levels == 0)
    o.shape.levels = clipmap::levels_to_cover(o.shape.level_size, (*source)->width(), (*source)->height());
  throw_if_bad_shape(clipmap::ClipSession::bytes_for(o, (*source)->width(), (*source)->height(), 0));
  auto pyramid = terrain::SourcePyramid::make(*source, cache, clipmap::reduction_for(o.mode),
                                              clipmap::pyramid_options_for(o.shape));
  if (!pyramid.ok()) return report_error(pyramid.error());
  // --backend gpu: one context; without one the answers say why they ran on the CPU.
  std::unique_ptr<gpu::ContextPool> pool;
  std::string no_gpu;
  if (o.use_gpu) {
    auto created = gpu::ContextPool::create({.contexts = 1});
    if (created.ok())
      pool = std::move(created).value();
    else
      no_gpu = created.error().message;
    o.gpu = pool.get();
  }
  InterruptScope interrupt;
  RunControl control;
  control.cancel = &interrupt.token();
  auto session = clipmap::ClipSession::open(*source, cache, *pyramid, o, playback.poses.front(), &control);
  if (!session.ok()) return report_error(session.error());
  if (Status added = (*session)->add_boxes(playback.boxes); !added.ok()) return report_error(added.error());

  SessionReport report;
  report.levels = o.shape.levels;
  report.level_size = o.shape.level_size;
  report.subtile = o.shape.subtile;
  report.memory_bytes = (*session)->bytes();
  const auto flight = std::chrono::steady_clock::now();
  for (std::size_t i = 0; i < playback.poses.size(); ++i) {
    pace(flight, i, playback.rate_hz);
    auto answer = (*session)->answer(playback.poses[i], &control);
    PoseLine line;
    line.seq = playback.poses[i].seq;
    if (!answer.ok()) {
      if (answer.error().code == ErrorCode::kCancelled) return report_error(answer.error());
      line.rejected = answer.error().message;
    } else {
      line.changes = answer->changes.size();
      line.boxes = answer->boxes;
      line.visible = answer->visible;
      line.samples = answer->cull.samples;
      line.fallbacks = answer->cull.fallbacks;
      line.subtiles_loaded = answer->subtiles_loaded;
      line.bytes_loaded = answer->bytes_loaded;
      line.seconds = answer->seconds;
      if (answer->viewshed) line.viewshed = {answer->viewshed->visible_cells, answer->viewshed->hidden_cells};
      line.gpu = answer->cull.gpu;
      line.gpu_fallback = no_gpu.empty() ? answer->gpu_fallback : no_gpu;
    }
    report.poses.push_back(line);
  }
  report.total_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
  print_session(playback, report, json, every_pose);
  return kExitOk;
}

int run_session(const Args& args) {
  SessionPlayback playback;
  playback.dataset = single_operand(args, "DEM");
  const bool json = args.has("--json"), every_pose = args.has("--every-pose");
  const auto path = args.text("--path");
  if (!path) throw UsageError("missing --path POSES.csv");
  const auto boxes = args.text("--boxes");
  if (!boxes) throw UsageError("missing --boxes BOXES.csv");
  playback.poses_path = *path;
  playback.boxes_path = *boxes;
  const bool lonlat = args.has("--lonlat");
  playback.poses = read_poses(*path, lonlat, args.has("--absolute"));
  const std::vector<visibility::BoxSpec> specs = read_boxes_file(*boxes, lonlat);
  for (std::size_t i = 0; i < specs.size(); ++i) playback.boxes.push_back({i + 1, specs[i]});
  clipmap::SessionOptions& o = playback.options;
  if (args.has("--conservative") && args.has("--exact")) throw UsageError("give --conservative or --exact, not both");
  o.mode = args.has("--conservative") ? clipmap::ClipMode::kConservative
           : args.has("--exact")      ? clipmap::ClipMode::kExact
                                      : clipmap::ClipMode::kFast;
  o.shape.levels = args.positive_integer("--levels").value_or(0);
  o.shape.level_size = args.positive_integer("--level-size").value_or(1024);
  o.shape.subtile = args.positive_integer("--subtile").value_or(std::min(64, std::max(8, o.shape.level_size / 2)));
  o.rays = args.positive_integer("--rays").value_or(1024);
  o.viewshed_radius = args.non_negative("--viewshed-radius").value_or(0.0);
  static constexpr std::string_view kBackends[] = {"cpu", "gpu"};
  o.use_gpu = args.choice("--backend", kBackends).value_or("cpu") == "gpu";
  if (o.use_gpu && o.mode == clipmap::ClipMode::kExact)
    throw UsageError("--backend gpu traces clip-maps: --exact runs on the CPU");
  playback.rate_hz = args.non_negative("--rate").value_or(0.0);
  if (args.has("--rate") && !(playback.rate_hz > 0.0)) throw UsageError("--rate must be more than 0 poses a second");
  (void)source_options(args);
  if (auto id = args.text("--session-id")) {
    if (!args.has("--server")) throw UsageError("--session-id needs --server");
    const bool valid = !id->empty() && id->size() <= 64 && std::all_of(id->begin(), id->end(), [](char c) {
      return std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '-';
    });
    if (!valid) throw UsageError("--session-id: 1 to 64 characters of A-Z, a-z, 0-9, '_' and '-'");
  }
  if (args.has("--server")) return remote::run_session(args, playback, json, every_pose);
  return run_embedded(args, playback, json, every_pose);
}

double percentile(std::vector<double> values, double p) {
  if (values.empty()) return 0.0;
  std::sort(values.begin(), values.end());
  const std::size_t at = std::min(values.size() - 1, static_cast<std::size_t>(p * static_cast<double>(values.size())));
  return values[at];
}

}  // namespace

void print_session(const SessionPlayback& playback, const SessionReport& report, bool json, bool every_pose) {
  std::vector<double> seconds;
  std::uint64_t dropped = 0, rejected = 0, changes = 0, samples = 0, fallbacks = 0, loaded = 0, bytes = 0;
  std::uint64_t on_gpu = 0;
  std::string gpu_fallback;  // the first answer's reason
  for (const PoseLine& p : report.poses) {
    dropped += p.dropped;
    if (!p.rejected.empty()) {
      ++rejected;
      continue;
    }
    on_gpu += p.gpu;
    if (gpu_fallback.empty()) gpu_fallback = p.gpu_fallback;
    seconds.push_back(p.seconds);
    changes += p.changes;
    samples += p.samples;
    fallbacks += p.fallbacks;
    loaded += p.subtiles_loaded;
    bytes += p.bytes_loaded;
  }
  const PoseLine* last = nullptr;
  for (const PoseLine& p : report.poses)
    if (p.rejected.empty()) last = &p;
  const std::size_t answered = seconds.size();
  const char* mode = clipmap::mode_name(playback.options.mode);
  if (json) {
    Json j;
    j["dem"] = playback.dataset;
    j["poses_file"] = playback.poses_path;
    j["boxes_file"] = playback.boxes_path;
    if (playback.options.mode != clipmap::ClipMode::kExact)
      j["clipmap"] = {{"levels", report.levels}, {"level_size", report.level_size}, {"subtile", report.subtile}};
    j["mode"] = mode;
    j["rays"] = playback.options.rays;
    j["backend"] = playback.options.use_gpu ? "gpu" : "cpu";
    j["answers_on_gpu"] = on_gpu;
    if (!gpu_fallback.empty()) j["gpu_fallback"] = gpu_fallback;
    j["memory_bytes"] = report.memory_bytes;
    if (!report.session_id.empty()) j["session_id"] = report.session_id;
    j["poses_sent"] = playback.poses.size();
    j["answered"] = answered;
    j["dropped"] = dropped;
    j["rejected"] = rejected;
    j["seconds_p50"] = percentile(seconds, 0.5);
    j["seconds_p99"] = percentile(seconds, 0.99);
    j["bytes_loaded"] = bytes;
    Json list = Json::array();
    for (const PoseLine& p : report.poses) {
      Json e{{"seq", p.seq}};
      if (!p.rejected.empty()) {
        e["rejected"] = p.rejected;
      } else {
        e["dropped"] = p.dropped;
        e["changes"] = p.changes;
        e["visible"] = p.visible;
        e["boxes"] = p.boxes;
        e["samples"] = p.samples;
        e["fallbacks"] = p.fallbacks;
        e["subtiles_loaded"] = p.subtiles_loaded;
        e["bytes_loaded"] = p.bytes_loaded;
        e["seconds"] = p.seconds;
        e["backend"] = p.gpu ? "gpu" : "cpu";
        if (!p.gpu_fallback.empty()) e["gpu_fallback"] = p.gpu_fallback;
        if (p.viewshed) e["viewshed"] = {{"visible_cells", (*p.viewshed)[0]}, {"hidden_cells", (*p.viewshed)[1]}};
      }
      list.push_back(std::move(e));
    }
    j["poses"] = std::move(list);
    j["total_seconds"] = report.total_seconds;
    print_json(j);
    return;
  }
  std::cout << "Session over " << playback.dataset << (report.where.empty() ? "" : " " + report.where)
            << (report.session_id.empty() ? "" : " (session " + report.session_id + ")") << '\n'
            << "  clip-map:   ";
  if (playback.options.mode == clipmap::ClipMode::kExact)
    std::cout << "none: exact, R3 on the full-resolution terrain at every pose; ";
  else
    std::cout << report.levels << " levels of " << report.level_size << " x " << report.level_size << " (sub-tiles "
              << report.subtile << "), " << mode << ", " << playback.options.rays << " rays; ";
  std::cout << fixed(static_cast<double>(report.memory_bytes) / (1 << 20), 1) << " MiB\n"
            << "  poses:      " << with_separators(playback.poses.size()) << " from " << playback.poses_path << ": "
            << with_separators(answered) << " answered, " << with_separators(dropped)
            << " dropped (a newer pose came), " << with_separators(rejected) << " rejected\n"
            << "  boxes:      " << with_separators(playback.boxes.size()) << " from " << playback.boxes_path;
  if (last) std::cout << ": " << with_separators(last->visible) << " visible at pose " << last->seq;
  std::cout << '\n'
            << "  per pose:   p50 " << fixed(percentile(seconds, 0.5) * 1e3, 2) << " ms, p99 "
            << fixed(percentile(seconds, 0.99) * 1e3, 2) << " ms" << (report.where.empty() ? "" : " (server time)")
            << "; " << fixed(answered ? double(changes) / double(answered) : 0.0, 1) << " changes on average\n"
            << "  loaded:     " << fixed(static_cast<double>(bytes) / (1 << 20), 2) << " MiB in "
            << with_separators(loaded) << " sub-tiles ("
            << fixed(answered ? static_cast<double>(bytes) / 1024.0 / double(answered) : 0.0, 1) << " KiB a pose)\n"
            << "  fallbacks:  " << with_separators(fallbacks) << " of " << with_separators(samples)
            << " samples read a coarser level than asked\n"
            << "  total:      " << fixed(report.total_seconds, 3) << " s\n";
  if (playback.options.use_gpu)
    std::cout << "  gpu:        " << with_separators(on_gpu) << " of " << with_separators(answered)
              << " answers traced on the GPU"
              << (gpu_fallback.empty() ? "" : "; the CPU traced others: " + gpu_fallback) << '\n';
  if (!every_pose) return;
  for (const PoseLine& p : report.poses) {
    std::cout << "  pose " << p.seq << ": ";
    if (!p.rejected.empty()) {
      std::cout << "rejected: " << p.rejected << '\n';
      continue;
    }
    std::cout << p.changes << " changed, " << p.visible << " of " << p.boxes << " visible, "
              << fixed(p.seconds * 1e3, 2) << " ms, " << p.fallbacks << " fallbacks, " << p.subtiles_loaded
              << " sub-tiles loaded" << (p.dropped ? ", " + std::to_string(p.dropped) + " dropped before it" : "")
              << (p.viewshed ? "; viewshed " + with_separators((*p.viewshed)[0]) + " cells seen, " +
                                   with_separators((*p.viewshed)[1]) + " hidden"
                             : "")
              << '\n';
  }
}

const Command& session_command() {
  static const Command command{
      "session",
      "Play a flight through a clip-map session: which boxes change visibility at each pose",
      "horizon session DEM --path POSES.csv --boxes BOXES.csv [options]",
      "Opens a session (an elevation clip-map around the client, levels updated on their\n"
      "own schedules, coarse levels standing in where a fine one lags), registers the\n"
      "boxes, and plays the poses: each answer names the boxes whose visibility changed.\n"
      "Prints the per-pose time, what was loaded and how many samples fell back. With\n"
      "--server the session runs on the daemon (one bidirectional stream); with --rate\n"
      "poses are sent on a clock and the daemon answers the newest, dropping the rest.",
      kFlags,
      "  horizon session data/dem/rainier_summit_srtm3_400x400.tif --path examples/rainier_flight.csv \\\n"
      "      --boxes examples/rainier_boxes.csv --lonlat --absolute --level-size 128 --conservative\n"
      "  horizon session rainier --server localhost:50051 --path examples/rainier_flight.csv \\\n"
      "      --boxes examples/rainier_boxes.csv --lonlat --absolute --rate 60\n",
      run_session,
  };
  return command;
}

}  // namespace horizon::cli
