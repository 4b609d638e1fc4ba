// The CPU/GPU crossover for Backend::kAuto (see calibrate.hpp).
#include "horizon/gpu/calibrate.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>

#include "horizon/visibility/viewshed.hpp"

namespace horizon::gpu {
namespace {

// Rolling synthetic terrain, 30 m cells: ridges of a few hundred metres at
// several wavelengths, so that horizons change all over the window.
terrain::Dem synthetic(int size) {
  terrain::Dem dem;
  dem.elevation = terrain::Grid<float>(size, size);
  for (int r = 0; r < size; ++r)
    for (int c = 0; c < size; ++c)
      dem.elevation.at(c, r) = static_cast<float>(500.0 + 200.0 * std::sin(c * 0.05) * std::cos(r * 0.04) +
                                                  60.0 * std::sin((c + 2 * r) * 0.21) + 15.0 * std::cos(c * 0.9 - r * 0.7));
  dem.georef.transform = {0.0, 30.0, size * 30.0, -30.0};
  dem.source = "calibration terrain";
  dem.format = "synthetic";
  return dem;
}

// 2 m above a point just off the centre cell.
Result<geodesy::GridPoint> centre_eye(const terrain::Dem& dem) {
  geodesy::PointSpec spec;
  spec.x = dem.georef.transform.x_at(dem.width() / 2 + 0.3);
  spec.y = dem.georef.transform.y_at(dem.height() / 2 + 0.6);
  spec.height = 2.0;
  return geodesy::resolve_point(dem, spec, "observer");
}

double median_seconds(const terrain::Dem& dem, const geodesy::GridPoint& eye, const visibility::ViewshedOptions& o,
                      ContextPool& pool, Status& status) {
  std::vector<double> times;
  for (int i = 0; i < 4; ++i) {
    const auto start = std::chrono::steady_clock::now();
    auto r = visibility::compute_viewshed(dem, eye, o, nullptr, &pool);
    if (!r.ok()) {
      status = r.error();
      return 0;
    }
    if (o.backend == visibility::Backend::kGpu && r->stats.backend != "gpu") {
      status = make_error(ErrorCode::kInternal, "gpu: calibration run fell back to the CPU: " + r->stats.gpu_fallback,
                          "gpu");
      return 0;
    }
    if (i > 0) times.push_back(std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
  }
  std::sort(times.begin(), times.end());
  return times[times.size() / 2];
}

}  // namespace

Result<Calibration> calibrate(ContextPool& pool, const CalibrationOptions& options) {
  Calibration out;
  if (pool.device().software && !options.time_software) {
    pool.set_crossover_cells(out.crossover_cells);
    return out;
  }
  // Every variant at the largest size; the fastest becomes the pool's default
  // and is the one the CPU is timed against below.
  {
    int size = 128;
    while (2 * size <= options.max_side) size *= 2;
    const terrain::Dem dem = synthetic(size);
    auto eye = centre_eye(dem);
    if (!eye.ok()) return eye.error();
    visibility::ViewshedOptions o;
    o.backend = visibility::Backend::kGpu;
    for (auto method : {visibility::GpuMethod::kFragment, visibility::GpuMethod::kCompute})
      for (bool log_step : {true, false}) {
        o.gpu = visibility::GpuOptions{method, log_step};
        Status status;
        const double seconds = median_seconds(dem, *eye, o, pool, status);
        if (!status.ok()) return status.error();
        out.variants.push_back({*o.gpu, seconds});
      }
    out.preferred = std::min_element(out.variants.begin(), out.variants.end(),
                                     [](const VariantTime& a, const VariantTime& b) { return a.seconds < b.seconds; })
                        ->variant;
    pool.set_preferred_variant(out.preferred);
  }
  for (int size = 128; size <= options.max_side; size *= 2) {
    const terrain::Dem dem = synthetic(size);
    auto eye = centre_eye(dem);
    if (!eye.ok()) return eye.error();
    visibility::ViewshedOptions o;
    o.threads = options.threads;
    Status status;
    CalibrationPoint p;
    p.cells = dem.elevation.size();
    o.backend = visibility::Backend::kCpu;
    p.cpu_seconds = median_seconds(dem, *eye, o, pool, status);
    o.backend = visibility::Backend::kGpu;
    if (status.ok()) p.gpu_seconds = median_seconds(dem, *eye, o, pool, status);
    if (!status.ok()) return status.error();
    out.points.push_back(p);
  }
  // The smallest size from which the GPU stays faster.
  for (auto it = out.points.rbegin(); it != out.points.rend() && it->gpu_seconds < it->cpu_seconds; ++it)
    out.crossover_cells = it->cells;
  pool.set_crossover_cells(out.crossover_cells);
  return out;
}

}  // namespace horizon::gpu
