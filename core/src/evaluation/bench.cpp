// bench.cpp — the runtime-against-error sweep (bench.hpp): the knob table,
// observer picks, timing, and the error of every setting and peer against R3.
#include "horizon/evaluation/bench.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <random>

#include "horizon/evaluation/compare.hpp"
#include "horizon/evaluation/peers.hpp"
#include "horizon/geodesy/observer.hpp"
#include "horizon/terrain/dem_reader.hpp"
#include "horizon/visibility/viewshed.hpp"

namespace horizon::evaluation {
namespace {

using visibility::RayBlend;
using visibility::ViewshedOptions;

// One line per setting: algorithm, name, what it sets (on top of the request's
// options and the engine's defaults). The sweep runs them in this order. The
// engine's default for each algorithm is found by comparison, not written
// here, so the table stays right when a default changes.
void spacing_blend(ViewshedOptions& o, double spacing, RayBlend blend) {
  o.radial.ray_spacing = spacing;
  o.radial.blend = blend;
}
void gpu_knobs(ViewshedOptions& o, visibility::GpuMethod method, bool log_step) {
  o.backend = visibility::Backend::kGpu;
  o.gpu = visibility::GpuOptions{method, log_step};
}
constexpr KnobSetting kKnobTable[] = {
    {"fast", "spacing 2, resample", [](ViewshedOptions& o) { spacing_blend(o, 2.0, RayBlend::kResample); }},
    {"fast", "spacing 1.5, resample", [](ViewshedOptions& o) { spacing_blend(o, 1.5, RayBlend::kResample); }},
    {"fast", "spacing 1, resample", [](ViewshedOptions& o) { spacing_blend(o, 1.0, RayBlend::kResample); }},
    {"fast", "spacing 0.5, resample", [](ViewshedOptions& o) { spacing_blend(o, 0.5, RayBlend::kResample); }},
    {"fast", "spacing 1, resample, thinning 2",
     [](ViewshedOptions& o) {
       spacing_blend(o, 1.0, RayBlend::kResample);
       o.radial.thinning_levels = 2;
     }},
    {"fast", "spacing 2, linear", [](ViewshedOptions& o) { spacing_blend(o, 2.0, RayBlend::kLinear); }},
    {"fast", "spacing 1, linear", [](ViewshedOptions& o) { spacing_blend(o, 1.0, RayBlend::kLinear); }},
    {"fast", "spacing 0.5, linear", [](ViewshedOptions& o) { spacing_blend(o, 0.5, RayBlend::kLinear); }},
    {"fast", "spacing 0.25, linear", [](ViewshedOptions& o) { spacing_blend(o, 0.25, RayBlend::kLinear); }},
    {"fast", "spacing 2, min", [](ViewshedOptions& o) { spacing_blend(o, 2.0, RayBlend::kMin); }},
    {"fast", "spacing 1, min", [](ViewshedOptions& o) { spacing_blend(o, 1.0, RayBlend::kMin); }},
    {"fast", "spacing 0.5, min", [](ViewshedOptions& o) { spacing_blend(o, 0.5, RayBlend::kMin); }},
    {"fast", "spacing 0.25, min", [](ViewshedOptions& o) { spacing_blend(o, 0.25, RayBlend::kMin); }},
    // The same rays on the GL path (visibility/radial_sweep_gl.hpp), at the default spacing
    // and blend; run only when the bench has an EGL context (BenchConfig::gpu).
    {"fast", "gpu fragment, log-step",
     [](ViewshedOptions& o) { gpu_knobs(o, visibility::GpuMethod::kFragment, true); }},
    {"fast", "gpu compute, log-step", [](ViewshedOptions& o) { gpu_knobs(o, visibility::GpuMethod::kCompute, true); }},
    {"fast", "gpu fragment, one-step",
     [](ViewshedOptions& o) { gpu_knobs(o, visibility::GpuMethod::kFragment, false); }},
    {"fast", "gpu compute, one-step", [](ViewshedOptions& o) { gpu_knobs(o, visibility::GpuMethod::kCompute, false); }},
    {"exact", "default", nullptr},
    {"conservative", "default", nullptr},
    {"r3", "reference", nullptr},
};

// True when `o` has the engine's default knobs for its algorithm.
bool has_default_knobs(const ViewshedOptions& o) {
  const visibility::RadialOptions d;
  if (o.algorithm != visibility::Algorithm::kRadial) return true;  // the table sets no knob of the others
  return o.radial.ray_spacing == d.ray_spacing && o.radial.blend == d.blend &&
         o.radial.thinning_levels == d.thinning_levels && o.backend != visibility::Backend::kGpu;
}

std::string blend_name(RayBlend b) {
  if (b == RayBlend::kLinear) return "linear";
  if (b == RayBlend::kMin) return "min";
  if (b == RayBlend::kResample) return "resample";
  return "blend " + std::to_string(static_cast<int>(b));
}

double median_of(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  const std::size_t m = v.size() / 2;
  return v.size() % 2 ? v[m] : 0.5 * (v[m - 1] + v[m]);
}

std::string base_name(const std::string& path) {
  return std::filesystem::path(path).filename().string();
}

ObserverPick nearest_centre_at(const terrain::Dem& dem, const std::vector<float>& sorted, double pct,
                               const char* kind) {
  const float level = sorted[static_cast<std::size_t>(pct * static_cast<double>(sorted.size() - 1))];
  const float tolerance = std::max(1.0f, 0.01f * (sorted.back() - sorted.front()));
  ObserverPick best{kind, dem.width() / 2, dem.height() / 2};
  double best_d = std::numeric_limits<double>::infinity();
  const double cc = 0.5 * (dem.width() - 1), cr = 0.5 * (dem.height() - 1);
  for (int r = 1; r + 1 < dem.height(); ++r)
    for (int c = 1; c + 1 < dem.width(); ++c) {
      const float z = dem.elevation.at(c, r);
      if (std::isnan(z) || std::abs(z - level) > tolerance) continue;
      const double d = std::hypot(c - cc, r - cr);
      if (d < best_d) best_d = d, best = {kind, c, r};
    }
  return best;
}

// Status of a config field.
Status bad(const std::string& field, const std::string& what) {
  return make_error(ErrorCode::kInvalidArgument, "bench " + field + ": " + what, field);
}

Status validate(const BenchConfig& c) {
  if (c.dems.empty()) return bad("dems", "no DEM given");
  if (c.observers < 1 && c.observer_xy.empty()) return bad("observers", "need at least one observer");
  if (c.repeats < 1) return bad("repeats", "must be at least 1, got " + std::to_string(c.repeats));
  if (c.warmup < 0) return bad("warmup", "must be >= 0, got " + std::to_string(c.warmup));
  if (c.algorithms.empty()) return bad("algorithms", "no algorithm given");
  if (!c.peers.empty() && c.work_dir.empty()) return bad("work_dir", "peers need a directory for their outputs");
  return Status::Ok();
}

// Reads a peer's output raster (mask or heights) and places it on the
// reference window. The peer's grid must have the DEM's cell size; its origin
// may differ by whole cells (an output cropped to the max distance).
Result<terrain::Grid<float>> peer_on_window(const std::string& path, const terrain::Dem& dem,
                                            const terrain::Window& window) {
  terrain::ReadOptions options;
  options.allow_missing_crs = true;
  // Through the window reader (libtiff): a palette-tagged byte raster (GRASS
  // writes one) stays one band of indices instead of being expanded to RGB.
  options.window = terrain::Window{0, 0, 1 << 30, 1 << 30};
  auto peer = terrain::read_dem(path, options);
  if (!peer.ok()) return peer.error();
  const auto& t = dem.georef.transform;
  const auto& p = peer->georef.transform;
  if (std::abs(p.pixel_width - t.pixel_width) > 1e-6 * std::abs(t.pixel_width) ||
      std::abs(p.pixel_height - t.pixel_height) > 1e-6 * std::abs(t.pixel_height))
    return make_error(ErrorCode::kDataError, "peer raster '" + path + "' has another cell size than the DEM", path);
  const double dc = (p.origin_x - t.origin_x) / t.pixel_width, dr = (p.origin_y - t.origin_y) / t.pixel_height;
  const int off_c = static_cast<int>(std::lround(dc)), off_r = static_cast<int>(std::lround(dr));
  if (std::abs(dc - off_c) > 1e-3 || std::abs(dr - off_r) > 1e-3)
    return make_error(ErrorCode::kDataError, "peer raster '" + path + "' is not aligned with the DEM's cells", path);
  terrain::Grid<float> out(window.width(), window.height(), std::numeric_limits<float>::quiet_NaN());
  for (int r = 0; r < window.height(); ++r)
    for (int c = 0; c < window.width(); ++c) {
      const int pc = c + window.col0 - off_c, pr = r + window.row0 - off_r;
      if (peer->elevation.contains(pc, pr)) out.at(c, r) = peer->elevation.at(pc, pr);
    }
  return out;
}

}  // namespace

std::span<const KnobSetting> knob_table() {
  return kKnobTable;
}

std::string_view peer_name(Peer peer) {
  return peer == Peer::kGdal ? "gdal" : "grass";
}

Result<std::vector<SweepSetting>> settings_for(std::span<const std::string> algorithms) {
  std::vector<SweepSetting> out;
  for (const std::string& name : algorithms) {
    const auto algorithm = visibility::parse_algorithm(name);
    if (!algorithm)
      return make_error(ErrorCode::kInvalidArgument,
                        "bench algorithms: '" + name + "' is not an algorithm (fast, exact, conservative, r3)",
                        "algorithms");
    const std::size_t first = out.size();
    bool has_default = false;
    for (const KnobSetting& k : kKnobTable) {
      if (k.algorithm != name) continue;
      ViewshedOptions o;
      o.algorithm = *algorithm;
      if (k.apply) k.apply(o);
      out.push_back({name, std::string(k.name), has_default_knobs(o), k.apply});
      has_default = has_default || out.back().is_default;
    }
    if (out.size() == first)
      return make_error(ErrorCode::kInvalidArgument,
                        "bench algorithms: '" + name + "' has no setting in the knob table", "algorithms");
    if (!has_default && *algorithm == visibility::Algorithm::kRadial) {
      // The engine's default is none of the table's points: sweep it too.
      const visibility::RadialOptions d;
      char label[96];
      std::snprintf(label, sizeof label, "default (spacing %g, %s)", d.ray_spacing, blend_name(d.blend).c_str());
      out.insert(out.begin() + static_cast<std::ptrdiff_t>(first), SweepSetting{name, label, true, nullptr});
    }
  }
  return out;
}

std::vector<ObserverPick> pick_observers(const terrain::Dem& dem, int count, std::uint32_t seed) {
  std::vector<float> sorted;
  ObserverPick summit{"summit", 0, 0};
  float top = -std::numeric_limits<float>::infinity();
  for (int r = 0; r < dem.height(); ++r)
    for (int c = 0; c < dem.width(); ++c) {
      const float z = dem.elevation.at(c, r);
      if (std::isnan(z)) continue;
      sorted.push_back(z);
      if (z > top) top = z, summit = {"summit", c, r};
    }
  std::vector<ObserverPick> picks;
  if (sorted.empty() || count <= 0) return picks;
  std::sort(sorted.begin(), sorted.end());
  picks.push_back(summit);
  if (count > 1) picks.push_back(nearest_centre_at(dem, sorted, 0.85, "ridge"));
  if (count > 2) picks.push_back(nearest_centre_at(dem, sorted, 0.10, "valley"));
  if (count > 3) {
    const int mid = dem.height() / 2;
    for (int c = std::min(3, dem.width() - 1); c < dem.width(); ++c)
      if (!std::isnan(dem.elevation.at(c, mid))) {
        picks.push_back({"edge", c, mid});
        break;
      }
  }
  std::mt19937 rng(seed);
  std::uniform_int_distribution<int> uc(0, dem.width() - 1), ur(0, dem.height() - 1);
  for (int tries = 0; static_cast<int>(picks.size()) < count && tries < 100000; ++tries) {
    const int c = uc(rng), r = ur(rng);
    if (!std::isnan(dem.elevation.at(c, r))) picks.push_back({"random " + std::to_string(picks.size() + 1), c, r});
  }
  return picks;
}

Result<BenchReport> run_bench(const BenchConfig& config, const RunControl* control) {
  HORIZON_RETURN_IF_ERROR(validate(config));
  auto settings = settings_for(config.algorithms);
  if (!settings.ok()) return settings.error();

  BenchReport report;
  std::string gpu_skip;  // why the GPU rows are not run, if they are not
  if (config.gpu == nullptr) {
    gpu_skip = "no EGL context given (horizon bench --gpu)";
  } else {
    const gpu::DeviceInfo& d = config.gpu->device();
    report.notes.push_back("gpu rows: " + d.renderer + " (" + d.version + ", EGL " + d.platform + ")");
  }
  for (const SweepSetting& s : *settings)
    if (s.name.starts_with("gpu") && !gpu_skip.empty()) {
      report.notes.push_back("gpu rows skipped: " + gpu_skip);
      break;
    }
  std::vector<Peer> peers;
  for (Peer p : config.peers) {
    if (peer_installed(peer_name(p)))
      peers.push_back(p);
    else
      report.notes.push_back(std::string(peer_name(p)) + ": not installed, skipped (" +
                             (p == Peer::kGdal ? "gdal_viewshed, Debian gdal-bin" : "r.viewshed, Debian grass-core") +
                             ")");
  }

  const int per_dem_observers = config.observer_xy.empty() ? config.observers : int(config.observer_xy.size());
  const double total_units =
      double(config.dems.size()) * per_dem_observers * double(settings->size() + peers.size() + 1);
  double units_done = 0;
  auto progress = [&](double extra) { report_progress(control, std::min(1.0, (units_done + extra) / total_units)); };

  for (const std::string& path : config.dems) {
    auto dem = terrain::read_dem(path);
    if (!dem.ok()) return dem.error();
    std::vector<ObserverPick> picks;
    if (config.observer_xy.empty()) {
      picks = pick_observers(*dem, config.observers);
    } else {
      for (std::size_t i = 0; i < config.observer_xy.size(); ++i) {
        const auto& t = dem->georef.transform;
        const double col = t.col_at(config.observer_xy[i].first), row = t.row_at(config.observer_xy[i].second);
        const int c = static_cast<int>(std::lround(col)), r = static_cast<int>(std::lround(row));
        if (!dem->elevation.contains(c, r)) {
          report.notes.push_back(base_name(path) + ": observer " + std::to_string(i + 1) + " is outside, skipped");
          continue;
        }
        picks.push_back({"given " + std::to_string(i + 1), c, r});
      }
    }

    for (const ObserverPick& pick : picks) {
      const auto& t = dem->georef.transform;
      geodesy::PointSpec spec;
      spec.x = t.x_at(pick.col);
      spec.y = t.y_at(pick.row);
      spec.height = config.observer_height;
      auto eye = geodesy::resolve_point(*dem, spec, "observer");
      if (!eye.ok()) {
        report.notes.push_back(base_name(path) + ": " + pick.kind + " observer skipped: " + eye.error().message);
        units_done += double(settings->size() + peers.size() + 1);
        continue;
      }
      ViewshedOptions base;
      base.target_height = config.target_height;
      base.curvature_coefficient = config.curvature;
      base.max_distance = config.max_distance;
      base.threads = config.threads;
      base.backend = visibility::Backend::kCpu;  // a row on the GPU says so (its knobs set kGpu)

      BenchRow proto;
      proto.dem = base_name(path);
      proto.epsg = dem->georef.epsg;
      proto.dem_width = dem->width();
      proto.dem_height = dem->height();
      proto.observer = pick.kind;
      proto.col = pick.col;
      proto.row = pick.row;
      proto.x = spec.x;
      proto.y = spec.y;

      // The reference: R3, untimed here (R3 is also timed as a setting when asked for).
      ViewshedOptions ref_options = base;
      ref_options.algorithm = visibility::Algorithm::kR3;
      auto reference = visibility::compute_viewshed(*dem, *eye, ref_options, nullptr);
      if (!reference.ok()) return reference.error();
      units_done += 1;
      progress(0);

      for (const SweepSetting& setting : *settings) {
        HORIZON_RETURN_IF_ERROR(check_control(control));
        ViewshedOptions options = base;
        options.algorithm = *visibility::parse_algorithm(setting.algorithm);
        if (setting.apply) setting.apply(options);
        if (options.backend == visibility::Backend::kGpu && !gpu_skip.empty()) {
          units_done += 1;
          continue;
        }
        if (options.backend == visibility::Backend::kGpu && options.gpu && !options.gpu->log_step &&
            options.gpu->method == visibility::GpuMethod::kFragment &&
            std::max(reference->frame.window.width(), reference->frame.window.height()) > config.gpu_one_step_limit) {
          report.notes.push_back(base_name(path) + ", " + pick.kind + ": " + setting.name + " skipped: one draw per " +
                                 "step outward, over the one-step limit of " +
                                 std::to_string(config.gpu_one_step_limit) + " steps");
          units_done += 1;
          continue;
        }
        std::vector<double> times;
        Result<visibility::ViewshedResult> result = make_error(ErrorCode::kInternal, "not run");
        for (int i = 0; i < config.warmup + config.repeats; ++i) {
          const auto start = std::chrono::steady_clock::now();
          result = visibility::compute_viewshed(*dem, *eye, options, nullptr, config.gpu);
          const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
          if (!result.ok()) return result.error();
          if (i >= config.warmup) times.push_back(s);
          progress(double(i + 1) / double(config.warmup + config.repeats));
        }
        BenchRow row = proto;
        row.algorithm = setting.algorithm;
        row.setting = setting.name;
        row.is_default = setting.is_default;
        row.timing = "compute";
        row.repeats = config.repeats;
        row.seconds_median = median_of(times);
        row.seconds_min = *std::min_element(times.begin(), times.end());
        row.cells_evaluated = result->stats.cells_evaluated;
        if (!result->stats.gpu_fallback.empty())
          report.notes.push_back(base_name(path) + ", " + pick.kind + ": " + setting.name +
                                 " ran on the CPU: " + result->stats.gpu_fallback);
        row.error = visibility::compare_viewsheds(*result, *reference, config.target_height);
        report.rows.push_back(std::move(row));
        units_done += 1;
        progress(0);
      }

      for (Peer p : peers) {
        HORIZON_RETURN_IF_ERROR(check_control(control));
        PeerRequest q;
        q.dem_path = path;
        q.x = spec.x;
        q.y = spec.y;
        q.observer_height = config.observer_height;
        q.target_height = config.target_height;
        q.curvature = config.curvature;
        q.max_distance = config.max_distance;
        q.work_dir = config.work_dir;
        q.repeats = config.repeats;
        auto run = p == Peer::kGdal ? run_gdal_viewshed(q) : run_grass_viewshed(q);
        units_done += 1;
        progress(0);
        if (!run.ok()) {
          report.notes.push_back(base_name(path) + ", " + pick.kind + ": " + run.error().message);
          continue;
        }
        const terrain::Window& w = reference->frame.window;
        auto mask = peer_on_window(run->mask_path, *dem, w);
        std::optional<terrain::Grid<float>> heights;
        if (!run->heights_path.empty()) {
          auto h = peer_on_window(run->heights_path, *dem, w);
          if (h.ok()) heights = std::move(h).value();
        }
        std::remove(run->mask_path.c_str());
        if (!run->heights_path.empty()) std::remove(run->heights_path.c_str());
        if (!mask.ok()) {
          report.notes.push_back(base_name(path) + ", " + pick.kind + ", " + std::string(peer_name(p)) + ": " +
                                 mask.error().message);
          continue;
        }
        BenchRow row = proto;
        row.algorithm = std::string(peer_name(p));
        row.setting = run->command;
        row.is_peer = true;
        row.timing = run->timing;
        row.repeats = config.repeats;
        row.seconds_median = run->seconds_median;
        row.seconds_min = run->seconds_min;
        row.error = compare_mask(*mask, heights ? &*heights : nullptr, *reference, config.target_height);
        row.cells_evaluated = row.error.cells_compared;
        report.rows.push_back(std::move(row));
      }
    }
  }
  report_progress(control, 1.0);
  return report;
}

}  // namespace horizon::evaluation
