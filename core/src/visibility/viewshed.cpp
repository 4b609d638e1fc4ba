// Viewshed driver: validation, frame, algorithm dispatch, derived rasters.
#include "horizon/visibility/viewshed.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>

#include "horizon/visibility/exact.hpp"
#include "horizon/visibility/r3.hpp"
#include "horizon/visibility/radial_sweep.hpp"
#include "horizon/visibility/radial_sweep_gl.hpp"
#include "horizon/visibility/viewshed_outputs.hpp"

namespace horizon::visibility {
namespace {

constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();

// A window-sized raster holding f(ohf, z) where the result has an answer, NaN elsewhere.
template <class F>
terrain::Grid<float> per_answered_cell(const ViewshedResult& result, F&& f) {
  terrain::Grid<float> out(result.ohf.width(), result.ohf.height(), kNaN);
  const auto ohf = result.ohf.values();
  const auto z = result.terrain.values();
  auto dst = out.values();
  for (std::size_t i = 0; i < ohf.size(); ++i)
    if (!std::isnan(ohf[i]) && !std::isnan(z[i])) dst[i] = f(ohf[i], z[i]);
  return out;
}

// The fast OHF on the GPU when the options and the policy ask for it. Returns
// true when the GPU answered (or the caller's control stopped it: `status`
// then holds that error); false leaves the work to the CPU, with
// stats.gpu_fallback saying why when the GPU was asked for.
bool try_gpu(const terrain::HeightView& elevation, const ViewFrame& frame, const ViewshedOptions& options,
             const RunControl* control, gpu::ContextPool* pool, const BackendPolicy* policy, ViewshedResult& result,
             Status& status) {
  if (options.algorithm != Algorithm::kRadial || options.backend == Backend::kCpu) return false;
  if (pool == nullptr) {
    if (options.backend == Backend::kGpu) result.stats.gpu_fallback = "no EGL context in this process";
    return false;
  }
  if (options.backend == Backend::kAuto &&
      (policy == nullptr || !policy->prefers_gpu(pool->device(), frame.window.cell_count())))
    return false;
  auto lease = pool->borrow();
  if (!lease.ok()) {
    result.stats.gpu_fallback = lease.error().message;
    return false;
  }
  const GpuOptions variant = options.gpu.value_or(policy ? policy->preferred_variant() : GpuOptions{});
  status = radial_ohf_gl(*lease, elevation, frame, options.radial, variant, control, result.ohf, result.stats);
  if (status.ok()) {
    result.stats.backend = "gpu";
    result.stats.gpu_variant = gpu_variant_name(variant);
    return true;
  }
  const ErrorCode code = status.error().code;
  if (code == ErrorCode::kCancelled || code == ErrorCode::kDeadlineExceeded) return true;
  result.stats.gpu_fallback = status.error().message;
  status = Status::Ok();
  return false;
}

// compute_viewshed, with `spare` (dem.elevation itself, or null) free to be
// taken as result.terrain.
Result<ViewshedResult> compute(const terrain::Dem& dem, terrain::Grid<float>* spare, const geodesy::GridPoint& observer,
                               const ViewshedOptions& options, const RunControl* control, gpu::ContextPool* gpu,
                               const BackendPolicy* policy, ResultStorage storage) {
  auto frame = make_view_frame(dem, observer, options);
  if (!frame.ok()) return frame.error();

  // Voids are read through the view: transparent ones stay NaN, which every
  // algorithm skips (a NaN slope never raises a horizon); NodataPolicy::kFill
  // reads them as the fill height. The DEM itself is never copied.
  const terrain::HeightView elevation = elevation_view(dem.elevation, options);

  ViewshedResult result;
  if (storage.ohf) result.ohf = std::move(*storage.ohf);  // size_output keeps its pages
  result.frame = *frame;
  result.target_height = options.target_height;
  result.field_of_view = options.field_of_view;
  result.stats.dem_cells = dem.elevation.size();
  result.stats.window_cells = frame->window.cell_count();

  const auto start = std::chrono::steady_clock::now();
  Status status;
  // The fast sweep's east and west sectors read a transposed copy of the
  // window (radial_ohf's column_buffer) in a kept raster the run does not
  // fill while it sweeps: the caller's OHF storage when only a mask is made,
  // its terrain storage (filled after the sweep) otherwise. Without storage
  // (a one-off run, whose fresh pages would cost what the copy saves) they
  // read the elevation in place.
  // mask_only: the sweep codes the cells itself when nothing needs its heights.
  const bool sweep_mask =
      options.mask_only && options.radial.blend == RayBlend::kResample && !options.field_of_view.limits();
  if (!try_gpu(elevation, *frame, options, control, gpu, policy, result, status)) switch (options.algorithm) {
      case Algorithm::kRadial:
        if (sweep_mask) {
          // No heights: a caller's OHF storage goes back to it, only lent to the sweep's lines.
          if (storage.ohf) *storage.ohf = std::move(result.ohf);
          result.ohf = terrain::Grid<float>();
          result.mask.emplace();
          if (storage.mask) *result.mask = std::move(*storage.mask);  // size_output keeps its pages
          status = radial_mask(elevation, *frame, options.radial, options.target_height, options.threads, control,
                               *result.mask, result.mask_counts, result.stats, storage.ohf);
          break;
        }
        status = radial_ohf(elevation, *frame, options.radial, options.threads, control, result.ohf, result.stats,
                            RadialBound::kNone, storage.terrain != &dem.elevation ? storage.terrain : nullptr);
        break;
      case Algorithm::kConservative:
        status = radial_ohf(elevation, *frame, options.radial, options.threads, control, result.ohf, result.stats,
                            RadialBound::kLowerBound);
        break;
      case Algorithm::kExact:
        status = exact_ohf(elevation, *frame, options.radial, options.threads, control, result.ohf, result.stats,
                           options.visibility_only ? std::optional<double>(options.target_height) : std::nullopt);
        break;
      case Algorithm::kR3:
        status = r3_ohf(elevation, *frame, options.threads, control, result.ohf, result.stats);
        break;
    }
  if (!status.ok()) return status.error();
  result.stats.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  // The elevations used, window-sized: the grid itself when the window
  // covers it and it can be given away (its voids filled in place, the
  // caller having given it up), else a copy of the window.
  const terrain::Window& w = frame->window;
  const bool whole = w.col0 == 0 && w.row0 == 0 && w.width() == dem.width() && w.height() == dem.height();
  if (whole && spare != nullptr) {
    result.terrain = std::move(*spare);
    if (elevation.fills_voids())
      for (float& v : result.terrain.values()) v = elevation.fill(v);
  } else {
    if (storage.terrain) result.terrain = std::move(*storage.terrain);
    terrain::copy_cells(elevation.sub(w), result.terrain);
  }
  // The field of view masks the answer, whichever algorithm and backend gave it.
  if (!result.mask) {
    mask_field_of_view(options.field_of_view, *frame, result.terrain, result.ohf, options.threads);
    if (options.mask_only) ensure_mask(result, options.threads);
  }
  return result;
}

}  // namespace

terrain::HeightView elevation_view(const terrain::Grid<float>& elevation, const ViewshedOptions& options) {
  const terrain::HeightView view(elevation);
  return options.nodata == NodataPolicy::kFill ? view.with_void_fill(static_cast<float>(options.nodata_fill_height))
                                               : view;
}

Result<ViewshedResult> compute_viewshed(const terrain::Dem& dem, const geodesy::GridPoint& observer,
                                        const ViewshedOptions& options, const RunControl* control,
                                        gpu::ContextPool* gpu, const BackendPolicy* policy, ResultStorage storage) {
  return compute(dem, nullptr, observer, options, control, gpu, policy, storage);
}

Result<ViewshedResult> compute_viewshed_taking_elevation(terrain::Dem& dem, const geodesy::GridPoint& observer,
                                                         const ViewshedOptions& options, const RunControl* control,
                                                         gpu::ContextPool* gpu, const BackendPolicy* policy,
                                                         ResultStorage storage) {
  return compute(dem, &dem.elevation, observer, options, control, gpu, policy, storage);
}

terrain::Grid<float> min_target_height(const ViewshedResult& result) {
  return per_answered_cell(result, min_target_height_at);
}

terrain::Grid<std::uint8_t> visibility_mask(const ViewshedResult& result, double target_height, unsigned threads,
                                            AnswerCounts* counts) {
  // The rule of min_target_height(), cell by cell, so the two rasters can never disagree.
  return visibility_codes(result, target_height, ValueCodes{}, threads, counts);
}

const terrain::Grid<std::uint8_t>& ensure_mask(ViewshedResult& result, unsigned threads) {
  if (!result.mask) result.mask = visibility_mask(result, result.target_height, threads, &result.mask_counts);
  return *result.mask;
}

terrain::Grid<float> ohf_raster(const ViewshedResult& result) {
  return per_answered_cell(result, [](float ohf, float z) { return std::max(ohf, z); });
}

terrain::Georeference window_georef(const terrain::Dem& dem, const ViewshedResult& result) {
  terrain::Georeference g = dem.georef;
  g.transform = dem.georef.transform.shifted(result.frame.window.col0, result.frame.window.row0);
  return g;
}

terrain::PreviewOptions preview_options(const ViewshedResult& result) {
  const ViewFrame& f = result.frame;
  terrain::PreviewOptions preview;
  preview.metres_per_col = f.metres_per_col;
  preview.metres_per_row = f.metres_per_row;
  // The preview covers the window only.
  preview.observers.push_back(
      {f.observer_col - f.window.col0, f.observer_row - f.window.row0,
       std::isfinite(f.max_distance) ? f.max_distance : std::numeric_limits<double>::infinity()});
  return preview;
}

}  // namespace horizon::visibility
