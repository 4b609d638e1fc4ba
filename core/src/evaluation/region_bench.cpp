// region_bench.cpp — the from-region sweep (region_bench.hpp): regions
// placed on valid ground, classified at every setting, timed and counted,
// their verdicts checked with R3; pooled, CSV and Markdown.
#include "horizon/evaluation/region_bench.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <random>
#include <tuple>

#include "horizon/evaluation/region_check.hpp"
#include "horizon/evaluation/seed_fuzzy.hpp"
#include "horizon/region/region.hpp"
#include "horizon/terrain/dem_reader.hpp"

namespace horizon::evaluation {
namespace {

Error bad(const std::string& field, const std::string& what) {
  return make_error(ErrorCode::kInvalidArgument, field + ": " + what, field);
}

Status validate(const RegionBenchConfig& c) {
  if (c.dems.empty()) return bad("dems", "no DEM given");
  if (c.regions < 1) return bad("regions", "must be at least 1");
  if (c.sizes.empty()) return bad("sizes", "no region size given");
  for (double s : c.sizes)
    if (!(std::isfinite(s) && s > 0)) return bad("sizes", "each region size must be a positive number of metres");
  if (c.face_resolutions.empty()) return bad("face_resolutions", "no resolution given");
  for (int f : c.face_resolutions)
    if (f < 8 || f > 65536) return bad("face_resolutions", "each must be in [8, 65536], got " + std::to_string(f));
  if (c.fuzzy_rows.empty()) return bad("fuzzy_rows", "no rows given (0: the continuous cover)");
  for (int r : c.fuzzy_rows)
    if (r != 0 && (r < 2 || r > 65536))
      return bad("fuzzy_rows", "each must be 0 or in [2, 65536], got " + std::to_string(r));
  if (c.seed_rows != 0 && (c.seed_rows < 8 || c.seed_rows > 4096))
    return bad("seed_rows", "must be 0 (no seed construction) or in [8, 4096], got " + std::to_string(c.seed_rows));
  if (c.seed_rows != 0 &&
      std::find(c.footprint_splits.begin(), c.footprint_splits.end(), 1) == c.footprint_splits.end())
    return bad("footprint_splits", "the seed's construction answers the region as one piece: include split 1");
  if (c.seed_rows != 0 && std::find(c.fuzzy_rows.begin(), c.fuzzy_rows.end(), 0) == c.fuzzy_rows.end())
    return bad("fuzzy_rows", "the seed's construction is compared with the continuous cover: include rows 0");
  for (int f : c.face_resolutions)
    if (c.seed_rows != 0 && f > 4096)
      return bad("face_resolutions", "the seed's array takes at most 4096 columns, got " + std::to_string(f));
  if (c.footprint_splits.empty()) return bad("footprint_splits", "no split given");
  for (int s : c.footprint_splits)
    if (s < 1 || s > 16) return bad("footprint_splits", "each must be in [1, 16], got " + std::to_string(s));
  if (!(std::isfinite(c.z_min) && std::isfinite(c.z_max) && c.z_min >= 0 && c.z_min <= c.z_max))
    return bad("heights", "need 0 <= z_min <= z_max metres above the ground");
  if (!(std::isfinite(c.max_distance) && c.max_distance > 0))
    return bad("max_distance", "must be a positive number of metres");
  if (c.repeats < 1) return bad("repeats", "must be at least 1");
  if (c.warmup < 0) return bad("warmup", "must be >= 0");
  if (c.check_points < 0) return bad("check_points", "must be >= 0");
  return Status::Ok();
}

double median_of(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  const std::size_t m = v.size() / 2;
  return v.size() % 2 ? v[m] : 0.5 * (v[m - 1] + v[m]);
}

// Centres on valid ground (the cell and its 8 neighbours hold data) in the
// middle 60 % of the DEM, drawn with a fixed seed.
std::vector<std::pair<int, int>> pick_centres(const terrain::Dem& dem, int count) {
  std::mt19937 rng(20261204);
  std::uniform_real_distribution<double> u(0.2, 0.8);
  std::vector<std::pair<int, int>> out;
  for (int tries = 0; tries < 10000 && static_cast<int>(out.size()) < count; ++tries) {
    const int c = static_cast<int>(u(rng) * dem.width()), r = static_cast<int>(u(rng) * dem.height());
    bool ok = c >= 1 && r >= 1 && c + 1 < dem.width() && r + 1 < dem.height();
    for (int dr = -1; ok && dr <= 1; ++dr)
      for (int dc = -1; ok && dc <= 1; ++dc) ok = !std::isnan(dem.elevation.at(c + dc, r + dr));
    if (ok) out.emplace_back(c, r);
  }
  return out;
}

// The square footprint of `side` ground metres centred on cell (col, row):
// its half-sizes in CRS units from the metres a cell spans there.
Result<region::RegionSpec> square_region(const terrain::Dem& dem, int col, int row, double side,
                                         const RegionBenchConfig& config) {
  const auto& t = dem.georef.transform;
  const double x = t.origin_x + (col + 0.5) * t.pixel_width, y = t.origin_y + (row + 0.5) * t.pixel_height;
  region::RegionSpec probe{.x_min = x - 0.25 * std::abs(t.pixel_width),
                           .y_min = y - 0.25 * std::abs(t.pixel_height),
                           .x_max = x + 0.25 * std::abs(t.pixel_width),
                           .y_max = y + 0.25 * std::abs(t.pixel_height),
                           .z_min = config.z_min,
                           .z_max = config.z_max};
  auto frame = region::resolve_region(dem, probe, {});
  if (!frame.ok()) return frame.error();
  const double hx = 0.5 * side / frame->metres_per_col * std::abs(t.pixel_width);
  const double hy = 0.5 * side / frame->metres_per_row * std::abs(t.pixel_height);
  region::RegionSpec s = probe;
  s.x_min = x - hx;
  s.x_max = x + hx;
  s.y_min = y - hy;
  s.y_max = y + hy;
  return s;
}

std::string fmt(const char* f, double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, f, v);
  return buf;
}

std::string size_label(double m) {
  return fmt("%g", m) + " m region";
}
std::string setting_label(const std::string& construction, int face, int splits, int rows) {
  if (construction == "seed") return "seed " + std::to_string(face) + "x" + std::to_string(rows);
  std::string s = std::to_string(face);
  if (splits != 2) s += ", " + std::to_string(splits) + "x" + std::to_string(splits);
  if (rows > 0) s += ", " + std::to_string(rows) + " rows";
  return s;
}

}  // namespace

