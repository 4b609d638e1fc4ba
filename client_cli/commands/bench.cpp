// `horizon bench DEM...`: flags -> evaluation::BenchConfig; report -> CSV,
// PNG charts, Markdown and a summary on stdout. The sweep is in
// core/src/evaluation (horizon_evaluation).
#include <algorithm>
#include <cctype>
#include <cmath>
#include <filesystem>
#include <iostream>
#include <memory>
#include <sstream>
#include <string_view>

#include "commands/bench_mesh.hpp"
#include "commands/bench_region.hpp"
#include "commands/bench_out.hpp"
#include "commands/command.hpp"
#include "horizon/evaluation/bench.hpp"
#include "inputs.hpp"
#include "interrupt.hpp"
#include "output.hpp"
#include "progress.hpp"

namespace horizon::cli {
namespace {

namespace fs = std::filesystem;

constexpr FlagSpec kFlags[] = {
    {"--observers", "", "N",
     "Observers per DEM, picked deterministically: summit, ridge, valley, edge, then random "
     "(default 4)"},
    {"--observer", "", "X,Y[;X,Y...]", "Observers in each DEM's CRS instead (';' between points)"},
    {"--algorithms", "", "LIST", "Comma-separated: fast, exact, conservative, r3 (default: all four)"},
    {"--peers", "", "LIST", "Peers to time too: gdal, grass, both 'gdal,grass' (default) or 'none'"},
    {"--repeats", "", "N", "Timed runs per setting; the median is kept (default 3)"},
    {"--warmup", "", "N", "Untimed runs before them (default 1)"},
    {"--height", "", "M", "Observer eye height above the ground, metres (default 2)"},
    {"--target-height", "", "M", "Target height above the ground, metres (default 0)"},
    {"--max-distance", "", "M", "Ground distance limit, metres (default: the whole DEM)"},
    {"--curvature", "", "C", "Curvature/refraction coefficient as GDAL's (default 0.85714)"},
    {"--threads", "", "N", "Worker threads for Horizon's algorithms (default 0 = all cores)"},
    {"--gpu", "", "", "Also run fast's GPU rows on an EGL context (the GPU, or Mesa llvmpipe without one)"},
    {"--out", "-o", "DIR", "Directory for bench.csv, bench.md and the charts (default bench-out)"},
    {"--markdown", "", "FILE", "Also write the Markdown tables to FILE"},
    // The TIN culling sweep (commands/bench_mesh.cpp).
    {"--mesh", "", "", "Sweep TIN culling instead: sectors/subsectors x cull mode, against exact sight lines"},
    {"--vertices", "", "N", "--mesh: the TIN's vertices, greedy insertion (default 10000)"},
    {"--sectors", "", "LIST", "--mesh: sectors/subsectors shapes (default 8/1,8/4,16/4,32/2)"},
    {"--cameras", "", "N",
     "--mesh: cameras above vertices drawn with a fixed seed, in turn in valleys, on slopes, on ridges and high "
     "(default 50)"},
    {"--high-eye", "", "M", "--mesh: how much higher the high cameras stand, metres (default 300)"},
    {"--exact", "", "N",
     "--mesh: of them, checked with exact sight lines over the TIN and R3 on the source DEM (default 5)"},
    // The from-region sweep (commands/bench_region.cpp).
    {"--region", "", "", "Sweep from-region visibility instead: region size x fuzzy-array resolution"},
    {"--sizes", "", "LIST", "--region: square footprints' sides, ground metres (default 30,120,480)"},
    {"--face-resolutions", "", "LIST", "--region: fuzzy-array columns a face (default 64,256,1024,4096)"},
    {"--splits", "", "LIST", "--region: footprint splits (default 2)"},
    {"--rows", "", "LIST",
     "--region: 0 for the continuous cover (default), N for the seed's fuzzy array of N slope rows, to compare"},
    {"--seed-rows", "", "N",
     "--region: also the seed's own construction (DEM triangles, sub-surfaces) on columns x N elements, one piece"},
    {"--heights", "", "ZMIN,ZMAX", "--region: viewpoint heights above the ground, metres (default 2,20)"},
    {"--regions", "", "N", "--region: region centres per DEM, on valid ground, fixed seed (default 2)"},
    {"--check", "", "N",
     "--region: check the verdicts with R3 from the corners, edges, faces and N interior points (default 200; "
     "0: no check)"},
};

constexpr std::string_view kAlgorithmNames[] = {"fast", "exact", "conservative", "r3"};

std::vector<std::string> split(const std::string& text, char sep) {
  std::vector<std::string> out;
  std::string item;
  std::istringstream in(text);
  while (std::getline(in, item, sep))
    if (!item.empty()) out.push_back(item);
  return out;
}

evaluation::BenchConfig parse_config(const Args& args) {
  evaluation::BenchConfig c;
  c.dems = args.positionals();
  if (c.dems.empty()) throw UsageError("missing DEM operand (one or more DEM files)");
  if (args.has("--observers") && args.has("--observer"))
    throw UsageError("--observers and --observer both choose the observers; give one of them");
  if (auto n = args.positive_integer("--observers")) c.observers = *n;
  if (auto list = args.text("--observer")) {
    for (const std::string& point : split(*list, ';')) {
      const auto comma = point.find(',');
      const auto x = comma == std::string::npos ? std::nullopt : parse_finite(point.substr(0, comma));
      const auto y = comma == std::string::npos ? std::nullopt : parse_finite(point.substr(comma + 1));
      if (!x || !y) throw UsageError("--observer: expected X,Y[;X,Y...] numbers, got '" + point + "'");
      c.observer_xy.emplace_back(*x, *y);
    }
    if (c.observer_xy.empty()) throw UsageError("--observer: no point given");
  }
  if (auto list = args.text("--algorithms")) {
    c.algorithms = split(*list, ',');
    if (c.algorithms.empty()) throw UsageError("--algorithms: empty list");
    for (const std::string& a : c.algorithms)
      if (std::find(std::begin(kAlgorithmNames), std::end(kAlgorithmNames), a) == std::end(kAlgorithmNames))
        throw UsageError("--algorithms: '" + a + "' is not one of fast, exact, conservative, r3");
  }
  if (auto list = args.text("--peers")) {
    c.peers.clear();
    if (*list != "none")
      for (const std::string& p : split(*list, ',')) {
        if (p == "gdal")
          c.peers.push_back(evaluation::Peer::kGdal);
        else if (p == "grass")
          c.peers.push_back(evaluation::Peer::kGrass);
        else
          throw UsageError("--peers: '" + p + "' is not gdal, grass or none");
      }
  }
  c.repeats = args.positive_integer("--repeats").value_or(3);
  c.warmup = static_cast<int>(args.non_negative_integer("--warmup").value_or(1));
  c.observer_height = args.non_negative("--height").value_or(2.0);
  c.target_height = args.non_negative("--target-height").value_or(0.0);
  if (auto d = args.non_negative("--max-distance")) {
    if (*d <= 0) throw UsageError("--max-distance: must be positive");
    c.max_distance = *d;
  }
  c.curvature = args.non_negative("--curvature").value_or(0.85714);
  c.threads = args.non_negative_integer("--threads").value_or(0);
  return c;
}

int run_bench(const Args& args) {
  if (args.has("--mesh") && args.has("--region")) throw UsageError("--mesh and --region are two sweeps; give one");
  if (args.has("--mesh")) return run_mesh_bench(args);
  for (std::string_view f : kMeshOnlyFlags)
    if (args.has(f)) throw UsageError(std::string(f) + ": a flag of the mesh sweep; add --mesh");
  if (args.has("--region")) return run_region_bench(args);
  for (std::string_view f : kRegionOnlyFlags)
    if (args.has(f)) throw UsageError(std::string(f) + ": a flag of the region sweep; add --region");
  evaluation::BenchConfig config = parse_config(args);
  const auto made = bench_out_dir(args);
  if (!made.ok()) return report_error(made.error());
  const std::string& out_dir = *made;
  std::error_code ec;
  const fs::path work = fs::path(out_dir) / "peer-work";
  if (!config.peers.empty()) {
    fs::create_directories(work, ec);
    config.work_dir = work.string();
  }

  auto pool = gpu_for_switch(args);
  if (!pool.ok()) return report_error(pool.error());
  config.gpu = pool->get();

  InterruptScope interrupt;
  RunControl control;
  control.cancel = &interrupt.token();
  ProgressBar progress("horizon bench", std::chrono::milliseconds(0));
  control.progress = progress.callback();
  auto report = evaluation::run_bench(config, &control);
  progress.finish();
  fs::remove_all(work, ec);
  if (!report.ok()) return report_error(report.error());

  std::string command = "horizon bench";
  for (const std::string& d : config.dems) command += " " + d;
  for (const FlagSpec& f : kFlags)
    if (auto v = args.text(f.name)) {
      command += ' ';
      command += f.name;
      if (!v->empty()) {
        command += ' ';
        command += *v;
      }
    }

  const std::vector<evaluation::Aggregate> aggregates = evaluation::aggregate(report->rows, true);
  const std::string csv = (fs::path(out_dir) / "bench.csv").string();
  if (auto s = evaluation::write_csv(csv, report->rows); !s.ok()) return report_error(s.error());
  const std::string md = (fs::path(out_dir) / "bench.md").string();
  if (auto s = evaluation::write_markdown(md, *report, aggregates, command); !s.ok()) return report_error(s.error());
  if (auto extra = args.text("--markdown"))
    if (auto s = evaluation::write_markdown(*extra, *report, aggregates, command); !s.ok())
      return report_error(s.error());

  // One chart per DEM, and the pooled one when there are several.
  std::vector<std::string> charts;
  std::string group_dem = "\x01";
  std::vector<evaluation::Aggregate> group;
  auto flush = [&]() -> Status {
    if (group.empty()) return Status::Ok();
    const bool pooled = group.front().dem.empty();
    const std::string name = pooled ? "pareto_all.png" : "pareto_" + dem_slug(group.front().dem) + ".png";
    const std::string title = pooled ? "All DEMs: runtime against error"
                                     : group.front().dem + ": runtime against error (" +
                                           std::to_string(group.front().observers) + " observers)";
    const std::string path = (fs::path(out_dir) / name).string();
    HORIZON_RETURN_IF_ERROR(evaluation::write_chart(path, group, title));
    charts.push_back(path);
    group.clear();
    return Status::Ok();
  };
  for (const evaluation::Aggregate& a : aggregates) {
    if (a.dem != group_dem) {
      if (auto s = flush(); !s.ok()) return report_error(s.error());
      group_dem = a.dem;
    }
    group.push_back(a);
  }
  if (auto s = flush(); !s.ok()) return report_error(s.error());

  std::cout << "Runtime against error, " << report->rows.size() << " runs\n";
  std::string current = "\x01";
  for (const evaluation::Aggregate& a : aggregates) {
    if (a.dem != current) {
      current = a.dem;
      std::cout << "\n  " << (a.dem.empty() ? std::string("all DEMs") : a.dem) << " (" << a.observers
                << " observers)\n";
    }
    std::string setting = a.is_peer ? "(peer)" : a.setting;
    setting.resize(22, ' ');
    std::string algorithm = a.algorithm;
    algorithm.resize(13, ' ');
    std::cout << "    " << algorithm << setting << (a.is_default ? "* " : "  ") << fixed(a.seconds * 1e3, 1)
              << " ms  IoU " << fixed(100 * a.iou, 3) << " %  missed " << fixed(100 * a.missed_rate, 3) << " %  extra "
              << fixed(100 * a.extra_rate, 3) << " %" << (a.on_front ? "  front" : "") << '\n';
  }
  for (const std::string& n : report->notes) std::cout << "  note: " << n << '\n';
  std::cout << "\nWrote " << csv << ", " << md;
  for (const std::string& c : charts) std::cout << ", " << c;
  std::cout << '\n';
  return kExitOk;
}

}  // namespace

const Command& bench_command() {
  static const Command command{
      "bench",
      "Sweep algorithms and their accuracy knobs: runtime against error (CSV, PNG, Markdown)",
      "horizon bench DEM... [--observers N | --observer X,Y[;X,Y...]] [--algorithms LIST] [--peers LIST] "
      "[--repeats N] [-o DIR]\n"
      "horizon bench --region DEM... [--sizes LIST] [--face-resolutions LIST] [--splits LIST] [--rows LIST] "
      "[--heights ZMIN,ZMAX] [--check N] [-o DIR]",
      "For each DEM, observer and setting of each algorithm's knobs (ray spacing, sampling,\n"
      "tolerances: a row of bench.md each), computes the viewshed after --warmup untimed runs,\n"
      "--repeats times, keeps the median compute time, and measures the result against R3\n"
      "(IoU, missed-visible, extra-visible, OHF RMSE and max error). gdal_viewshed and GRASS\n"
      "r.viewshed are run on the same files and observers when installed (a missing peer is\n"
      "reported, not an error). Writes DIR/bench.csv (one line per run), DIR/bench.md (tables\n"
      "pooled per DEM and over all DEMs) and DIR/pareto_*.png (time against 1 - IoU, log axes,\n"
      "the Pareto front drawn).\n"
      "With --region, sweeps from-region visibility instead (always visible, always hidden or\n"
      "undetermined): square regions of each --sizes side at --regions centres, classified at\n"
      "each --face-resolutions and --splits (median of --repeats), and with --rows on the\n"
      "seed's row-snapped fuzzy array too, every cell within --max-distance (default 3000 m):\n"
      "the decided share against time, each verdict checked with R3 (--check). Writes\n"
      "DIR/bench_region.csv, DIR/bench_region.md and DIR/region_*.png; exits 1 if any verdict\n"
      "contradicts R3.",
      kFlags,
      "  horizon bench data/dem/olinda_coast_utm25s_111x111.tif --observers 2 --peers none -o out/bench\n"
      "  horizon bench data/dem/olinda_coast_utm25s_111x111.tif data/dem/everest_summit_voids_srtm3_300x300.tif \\\n"
      "      --algorithms fast,r3 --repeats 2 --peers none --markdown out/table.md\n"
      "  horizon bench --region data/dem/ecuador_andes_utm17s_10m_383x415.tif --sizes 20,100 \\\n"
      "      --face-resolutions 64,256 --check 20 -o out/region\n",
      run_bench,
  };
  return command;
}

}  // namespace horizon::cli
