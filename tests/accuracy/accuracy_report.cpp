// accuracy_report — the fast viewshed against the exact R3 reference.
//
//   accuracy_report [--algorithm A[,B...]] [--blend linear|min|resample] [--height M] [--max-distance M]
//                   [--threads N] [--ray-spacing S] [--check] DEM...
//
// Algorithm "fast-gpu" is fast on the GL path (an EGL context: the GPU, or
// Mesa llvmpipe); with both fast and fast-gpu the summary also counts the runs
// whose OHF is bit-identical between the two.
//
// For every DEM and every observer of observer_picks.hpp (summit, ridge,
// valley, edge) it computes R3 once and each tested algorithm (--algorithm
// fast,conservative,exact; default fast), and prints one Markdown table row
// per algorithm: visible-set IoU, missed-visible and extra-visible rates,
// OHF RMSE / max in metres, both run times. With --check it exits 1 when any
// row misses the bar of issue #2 (IoU >= 99.0 %, missed <= 0.5 %).
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "horizon/geodesy/observer.hpp"
#include "horizon/gpu/context_pool.hpp"
#include "horizon/terrain/dem_reader.hpp"
#include "horizon/visibility/agreement.hpp"
#include "horizon/visibility/viewshed.hpp"
#include "observer_picks.hpp"

using namespace horizon;

namespace {

struct Tested {
  visibility::Algorithm algorithm;
  visibility::Backend backend;
  std::string label;  // "fast", "fast-gpu", ...
};

// Parses a finite number or explains what was wrong with the flag's value.
bool parse_number(const char* flag, const char* text, double& out) {
  char* end = nullptr;
  out = text ? std::strtod(text, &end) : 0.0;
  if (!text || end == text || *end != '\0' || !std::isfinite(out)) {
    std::fprintf(stderr, "accuracy_report: %s: expected a number, got '%s'\n", flag, text ? text : "");
    return false;
  }
  return true;
}

int usage() {
  std::fprintf(stderr,
               "usage: accuracy_report [--algorithm A[,B...]] [--blend B] [--height M] [--max-distance M] [--threads "
               "N] [--ray-spacing S] [--check] DEM...\n");
  return 2;
}

}  // namespace