Result<RegionBenchReport> run_region_bench(const RegionBenchConfig& config, const RunControl* control) {
  HORIZON_RETURN_IF_ERROR(validate(config));
  RegionBenchReport report;
  const double units = double(config.dems.size()) * config.regions * double(config.sizes.size());
  double done = 0;
  for (const std::string& path : config.dems) {
    auto dem = terrain::read_dem(path);
    if (!dem.ok()) return dem.error();
    const std::string name = std::filesystem::path(path).filename().string();
    const auto centres = pick_centres(*dem, config.regions);
    if (static_cast<int>(centres.size()) < config.regions)
      report.notes.push_back(name + ": only " + std::to_string(centres.size()) + " region centres on valid ground");
    for (std::size_t k = 0; k < centres.size(); ++k) {
      const auto [col, row] = centres[k];
      for (double side : config.sizes) {
        HORIZON_RETURN_IF_ERROR(check_control(control));
        auto spec = square_region(*dem, col, row, side, config);
        if (!spec.ok()) return spec.error();
        RegionBenchRow proto;
        proto.dem = name;
        proto.region = "region " + std::to_string(k + 1);
        proto.x_min = spec->x_min;
        proto.y_min = spec->y_min;
        proto.x_max = spec->x_max;
        proto.y_max = spec->y_max;
        proto.size_m = side;
        bool skipped = false;
        for (int splits : config.footprint_splits)
          for (int face : config.face_resolutions)
            for (int rows : config.fuzzy_rows) {
              if (skipped) break;
              HORIZON_RETURN_IF_ERROR(check_control(control));
              region::RegionOptions options;
              options.face_resolution = face;
              options.footprint_splits = splits;
              options.fuzzy_rows = rows;
              options.curvature_coefficient = config.curvature;
              options.target_height = config.target_height;
              options.max_distance = config.max_distance;
              options.threads = config.threads;
              std::vector<double> times;
              Result<region::RegionCellsResult> res = make_error(ErrorCode::kInternal, "not run");
              for (int i = 0; i < config.warmup + config.repeats; ++i) {
                const auto start = std::chrono::steady_clock::now();
                res = region::classify_cells(*dem, *spec, options, control);
                const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
                if (!res.ok()) break;
                if (i >= config.warmup) times.push_back(s);
              }
              if (!res.ok()) {
                if (res.error().code == ErrorCode::kCancelled || res.error().code == ErrorCode::kDeadlineExceeded)
                  return res.error();
                // A footprint off the DEM or over voids alone: that region at that size is left out.
                report.notes.push_back(name + ", " + proto.region + ", " + size_label(side) +
                                       ": skipped: " + res.error().message);
                skipped = true;
                break;
              }
              RegionBenchRow r = proto;
              r.face_resolution = face;
              r.footprint_splits = splits;
              r.fuzzy_rows = rows;
              r.repeats = config.repeats;
              r.seconds_median = median_of(times);
              r.seconds_min = *std::min_element(times.begin(), times.end());
              const region::RegionStats& st = res->stats;
              r.cells = st.items;
              r.always_hidden = st.always_hidden;
              r.always_visible = st.always_visible;
              r.undetermined = st.undetermined;
              r.walls_swept = st.walls_swept;
              r.wall_nodes_read = st.wall_nodes_read;
              r.pyramid_cells_read = st.pyramid_cells_read;
              // The R3 check, from one sampling of the region for every row of this setting.
              const auto viewpoints = config.check_points > 0
                                          ? sample_region(*dem, *spec, res->frame, {8, config.check_points, 1})
                                          : std::vector<geodesy::GridPoint>{};
              const auto check_into = [&](RegionBenchRow& out, const region::RegionCellsResult& cells) {
                if (viewpoints.empty()) return;
                const RegionCheck c = check_cells(*dem, cells, options, viewpoints, config.check_cells, config.threads);
                out.checked_cells = c.items_checked;
                out.viewpoints = c.viewpoints;
                out.wrong = c.wrong_hidden + c.wrong_visible;
                out.sampled_hidden = c.sampled_hidden;
                out.hidden_checked = c.hidden_checked;
              };
              check_into(r, *res);
              const bool with_seed = config.seed_rows > 0 && splits == 1 && rows == 0;
              report.rows.push_back(std::move(r));
              if (!with_seed) continue;
              // The seed's construction (seed_fuzzy.hpp) on the same cells, one piece, `face` columns.
              const SeedFuzzyOptions so{
                  .columns = face, .rows = config.seed_rows, .target_height = config.target_height};
              std::vector<double> seed_times;
              Result<SeedFuzzyResult> seed = make_error(ErrorCode::kInternal, "not run");
              for (int i = 0; i < config.warmup + config.repeats; ++i) {
                seed = seed_fuzzy_hidden(*dem, *res, so, control);
                if (!seed.ok()) return seed.error();
                if (i >= config.warmup) seed_times.push_back(seed->stats.seconds);
              }
              RegionBenchRow s = proto;
              s.construction = "seed";
              s.face_resolution = face;
              s.footprint_splits = 1;
              s.fuzzy_rows = config.seed_rows;
              s.repeats = config.repeats;
              s.seconds_median = median_of(seed_times);
              s.seconds_min = *std::min_element(seed_times.begin(), seed_times.end());
              s.cells = seed->stats.items;
              s.always_hidden = seed->stats.always_hidden;
              s.undetermined = s.cells - s.always_hidden;
              s.patches = seed->stats.patches;
              s.sub_surfaces = seed->stats.sub_surfaces;
              s.not_umbra = seed->stats.not_umbra;
              s.too_deep = seed->stats.too_deep;
              s.off_array = seed->stats.off_array;
              s.elements = seed->stats.elements;
              s.umbra_elements = seed->stats.umbra_elements;
              for (int j = 0; j < res->codes.height(); ++j)
                for (int i = 0; i < res->codes.width(); ++i)
                  s.seed_only += seed->codes.at(i, j) == 0 && res->codes.at(i, j) != 0;
              region::RegionCellsResult as_cells;  // the seed's verdicts, checked as a classification
              as_cells.window = seed->window;
              as_cells.frame = res->frame;
              as_cells.codes = std::move(seed->codes);
              check_into(s, as_cells);
              report.rows.push_back(std::move(s));
            }
        done += 1;
        report_progress(control, done / units);
      }
    }
  }
  return report;
}

