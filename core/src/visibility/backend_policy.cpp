// Backend choice for the fast algorithm: the policy and its calibration (see backend_policy.hpp).
#include "horizon/visibility/backend_policy.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>

#include "horizon/visibility/viewshed.hpp"

namespace horizon::visibility {
namespace {

// Rolling synthetic terrain, 30 m cells: ridges of a few hundred metres at
// several wavelengths, so that horizons change all over the window.
terrain::Dem synthetic(int size) {
  terrain::Dem dem;
  dem.elevation = terrain::Grid<float>(size, size);
  for (int r = 0; r < size; ++r)
    for (int c = 0; c < size; ++c)
      dem.elevation.at(c, r) =
          static_cast<float>(500.0 + 200.0 * std::sin(c * 0.05) * std::cos(r * 0.04) +
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

double median_seconds(const terrain::Dem& dem, const geodesy::GridPoint& eye, const ViewshedOptions& o,
                      gpu::ContextPool& pool, const BackendPolicy& policy, Status& status) {
  std::vector<double> times;
  for (int i = 0; i < 4; ++i) {
    const auto start = std::chrono::steady_clock::now();
    auto r = compute_viewshed(dem, eye, o, nullptr, &pool, &policy);
    if (!r.ok()) {
      status = r.error();
      return 0;
    }
    if (o.backend == Backend::kGpu && r->stats.backend != "gpu") {
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

bool BackendPolicy::prefers_gpu(const gpu::DeviceInfo& device, std::uint64_t cells) const {
  if (device.software) return false;
  std::lock_guard lock(mutex_);
  return cells >= crossover_cells_;
}

std::uint64_t BackendPolicy::crossover_cells() const {
  std::lock_guard lock(mutex_);
  return crossover_cells_;
}

void BackendPolicy::set_crossover_cells(std::uint64_t cells) {
  std::lock_guard lock(mutex_);
  crossover_cells_ = cells;
}

GpuOptions BackendPolicy::preferred_variant() const {
  std::lock_guard lock(mutex_);
  return preferred_;
}

void BackendPolicy::set_preferred_variant(const GpuOptions& variant) {
  std::lock_guard lock(mutex_);
  preferred_ = variant;
}

Result<Calibration> calibrate(gpu::ContextPool& pool, BackendPolicy& policy, const CalibrationOptions& options) {
  Calibration out;
  if (pool.device().software && !options.time_software) {
    policy.set_crossover_cells(out.crossover_cells);
    return out;
  }
  // Every variant at the largest size; the fastest becomes the policy's default
  // and is the one the CPU is timed against below.
  {
    int size = 128;
    while (2 * size <= options.max_side) size *= 2;
    const terrain::Dem dem = synthetic(size);
    auto eye = centre_eye(dem);
    if (!eye.ok()) return eye.error();
    ViewshedOptions o;
    o.backend = Backend::kGpu;
    for (auto method : {GpuMethod::kFragment, GpuMethod::kCompute})
      for (bool log_step : {true, false}) {
        o.gpu = GpuOptions{method, log_step};
        Status status;
        const double seconds = median_seconds(dem, *eye, o, pool, policy, status);
        if (!status.ok()) return status.error();
        out.variants.push_back({*o.gpu, seconds});
      }
    out.preferred =
        std::min_element(out.variants.begin(), out.variants.end(), [](const VariantTime& a, const VariantTime& b) {
          return a.seconds < b.seconds;
        })->variant;
    policy.set_preferred_variant(out.preferred);
  }
  for (int size = 128; size <= options.max_side; size *= 2) {
    const terrain::Dem dem = synthetic(size);
    auto eye = centre_eye(dem);
    if (!eye.ok()) return eye.error();
    ViewshedOptions o;
    o.threads = options.threads;
    Status status;
    CalibrationPoint p;
    p.cells = dem.elevation.size();
    o.backend = Backend::kCpu;
    p.cpu_seconds = median_seconds(dem, *eye, o, pool, policy, status);
    o.backend = Backend::kGpu;
    if (status.ok()) p.gpu_seconds = median_seconds(dem, *eye, o, pool, policy, status);
    if (!status.ok()) return status.error();
    out.points.push_back(p);
  }
  // The smallest size from which the GPU stays faster.
  for (auto it = out.points.rbegin(); it != out.points.rend() && it->gpu_seconds < it->cpu_seconds; ++it)
    out.crossover_cells = it->cells;
  policy.set_crossover_cells(out.crossover_cells);
  return out;
}

}  // namespace horizon::visibility
