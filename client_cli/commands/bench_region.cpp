// `horizon bench --region DEM...`: flags -> evaluation::RegionBenchConfig;
// report -> CSV, Markdown, one chart per DEM and a summary on stdout.
#include "commands/bench_region.hpp"

#include <cctype>
#include <filesystem>
#include <iostream>

#include "commands/bench_out.hpp"
#include "commands/command.hpp"
#include "horizon/evaluation/region_bench.hpp"
#include "inputs.hpp"
#include "interrupt.hpp"
#include "output.hpp"
#include "progress.hpp"

namespace horizon::cli {
namespace {

namespace fs = std::filesystem;

std::vector<double> number_list(const Args& args, std::string_view flag) {
  const std::string text = *args.text(flag);
  const CsvNumbers n = parse_csv_numbers(text);
  if (n.blank || !n.numeric || n.values.empty())
    throw UsageError(std::string(flag) + ": expected comma-separated numbers, got '" + text + "'");
  return n.values;
}

std::vector<int> integer_list(const Args& args, std::string_view flag, int lo, int hi) {
  std::vector<int> out;
  for (double v : number_list(args, flag)) {
    if (v != std::floor(v) || v < lo || v > hi)
      throw UsageError(std::string(flag) + ": each must be a whole number in [" + std::to_string(lo) + ", " +
                       std::to_string(hi) + "], got " + fixed(v, 3));
    out.push_back(static_cast<int>(v));
  }
  return out;
}

evaluation::RegionBenchConfig parse_config(const Args& args) {
  for (std::string_view f : kViewshedOnlyFlags)
    if (args.has(f)) throw UsageError(std::string(f) + ": not a flag of the region sweep (--region)");
  evaluation::RegionBenchConfig c;
  c.dems = args.positionals();
  if (c.dems.empty()) throw UsageError("missing DEM operand (one or more DEM files)");
  if (args.has("--sizes")) {
    c.sizes = number_list(args, "--sizes");
    for (double s : c.sizes)
      if (!(s > 0)) throw UsageError("--sizes: each region side must be a positive number of metres");
  }
  if (args.has("--face-resolutions")) c.face_resolutions = integer_list(args, "--face-resolutions", 8, 65536);
  if (args.has("--splits")) c.footprint_splits = integer_list(args, "--splits", 1, 16);
  if (auto n = args.positive_integer("--seed-rows")) {
    if (*n < 8 || *n > 4096) throw UsageError("--seed-rows: must be a whole number in [8, 4096]");
    c.seed_rows = static_cast<int>(*n);
    if (!args.has("--splits")) c.footprint_splits = {1, 2};
  }
  if (args.has("--rows")) {
    c.fuzzy_rows = integer_list(args, "--rows", 0, 65536);
    for (int r : c.fuzzy_rows)
      if (r == 1) throw UsageError("--rows: 0 (the continuous cover) or at least 2 rows, got 1");
  }
  if (args.has("--heights")) {
    const std::vector<double> z = number_list(args, "--heights");
    if (z.size() != 2 || z[0] < 0 || z[0] > z[1])
      throw UsageError("--heights: expected ZMIN,ZMAX metres above the ground with 0 <= ZMIN <= ZMAX");
    c.z_min = z[0];
    c.z_max = z[1];
  }
  if (auto n = args.positive_integer("--regions")) c.regions = *n;
  if (auto n = args.non_negative_integer("--check")) c.check_points = static_cast<int>(*n);
  c.repeats = args.positive_integer("--repeats").value_or(3);
  c.warmup = static_cast<int>(args.non_negative_integer("--warmup").value_or(1));
  c.target_height = args.non_negative("--target-height").value_or(1.5);
  if (auto d = args.non_negative("--max-distance")) {
    if (*d <= 0) throw UsageError("--max-distance: must be positive");
    c.max_distance = *d;
  }
  c.curvature = args.non_negative("--curvature").value_or(0.85714);
  c.threads = args.non_negative_integer("--threads").value_or(0);
  return c;
}

std::string command_line(const Args& args, const evaluation::RegionBenchConfig& c) {
  std::string command = "horizon bench --region";
  for (const std::string& d : c.dems) command += " " + d;
  for (std::string_view f :
       {"--sizes", "--face-resolutions", "--splits", "--rows", "--seed-rows", "--heights", "--regions", "--check",
        "--repeats", "--warmup", "--target-height", "--max-distance", "--curvature", "--threads"})
    if (auto v = args.text(f)) {
      command += ' ';
      command += f;
      command += ' ';
      command += *v;
    }
  return command;
}

}  // namespace

std::string dem_slug(const std::string& dem) {
  std::string s = fs::path(dem).stem().string();
  for (char& ch : s)
    if (!std::isalnum(static_cast<unsigned char>(ch)) && ch != '_' && ch != '-') ch = '_';
  return s;
}

int run_region_bench(const Args& args) {
  const evaluation::RegionBenchConfig config = parse_config(args);
  const auto made = bench_out_dir(args);
  if (!made.ok()) return report_error(made.error());
  const std::string& out_dir = *made;

  InterruptScope interrupt;
  RunControl control;
  control.cancel = &interrupt.token();
  ProgressBar progress("horizon bench --region", std::chrono::milliseconds(0));
  control.progress = progress.callback();
  auto report = evaluation::run_region_bench(config, &control);
  progress.finish();
  if (!report.ok()) return report_error(report.error());
  if (report->rows.empty()) {
    for (const std::string& n : report->notes) std::cerr << "horizon: note: " << n << '\n';
    return report_error(make_error(ErrorCode::kDataError, "no region could be classified", "dems"));
  }

  const std::string command = command_line(args, config);
  const std::string csv = (fs::path(out_dir) / "bench_region.csv").string();
  if (auto s = evaluation::write_region_csv(csv, report->rows); !s.ok()) return report_error(s.error());
  const std::string md = (fs::path(out_dir) / "bench_region.md").string();
  if (auto s = evaluation::write_region_markdown(md, *report, command); !s.ok()) return report_error(s.error());
  if (auto extra = args.text("--markdown"))
    if (auto s = evaluation::write_region_markdown(*extra, *report, command); !s.ok()) return report_error(s.error());

  // One chart per DEM: time against the undetermined share, a colour per region size.
  const std::vector<evaluation::Aggregate> aggregates = evaluation::aggregate_regions(report->rows);
  std::vector<std::string> charts;
  for (const std::string& dem : config.dems) {
    const std::string name = fs::path(dem).filename().string();
    std::vector<evaluation::Aggregate> group;
    for (const evaluation::Aggregate& a : aggregates)
      if (a.dem == name) group.push_back(a);
    if (group.empty()) continue;
    const std::string path = (fs::path(out_dir) / ("region_" + dem_slug(dem) + ".png")).string();
    const std::string title = name + ": from-region cells left undetermined against time (" +
                              std::to_string(group.front().observers) + " regions)";
    if (auto s = evaluation::write_chart(path, group, title, evaluation::region_chart_text()); !s.ok())
      return report_error(s.error());
    charts.push_back(path);
  }

  std::cout << "From-region runtime against undecided cells, " << report->rows.size() << " runs\n";
  std::string current;
  std::uint64_t wrong = 0;
  for (const auto& r : report->rows) wrong += r.wrong;
  for (const evaluation::Aggregate& a : aggregates) {
    if (a.dem != current) {
      current = a.dem;
      std::cout << "\n  " << a.dem << " (" << a.observers << " regions)\n";
    }
    std::string size = a.algorithm;
    size.resize(16, ' ');
    std::string setting = a.setting;
    setting.resize(14, ' ');
    std::cout << "    " << size << setting << (a.is_default ? "* " : "  ") << fixed(a.seconds * 1e3, 1)
              << " ms  decided " << fixed(100 * a.iou, 1) << " %" << (a.on_front ? "  front" : "") << '\n';
  }
  if (config.check_points > 0)
    std::cout << "\n  R3 check: " << wrong << " wrong verdicts (corners, edges, faces and " << config.check_points
              << " interior viewpoints a region)\n";
  for (const std::string& n : report->notes) std::cout << "  note: " << n << '\n';
  std::cout << "\nWrote " << csv << ", " << md;
  for (const std::string& c : charts) std::cout << ", " << c;
  std::cout << '\n';
  // A wrong verdict is a bug in the method, not a slow setting: say so in the status.
  return wrong == 0 ? kExitOk
                    : report_error(make_error(ErrorCode::kInternal,
                                              std::to_string(wrong) + " from-region verdicts contradict R3", "region"));
}

}  // namespace horizon::cli