std::vector<Aggregate> aggregate_regions(const std::vector<RegionBenchRow>& rows) {
  // Keyed by (DEM, size, splits, face, rows) in first-seen order of the DEMs.
  std::vector<Aggregate> out;
  std::map<std::tuple<std::string, double, int, int, int, std::string>, std::size_t> index;
  std::vector<std::pair<std::uint64_t, std::uint64_t>> counts;  // decided, cells
  for (const RegionBenchRow& r : rows) {
    const auto key =
        std::make_tuple(r.dem, r.size_m, r.footprint_splits, r.face_resolution, r.fuzzy_rows, r.construction);
    auto [it, fresh] = index.try_emplace(key, out.size());
    if (fresh) {
      Aggregate a;
      a.dem = r.dem;
      a.algorithm = size_label(r.size_m) + (r.construction == "seed" ? " (seed)" : "");
      a.setting = setting_label(r.construction, r.face_resolution, r.footprint_splits, r.fuzzy_rows);
      a.is_default = r.face_resolution == region::RegionOptions{}.face_resolution &&
                     r.footprint_splits == region::RegionOptions{}.footprint_splits && r.fuzzy_rows == 0 &&
                     r.construction == "walls";
      out.push_back(a);
      counts.emplace_back(0, 0);
    }
    Aggregate& a = out[it->second];
    a.observers += 1;
    a.seconds += r.seconds_median;
    counts[it->second].first += r.always_hidden + r.always_visible;
    counts[it->second].second += r.cells;
  }
  for (std::size_t i = 0; i < out.size(); ++i)
    out[i].iou = counts[i].second ? double(counts[i].first) / double(counts[i].second) : 1.0;
  // Region sizes are the question, not a knob: the front is per size.
  std::map<std::pair<std::string, std::string>, std::vector<Aggregate*>> groups;
  for (Aggregate& a : out) groups[{a.dem, a.algorithm}].push_back(&a);
  for (auto& [key, group] : groups) mark_front(group);
  return out;
}

