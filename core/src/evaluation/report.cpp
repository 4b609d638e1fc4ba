// report.cpp — pooling bench rows per setting, the Pareto front, CSV and
// Markdown (bench.hpp).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <map>
#include <set>
#include <sstream>

#include "horizon/evaluation/bench.hpp"

namespace horizon::evaluation {
namespace {

std::string fmt(const char* f, double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, f, v);
  return buf;
}

void add(Aggregate& a, const BenchRow& r, double& sq_weighted) {
  a.observers += 1;
  a.seconds += r.seconds_median;
  a.cells_compared += r.error.cells_compared;
  a.reference_visible += r.error.reference_visible;
  a.missed += r.error.missed_visible;
  a.extra += r.error.extra_visible;
  a.both += r.error.both_visible;
  sq_weighted += r.error.ohf_rmse * r.error.ohf_rmse * double(r.error.cells_compared);
  a.ohf_max = std::isnan(r.error.ohf_max_error) || std::isnan(a.ohf_max) ? std::nan("")
                                                                         : std::max(a.ohf_max, r.error.ohf_max_error);
}

void finish(Aggregate& a, double sq_weighted) {
  const double united = double(a.both + a.missed + a.extra);
  a.iou = united > 0 ? double(a.both) / united : 1.0;
  a.missed_rate = a.reference_visible ? double(a.missed) / double(a.reference_visible) : 0.0;
  a.extra_rate = a.reference_visible ? double(a.extra) / double(a.reference_visible) : 0.0;
  a.ohf_rmse = a.cells_compared ? std::sqrt(sq_weighted / double(a.cells_compared)) : 0.0;
  if (std::isnan(a.ohf_max)) a.ohf_rmse = std::nan("");
}

std::string csv_field(const std::string& s) {
  if (s.find_first_of(",\"\n") == std::string::npos) return s;
  std::string out = "\"";
  for (char c : s) out += c == '"' ? std::string("\"\"") : std::string(1, c);
  return out + "\"";
}

std::string time_text(double seconds) {
  if (seconds < 1.0) return fmt("%.1f ms", seconds * 1e3);
  return fmt("%.2f s", seconds);
}

std::string percent(double v) {
  return std::isnan(v) ? "n/a" : fmt("%.3f%%", 100.0 * v);
}
std::string metres(double v) {
  return std::isnan(v) ? "n/a" : fmt("%.2f", v);
}

}  // namespace

void mark_front(std::vector<Aggregate*>& group) {
  for (Aggregate* a : group) {
    a->on_front = true;
    for (const Aggregate* b : group) {
      if (a == b) continue;
      const bool no_worse = b->seconds <= a->seconds && b->error() <= a->error();
      const bool better = b->seconds < a->seconds || b->error() < a->error();
      if (no_worse && better) {
        a->on_front = false;
        break;
      }
    }
  }
}

std::vector<Aggregate> aggregate(const std::vector<BenchRow>& input, bool overall) {
  // A peer's setting is its command line, which names the observer: pool
  // peers by name.
  std::vector<BenchRow> rows = input;
  for (BenchRow& r : rows)
    if (r.is_peer) r.setting = r.algorithm;
  std::vector<std::string> dems;  // first-seen order
  std::vector<std::pair<std::string, std::string>> settings;
  for (const BenchRow& r : rows) {
    if (std::find(dems.begin(), dems.end(), r.dem) == dems.end()) dems.push_back(r.dem);
    const auto key = std::make_pair(r.algorithm, r.setting);
    if (std::find(settings.begin(), settings.end(), key) == settings.end()) settings.push_back(key);
  }
  std::vector<Aggregate> out;
  // Pools the rows of one DEM (or all, dem_filter empty) per setting. Across
  // DEMs only settings measured on every observer of every DEM are pooled,
  // so their times add up over the same work.
  auto pool = [&](const std::string& dem_filter) {
    std::map<std::string, std::set<std::string>> observers_of_dem;
    for (const BenchRow& r : rows)
      if (dem_filter.empty() || r.dem == dem_filter) observers_of_dem[r.dem].insert(r.observer);
    const std::size_t first = out.size();
    for (const auto& [algorithm, setting] : settings) {
      Aggregate a;
      a.dem = dem_filter;
      a.algorithm = algorithm;
      a.setting = setting;
      double sq = 0;
      std::map<std::string, std::set<std::string>> seen;
      for (const BenchRow& r : rows) {
        if (r.algorithm != algorithm || r.setting != setting) continue;
        if (!dem_filter.empty() && r.dem != dem_filter) continue;
        a.is_default = r.is_default;
        a.is_peer = r.is_peer;
        seen[r.dem].insert(r.observer);
        add(a, r, sq);
      }
      if (a.observers == 0) continue;
      if (dem_filter.empty() && seen != observers_of_dem) continue;
      finish(a, sq);
      out.push_back(a);
    }
    std::vector<Aggregate*> group;
    for (std::size_t i = first; i < out.size(); ++i) group.push_back(&out[i]);
    mark_front(group);
  };
  for (const std::string& d : dems) pool(d);
  if (overall && dems.size() > 1) pool("");
  return out;
}

