// `horizon bench --mesh DEM...`: flags -> evaluation::MeshBenchConfig;
// report -> CSV, Markdown and a table on stdout.
#include "commands/bench_mesh.hpp"

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <sstream>

#include "commands/bench_out.hpp"
#include "commands/bench_region.hpp"
#include "commands/command.hpp"
#include "horizon/evaluation/mesh_bench.hpp"
#include "interrupt.hpp"
#include "output.hpp"
#include "progress.hpp"

namespace horizon::cli {
namespace {

namespace fs = std::filesystem;

evaluation::MeshBenchConfig parse_config(const Args& args) {
  for (std::string_view f : kViewshedOnlyFlags)
    if (f != "--height" && args.has(f)) throw UsageError(std::string(f) + ": not a flag of the mesh sweep (--mesh)");
  for (std::string_view f : kRegionOnlyFlags)
    if (args.has(f)) throw UsageError(std::string(f) + ": not a flag of the mesh sweep (--mesh)");
  if (args.has("--curvature"))
    throw UsageError(
        "--curvature: the mesh sweep reads R3 on a flat earth, as the TIN's local frame is (docs/accuracy.md)");
  evaluation::MeshBenchConfig c;
  c.dems = args.positionals();
  if (c.dems.empty()) throw UsageError("missing DEM operand (one or more DEM files)");
  if (auto n = args.positive_integer("--vertices")) {
    if (*n < 4) throw UsageError("--vertices: a TIN needs 4 or more");
    c.vertices = static_cast<std::uint32_t>(*n);
  }
  if (auto list = args.text("--sectors")) {
    c.shapes.clear();
    std::stringstream items(*list);
    for (std::string item; std::getline(items, item, ',');) {
      int s = 0, k = 0;
      char tail = 0;
      if (std::sscanf(item.c_str(), "%d/%d%c", &s, &k, &tail) != 2)
        throw UsageError("--sectors: expected S/K[,S/K...] (e.g. 8/1,16/4), got '" + *list + "'");
      c.shapes.emplace_back(s, k);
    }
    if (c.shapes.empty()) throw UsageError("--sectors: no shape given");
  }
  if (auto n = args.positive_integer("--cameras")) c.cameras = *n;
  if (auto n = args.non_negative_integer("--exact")) c.exact_cameras = static_cast<int>(*n);
  if (c.exact_cameras > c.cameras) throw UsageError("--exact: at most --cameras cameras can be checked");
  if (auto h = args.non_negative("--height")) c.height = *h;
  if (auto h = args.non_negative("--high-eye")) c.high_eye = *h;
  c.threads = args.non_negative_integer("--threads").value_or(0);
  return c;
}

Status write_text(const std::string& path, const std::string& text) {
  std::ofstream out(path);
  out << text;
  if (!out) return make_error(ErrorCode::kIoError, path + ": cannot write", "--out");
  return Status::Ok();
}

}  // namespace

int run_mesh_bench(const Args& args) {
  const evaluation::MeshBenchConfig config = parse_config(args);
  const auto made = bench_out_dir(args);
  if (!made.ok()) return report_error(made.error());
  const std::string& out_dir = *made;
  InterruptScope interrupt;
  RunControl control;
  control.cancel = &interrupt.token();
  auto report = evaluation::run_mesh_bench(config, &control);
  if (!report.ok()) return report_error(report.error());
  const std::string csv = (fs::path(out_dir) / "bench_mesh.csv").string();
  const std::string md = (fs::path(out_dir) / "bench_mesh.md").string();
  if (auto s = write_text(csv, report->csv()); !s.ok()) return report_error(s.error());
  if (auto s = write_text(md, report->markdown()); !s.ok()) return report_error(s.error());
  if (auto extra = args.text("--markdown"))
    if (auto s = write_text(*extra, report->markdown()); !s.ok()) return report_error(s.error());
  std::cout << "TIN culling: runtime against error, " << config.cameras << " cameras " << fixed(config.height, 1)
            << " m above vertices, " << config.exact_cameras
            << " checked with exact sight lines over the TIN and with R3 on the DEM\n\n"
            << report->markdown() << "\nWrote " << csv << ", " << md << '\n';
  std::uint64_t unsound = 0;
  for (const auto& r : report->rows)
    if (r.mode == "conservative") unsound += r.false_hidden;
  // The conservative mode culling a visible triangle is a bug, not a setting.
  return unsound == 0
             ? kExitOk
             : report_error(make_error(ErrorCode::kInternal,
                                       std::to_string(unsound) + " triangles culled conservatively are seen", "mesh"));
}

}  // namespace horizon::cli