Status write_region_csv(const std::string& path, const std::vector<RegionBenchRow>& rows) {
  const std::string tmp = path + ".tmp";
  {
    std::ofstream f(tmp);
    if (!f) return make_error(ErrorCode::kIoError, "cannot write '" + path + "'", path);
    f << "dem,region,x_min,y_min,x_max,y_max,size_m,construction,face_resolution,footprint_splits,fuzzy_rows,repeats,"
         "seconds_median,seconds_min,cells,"
         "always_hidden,always_visible,undetermined,decided,walls_swept,wall_nodes_read,pyramid_cells_read,"
         "checked_cells,viewpoints,wrong,sampled_hidden,hidden_checked,patches,sub_surfaces,not_umbra,too_deep,"
         "off_array,elements,umbra_elements,seed_only\n";
    for (const RegionBenchRow& r : rows)
      f << r.dem << ',' << r.region << ',' << fmt("%.9g", r.x_min) << ',' << fmt("%.9g", r.y_min) << ','
        << fmt("%.9g", r.x_max) << ',' << fmt("%.9g", r.y_max) << ',' << r.size_m << ',' << r.construction << ','
        << r.face_resolution << ',' << r.footprint_splits << ',' << r.fuzzy_rows << ',' << r.repeats << ','
        << fmt("%.6f", r.seconds_median) << ',' << fmt("%.6f", r.seconds_min) << ',' << r.cells << ','
        << r.always_hidden << ',' << r.always_visible << ',' << r.undetermined << ',' << fmt("%.5f", r.decided()) << ','
        << r.walls_swept << ',' << r.wall_nodes_read << ',' << r.pyramid_cells_read << ',' << r.checked_cells << ','
        << r.viewpoints << ',' << r.wrong << ',' << r.sampled_hidden << ',' << r.hidden_checked << ',' << r.patches
        << ',' << r.sub_surfaces << ',' << r.not_umbra << ',' << r.too_deep << ',' << r.off_array << ',' << r.elements
        << ',' << r.umbra_elements << ',' << r.seed_only << '\n';
    if (!f.flush()) return make_error(ErrorCode::kIoError, "cannot write '" + path + "'", path);
  }
  std::error_code ec;
  std::filesystem::rename(tmp, path, ec);
  if (ec) return make_error(ErrorCode::kIoError, "cannot write '" + path + "': " + ec.message(), path);
  return Status::Ok();
}