Status write_csv(const std::string& path, const std::vector<BenchRow>& rows) {
  std::ofstream out(path);
  if (!out) return make_error(ErrorCode::kIoError, "cannot write CSV '" + path + "'", path);
  out << "dem,epsg,width,height,observer,col,row,x,y,algorithm,setting,default,peer,timing,repeats,"
         "seconds_median,seconds_min,cells_evaluated,cells_compared,reference_visible,missed_visible,extra_visible,"
         "iou,missed_rate,extra_rate,ohf_rmse_m,ohf_max_error_m\n";
  char buf[512];
  for (const BenchRow& r : rows) {
    std::snprintf(buf, sizeof buf, "%d,%d,%d,%s,%d,%d,%.6f,%.6f", r.epsg, r.dem_width, r.dem_height,
                  csv_field(r.observer).c_str(), r.col, r.row, r.x, r.y);
    out << csv_field(r.dem) << ',' << buf << ',' << csv_field(r.algorithm) << ',' << csv_field(r.setting) << ','
        << (r.is_default ? 1 : 0) << ',' << (r.is_peer ? 1 : 0) << ',' << csv_field(r.timing) << ',' << r.repeats;
    std::snprintf(buf, sizeof buf, ",%.6f,%.6f,%llu,%llu,%llu,%llu,%llu,%.6f,%.6f,%.6f,%.4f,%.4f", r.seconds_median,
                  r.seconds_min, static_cast<unsigned long long>(r.cells_evaluated),
                  static_cast<unsigned long long>(r.error.cells_compared),
                  static_cast<unsigned long long>(r.error.reference_visible),
                  static_cast<unsigned long long>(r.error.missed_visible),
                  static_cast<unsigned long long>(r.error.extra_visible), r.error.iou, r.error.missed_rate,
                  r.error.extra_rate, r.error.ohf_rmse, r.error.ohf_max_error);
    out << buf << '\n';
  }
  out.close();
  if (!out) return make_error(ErrorCode::kIoError, "cannot write CSV '" + path + "'", path);
  return Status::Ok();
}

Status write_markdown(const std::string& path, const BenchReport& report, const std::vector<Aggregate>& aggregates,
                      const std::string& command) {
  std::ostringstream md;
  md << "Generated by:\n\n```\n"
     << command << "\n```\n\n"
     << "Time: compute time of one viewshed (median of the timed runs), summed over the DEM's observers; "
        "peers: gdal_viewshed as a whole process, GRASS the r.viewshed module alone. Error against R3, "
        "pooled over the observers (observer cell and its 8 neighbours excluded). "
        "**bold** = default setting; \"front\" = on the Pareto front of time against 1 - IoU.\n";
  std::string current = "\x01";
  for (const Aggregate& a : aggregates) {
    if (a.dem != current) {
      current = a.dem;
      std::string dem_line = a.dem.empty() ? "All DEMs pooled" : "`" + a.dem + "`";
      for (const BenchRow& r : report.rows)
        if (!a.dem.empty() && r.dem == a.dem) {
          dem_line += " (" + std::to_string(r.dem_width) + "x" + std::to_string(r.dem_height) +
                      ", EPSG:" + std::to_string(r.epsg) + ")";
          break;
        }
      md << "\n#### " << dem_line << ", " << a.observers << " observers\n\n"
         << "| algorithm | setting | time | IoU | missed visible | extra visible | OHF RMSE (m) | OHF max (m) | front "
            "|\n"
         << "|---|---|---:|---:|---:|---:|---:|---:|:---:|\n";
    }
    std::string setting = a.is_peer ? "(peer)" : a.setting;
    if (a.is_default) setting = "**" + setting + "**";
    md << "| " << a.algorithm << " | " << setting << " | " << time_text(a.seconds) << " | " << percent(a.iou) << " | "
       << percent(a.missed_rate) << " | " << percent(a.extra_rate) << " | " << metres(a.ohf_rmse) << " | "
       << metres(a.ohf_max) << " | " << (a.on_front ? "front" : "") << " |\n";
  }
  if (!report.notes.empty()) {
    md << "\nNotes:\n";
    for (const std::string& n : report.notes) md << "- " << n << "\n";
  }
  std::ofstream out(path);
  out << md.str();
  out.close();
  if (!out) return make_error(ErrorCode::kIoError, "cannot write Markdown '" + path + "'", path);
  return Status::Ok();
}

}  // namespace horizon::evaluation
