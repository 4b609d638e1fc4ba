// `horizon stress [DEM...]`: flags -> evaluation::StressConfig; results -> a
// report on stdout (and Markdown). The checks are in core/src/evaluation/stress.cpp.
#include <algorithm>
#include <fstream>
#include <iostream>
#include <memory>
#include <sstream>
#include <string_view>

#include "commands/command.hpp"
#include "horizon/evaluation/stress.hpp"
#include "interrupt.hpp"
#include "output.hpp"
#include "progress.hpp"

namespace horizon::cli {
namespace {

constexpr FlagSpec kFlags[] = {
    {"--algorithms", "", "LIST", "Comma-separated: fast, exact, conservative, r3 (default: all four)"},
    {"--checks", "", "LIST", "Comma-separated check names (default: all; see the list below)"},
    {"--observers", "", "N", "Random observers per DEM for the dem_* checks (default 3)"},
    {"--radius", "", "CELLS", "Radius of the dem_* viewsheds in cells, 0 = whole DEM (default 150)"},
    {"--size", "", "CELLS", "Side of the synthetic DEMs, >= 64 (default 96)"},
    {"--seed", "", "N", "Seed of the random observers (default 20261122)"},
    {"--threads", "", "N", "Worker threads (default 0 = all cores)"},
    {"--gpu", "", "", "Also run every check on fast's GPU path (an EGL context; Mesa llvmpipe without a GPU)"},
    {"--markdown", "", "FILE", "Also write the report as a Markdown table"},
};

std::vector<std::string> split(const std::string& text) {
  std::vector<std::string> out;
  std::string item;
  std::istringstream in(text);
  while (std::getline(in, item, ','))
    if (!item.empty()) out.push_back(item);
  return out;
}

int run_stress(const Args& args) {
  evaluation::StressConfig config;
  config.dems = args.positionals();
  if (auto list = args.text("--algorithms")) {
    config.algorithms.clear();
    for (const std::string& a : split(*list)) {
      auto algorithm = visibility::parse_algorithm(a);
      if (!algorithm) throw UsageError("--algorithms: '" + a + "' is not one of fast, exact, conservative, r3");
      config.algorithms.push_back(*algorithm);
    }
    if (config.algorithms.empty()) throw UsageError("--algorithms: empty list");
  }
  std::vector<std::string> checks;
  if (auto list = args.text("--checks")) {
    const auto names = evaluation::stress_check_names();
    for (const std::string& c : split(*list)) {
      if (std::find(names.begin(), names.end(), c) == names.end())
        throw UsageError("--checks: '" + c + "' is not a check (see horizon stress --help)");
      checks.push_back(c);
    }
  }
  config.observers_per_dem = args.positive_integer("--observers").value_or(3);
  config.radius_cells = static_cast<int>(args.non_negative_integer("--radius").value_or(150));
  config.synthetic_size = args.positive_integer("--size").value_or(96);
  if (config.synthetic_size < 64) throw UsageError("--size: must be at least 64");
  config.seed = args.non_negative_integer("--seed").value_or(config.seed);
  config.threads = args.non_negative_integer("--threads").value_or(0);

  auto pool = gpu_for_switch(args);
  if (!pool.ok()) return report_error(pool.error());
  config.gpu = pool->get();

  InterruptScope interrupt;
  RunControl control;
  control.cancel = &interrupt.token();
  ProgressBar progress("horizon stress", std::chrono::milliseconds(0));
  control.progress = progress.callback();
  auto results = evaluation::run_stress(config, checks, &control);
  progress.finish();
  if (!results.ok()) return report_error(results.error());

  std::size_t failed = 0;
  std::cout << "Stress report: " << results->size() << " checks x algorithms, " << config.dems.size()
            << " real DEMs\n\n";
  std::cout << "  check                 algorithm     cases  result      worst deviation  (OHF)\n";
  for (const evaluation::CheckResult& r : *results) {
    std::string check = r.check, algorithm = r.algorithm;
    check.resize(22, ' ');
    algorithm.resize(13, ' ');
    std::string result = r.cases == 0 ? "no cases" : r.passed() ? "pass" : "FAIL (" + std::to_string(r.failed) + ")";
    result.resize(11, ' ');
    std::string cases = std::to_string(r.cases);
    cases.insert(0, cases.size() < 5 ? 5 - cases.size() : 0, ' ');
    std::cout << "  " << check << algorithm << " " << cases << "  " << result << " " << fixed(r.worst, 0) << " "
              << r.unit;
    if (r.worst_ohf > 0) std::cout << "  (" << fixed(r.worst_ohf, 4) << " m)";
    if (r.explained > 0) std::cout << "  + " << r.explained << " cells its own error explains";
    std::cout << '\n';
    failed += !r.passed();
  }
  if (std::any_of(results->begin(), results->end(), [](const auto& r) { return r.explained > 0; })) {
    std::cout
        << "\nCells a property missed that the algorithm's own error explains (not failures; see docs/stress.md):\n";
    for (const evaluation::CheckResult& r : *results)
      if (r.explained > 0) std::cout << "  " << r.check << " / " << r.algorithm << ": " << r.first_explained << '\n';
  }
  if (failed) {
    std::cout << "\nFirst failure of each failing check:\n";
    for (const evaluation::CheckResult& r : *results)
      if (!r.passed()) std::cout << "  " << r.check << " / " << r.algorithm << ": " << r.first_failure << '\n';
  }
  std::cout << '\n' << (failed ? std::to_string(failed) + " failing" : std::string("all pass")) << '\n';
  if (auto path = args.text("--markdown")) {
    std::ofstream out(*path);
    out << evaluation::stress_markdown(*results);
    out.close();
    if (!out)
      return report_error(make_error(ErrorCode::kIoError, "--markdown: cannot write '" + *path + "'", "--markdown"));
  }
  // Failing checks are findings, not a broken run: exit 1 so scripts notice.
  return failed ? kExitFailure : kExitOk;
}

std::string check_list() {
  std::string text = "Checks:\n";
  for (const std::string& n : evaluation::stress_check_names()) text += "  " + n + "\n";
  return text;
}

}  // namespace

const Command& stress_command() {
  static const std::string examples =
      "  horizon stress                                      # synthetic checks only\n"
      "  horizon stress data/dem/olinda_coast_utm25s_111x111.tif --markdown out/stress.md\n"
      "  horizon stress --algorithms fast --checks wall_1000m,flat_all_visible\n\n" +
      check_list();
  static const Command command{
      "stress",
      "Numerical-stability stress checks of every algorithm; prints a pass/fail report",
      "horizon stress [DEM...] [--algorithms LIST] [--checks LIST] [--observers N] [--radius CELLS]",
      "Runs property checks built to break the visibility algorithms (docs/stress.md):\n"
      "far-from-origin and geographic coordinates, extreme heights and cell sizes, walls,\n"
      "flat terrain, observer placement and height, voids; and on the given real DEMs with\n"
      "random observers (fixed seed): raising the eye or the target never hides a cell, the\n"
      "minimum visible height is consistent, moving or cropping the DEM changes nothing.\n"
      "Prints check, algorithm, cases, pass/fail and the worst deviation; exit status 1 when\n"
      "any check fails.",
      kFlags,
      examples,
      run_stress,
  };
  return command;
}

}  // namespace horizon::cli