Status write_region_markdown(const std::string& path, const RegionBenchReport& report, const std::string& command) {
  struct Pool {
    std::string dem;
    double size = 0;
    std::string construction;
    int face = 0, splits = 0, rows = 0, regions = 0;
    double seconds = 0;
    std::uint64_t cells = 0, hidden = 0, visible = 0, undetermined = 0, wrong = 0, checked = 0, sampled_hidden = 0,
                  hidden_checked = 0;
  };
  std::vector<Pool> pools;
  for (const RegionBenchRow& r : report.rows) {
    auto it = std::find_if(pools.begin(), pools.end(), [&](const Pool& p) {
      return p.dem == r.dem && p.size == r.size_m && p.face == r.face_resolution && p.splits == r.footprint_splits &&
             p.rows == r.fuzzy_rows && p.construction == r.construction;
    });
    if (it == pools.end()) {
      pools.push_back({.dem = r.dem,
                       .size = r.size_m,
                       .construction = r.construction,
                       .face = r.face_resolution,
                       .splits = r.footprint_splits,
                       .rows = r.fuzzy_rows});
      it = pools.end() - 1;
    }
    it->regions += 1;
    it->seconds += r.seconds_median;
    it->cells += r.cells;
    it->hidden += r.always_hidden;
    it->visible += r.always_visible;
    it->undetermined += r.undetermined;
    it->wrong += r.wrong;
    it->checked += r.checked_cells;
    it->sampled_hidden += r.sampled_hidden;
    it->hidden_checked += r.hidden_checked;
  }
  const auto pct = [](std::uint64_t a, std::uint64_t b) {
    return b ? fmt("%.1f %%", 100.0 * double(a) / double(b)) : "-";
  };
  const std::string tmp = path + ".tmp";
  {
    std::ofstream f(tmp);
    if (!f) return make_error(ErrorCode::kIoError, "cannot write '" + path + "'", path);
    f << "<!-- " << command << " -->\n";
    std::string dem;
    for (const Pool& p : pools) {
      if (p.dem != dem) {
        dem = p.dem;
        f << "\n### " << dem << "\n\n"
          << "| region side | construction | face resolution | splits | slope rows | regions | time (sum of medians) "
             "| cells | always hidden | always visible | undetermined | wrong (R3 check) | decided of sampled-hidden "
             "|\n"
          << "|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n";
      }
      f << "| " << fmt("%g", p.size) << " m | " << p.construction << " | " << p.face << " | " << p.splits << " | "
        << (p.rows ? std::to_string(p.rows) : std::string("continuous")) << " | " << p.regions << " | "
        << (p.seconds < 1 ? fmt("%.1f ms", p.seconds * 1e3) : fmt("%.2f s", p.seconds)) << " | " << p.cells << " | "
        << pct(p.hidden, p.cells) << " | " << pct(p.visible, p.cells) << " | " << pct(p.undetermined, p.cells) << " | "
        << (p.checked ? std::to_string(p.wrong) + " of " + std::to_string(p.checked) + " cells" : std::string("-"))
        << " | " << pct(p.hidden_checked, p.sampled_hidden) << " |\n";
    }
    for (const std::string& n : report.notes) f << "\nNote: " << n << '\n';
    if (!f.flush()) return make_error(ErrorCode::kIoError, "cannot write '" + path + "'", path);
  }
  std::error_code ec;
  std::filesystem::rename(tmp, path, ec);
  if (ec) return make_error(ErrorCode::kIoError, "cannot write '" + path + "': " + ec.message(), path);
  return Status::Ok();
}

ChartText region_chart_text() {
  return {.x_axis = "time, summed over the regions (log scale)",
          .y_axis = "undetermined share of the cells (log scale)",
          .zero_line = "0",
          .notes = {"time: one", "classification;", "labels: fuzzy-array", "columns a face", "(N rows: the seed's",
                    "slope rows)"},
          .error_floor_log = 0,
          .pareto_front = false};
}

}  // namespace horizon::evaluation