int main(int argc, char** argv) {
  double height = 2.0;
  visibility::ViewshedOptions options;
  bool check = false;
  std::vector<Tested> tested;
  std::vector<std::string> dems;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto value = [&]() -> const char* { return i + 1 < argc ? argv[++i] : nullptr; };
    double number = 0;
    if (a == "--height") {
      if (!parse_number("--height", value(), height)) return usage();
    } else if (a == "--max-distance") {
      if (!parse_number("--max-distance", value(), options.max_distance)) return usage();
    } else if (a == "--threads") {
      if (!parse_number("--threads", value(), number) || number < 0) return usage();
      options.threads = static_cast<unsigned>(number);
    } else if (a == "--ray-spacing") {
      if (!parse_number("--ray-spacing", value(), options.radial.ray_spacing)) return usage();
    } else if (a == "--algorithm") {
      // One name or a comma-separated list: R3 is computed once per observer for all of them.
      const char* v = value();
      std::string list = v ? v : "";
      for (std::size_t start = 0; start <= list.size();) {
        const std::size_t comma = std::min(list.find(',', start), list.size());
        const std::string name = list.substr(start, comma - start);
        const bool on_gpu = name == "fast-gpu";
        const auto parsed = on_gpu ? visibility::Algorithm::kRadial : visibility::parse_algorithm(name);
        if (!parsed) {
          std::fprintf(stderr,
                       "accuracy_report: --algorithm: expected fast, fast-gpu, exact, conservative or r3, got '%s'\n",
                       name.c_str());
          return usage();
        }
        tested.push_back({*parsed, on_gpu ? visibility::Backend::kGpu : visibility::Backend::kCpu, name});
        start = comma + 1;
      }
    } else if (a == "--blend") {
      const char* v = value();
      const std::string b = v ? v : "";
      if (b == "linear")
        options.radial.blend = visibility::RayBlend::kLinear;
      else if (b == "min")
        options.radial.blend = visibility::RayBlend::kMin;
      else if (b == "resample")
        options.radial.blend = visibility::RayBlend::kResample;
      else {
        std::fprintf(stderr, "accuracy_report: --blend: expected linear, min or resample, got '%s'\n", b.c_str());
        return usage();
      }
    } else if (a == "--check") {
      check = true;
    } else if (!a.empty() && a[0] == '-') {
      return usage();
    } else {
      dems.push_back(a);
    }
  }
  if (dems.empty()) return usage();
  if (tested.empty()) tested.push_back({visibility::Algorithm::kRadial, visibility::Backend::kCpu, "fast"});
  std::unique_ptr<gpu::ContextPool> pool;
  int cpu_fast = -1, gpu_fast = -1;
  for (std::size_t k = 0; k < tested.size(); ++k) {
    if (tested[k].label == "fast") cpu_fast = static_cast<int>(k);
    if (tested[k].label != "fast-gpu") continue;
    gpu_fast = static_cast<int>(k);
    auto created = gpu::ContextPool::create({.contexts = 1});
    if (!created.ok()) {
      std::fprintf(stderr, "accuracy_report: fast-gpu: %s\n", created.error().message.c_str());
      return 1;
    }
    pool = std::move(*created);
    std::fprintf(stderr, "accuracy_report: fast-gpu on %s (%s)\n", pool->device().renderer.c_str(),
                 pool->device().version.c_str());
  }
  int identical = 0;

  std::printf(
      "| algorithm | DEM | observer (col,row) | cells compared | R3 visible | IoU | missed visible | "
      "extra visible | OHF RMSE (m) | OHF max (m) | time (ms) | R3 (ms) |\n");
  std::printf("|---|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n");
  std::vector<double> worst_iou(tested.size(), 1.0), worst_missed(tested.size(), 0.0);
  int rows = 0;
  for (const std::string& path : dems) {
    auto dem = terrain::read_dem(path);
    if (!dem.ok()) {
      std::fprintf(stderr, "accuracy_report: %s\n", dem.error().message.c_str());
      return 1;
    }
    for (const auto& pick : accuracy::pick_observers(*dem)) {
      auto eye = accuracy::pick_eye(*dem, pick, height);
      if (!eye.ok()) {
        std::fprintf(stderr, "accuracy_report: %s\n", eye.error().message.c_str());
        return 1;
      }
      options.algorithm = visibility::Algorithm::kR3;
      options.backend = visibility::Backend::kCpu;
      auto exact = visibility::compute_viewshed(*dem, *eye, options);
      if (!exact.ok()) {
        std::fprintf(stderr, "accuracy_report: %s\n", exact.error().message.c_str());
        return 1;
      }
      std::vector<terrain::Grid<float>> ohfs(tested.size());
      for (std::size_t k = 0; k < tested.size(); ++k) {
        options.algorithm = tested[k].algorithm;
        options.backend = tested[k].backend;
        auto fast = visibility::compute_viewshed(*dem, *eye, options, nullptr, pool.get());
        if (!fast.ok()) {
          std::fprintf(stderr, "accuracy_report: %s\n", fast.error().message.c_str());
          return 1;
        }
        if (!fast->stats.gpu_fallback.empty()) {
          std::fprintf(stderr, "accuracy_report: %s: the GPU did not answer: %s\n", tested[k].label.c_str(),
                       fast->stats.gpu_fallback.c_str());
          return 1;
        }
        const auto a = visibility::compare_viewsheds(*fast, *exact, options.target_height);
        std::printf("| %s | %s | %s (%d,%d) | %llu | %.1f%% | %.3f%% | %.3f%% | %.3f%% | %.2f | %.1f | %.1f | %.0f |\n",
                    tested[k].label.c_str(), std::filesystem::path(path).filename().c_str(), pick.kind.c_str(),
                    pick.col, pick.row, static_cast<unsigned long long>(a.cells_compared),
                    a.cells_compared ? 100.0 * a.reference_visible / a.cells_compared : 0.0, 100.0 * a.iou,
                    100.0 * a.missed_rate, 100.0 * a.extra_rate, a.ohf_rmse, a.ohf_max_error, 1e3 * fast->stats.seconds,
                    1e3 * exact->stats.seconds);
        std::fflush(stdout);
        ohfs[k] = std::move(fast->ohf);
        worst_iou[k] = std::min(worst_iou[k], a.iou);
        worst_missed[k] = std::max(worst_missed[k], a.missed_rate);
      }
      if (cpu_fast >= 0 && gpu_fast >= 0) {
        const auto c = ohfs[static_cast<std::size_t>(cpu_fast)].values(),
                   g = ohfs[static_cast<std::size_t>(gpu_fast)].values();
        bool same = c.size() == g.size();
        for (std::size_t i = 0; same && i < c.size(); ++i)
          same = (std::isnan(c[i]) && std::isnan(g[i])) || c[i] == g[i];
        identical += same;
      }
      ++rows;
    }
  }
  std::printf("\n");
  bool below = false;
  for (std::size_t k = 0; k < tested.size(); ++k) {
    std::printf("%s: %d observer runs; worst IoU %.3f%%, worst missed-visible rate %.3f%%.\n", tested[k].label.c_str(),
                rows, 100.0 * worst_iou[k], 100.0 * worst_missed[k]);
    below = below || worst_iou[k] < 0.99 || worst_missed[k] > 0.005;
  }
  if (cpu_fast >= 0 && gpu_fast >= 0)
    std::printf("fast-gpu: OHF bit-identical to fast (CPU) in %d of %d observer runs.\n", identical, rows);
  if (check && below) {
    std::fprintf(stderr, "accuracy_report: below the bar (IoU >= 99.0%%, missed <= 0.5%%)\n");
    return 1;
  }
  return 0;
}
