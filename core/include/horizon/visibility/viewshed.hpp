// horizon/visibility/viewshed.hpp — the engine's viewshed entry point.
//
//   auto dem = terrain::read_dem("dem.tif");
//   auto eye = geodesy::resolve_point(*dem, {.x = 86.92, .y = 27.98, .height = 2,
//                                            .frame = geodesy::PointFrame::kWgs84}, "observer");
//   auto vs  = visibility::compute_viewshed(*dem, *eye, {.max_distance = 20000});
//   auto visible = visibility::visibility_mask(*dem, *vs, /*target_height=*/0);
//
// The result is the occlusion height field (OHF) over the max-distance window;
// every output raster is derived from it by one of the functions below, so the
// viewshed, the OHF and the minimum visible target height can never disagree:
//   min_target_height = OHF - z, or 0 when that is at most kTieTolerance  (float32, metres)
//   visible           = target_height >= min_target_height
// The tolerance settles ties: where the sight line grazes the terrain exactly
// (a flat sea, a plane) OHF == z in exact arithmetic, and which way float
// rounding falls must not decide visibility. 1 mm is about one float32 unit
// in the last place of an elevation near 8 km, far below any DEM's accuracy.
#pragma once

#include <cstdint>
#include <optional>

#include "horizon/common/control.hpp"
#include "horizon/common/error.hpp"
#include "horizon/geodesy/observer.hpp"
#include "horizon/gpu/context_pool.hpp"
#include "horizon/terrain/dem.hpp"
#include "horizon/terrain/height_view.hpp"
#include "horizon/terrain/preview.hpp"
#include "horizon/visibility/backend_policy.hpp"
#include "horizon/visibility/options.hpp"
#include "horizon/visibility/view_frame.hpp"
#include "horizon/visibility/work_stats.hpp"

namespace horizon::visibility {

// How many cells of a visible raster fell in each class, counted as the
// raster is made (a class, not a code: two classes may share a code).
struct AnswerCounts {
  std::uint64_t visible = 0, hidden = 0;
  std::uint64_t out_of_range = 0;  // no answer: beyond max distance, outside the field of view
  std::uint64_t nodata = 0;        // a void target
};

struct ViewshedResult {
  ViewFrame frame;               // geometry; frame.window locates the grids in the DEM
  terrain::Grid<float> ohf;      // absolute metres, window-sized; NaN = not computed; -inf = nothing can block
  terrain::Grid<float> terrain;  // window crop of the elevations used (voids filled per NodataPolicy)
  double target_height = 0.0;    // from the options, used by visibility_mask() by default
  FieldOfView field_of_view;     // from the options: the cells outside it have no answer
  WorkStats stats;
  // With ViewshedOptions::mask_only: visibility_mask(*this, target_height)
  // and its counts; `ohf` is empty when the sweep made the mask itself.
  std::optional<terrain::Grid<std::uint8_t>> mask;
  AnswerCounts mask_counts;
};

// Rasters whose storage a run may fill instead of allocating its own (a
// caller's Workspace, plan.hpp): result.ohf, result.terrain and (mask_only)
// result.mask take them over. Any may be null; their contents are
// overwritten. While it sweeps, the fast algorithm fills the terrain
// storage (or, mask_only, the OHF storage, which it then leaves with the
// caller) with its east and west sectors' lines (radial_ohf's
// column_buffer); without it those sectors read the DEM in place.
struct ResultStorage {
  terrain::Grid<float>* ohf = nullptr;
  terrain::Grid<float>* terrain = nullptr;
  terrain::Grid<std::uint8_t>* mask = nullptr;
};

// Validates the options, builds the frame and runs the chosen algorithm.
// Algorithm fast runs on `gpu` (may be null: no GPU) when options.backend is
// kGpu, or kAuto and `policy` prefers the GPU for the window's size (null:
// an unmeasured policy, so auto stays on the CPU); a request naming no GL
// variant runs the policy's preferred one. A GPU failure, or kGpu without a
// pool, is answered on the CPU with stats.gpu_fallback saying why.
// stats.backend says where it ran. `storage`: see ResultStorage.
Result<ViewshedResult> compute_viewshed(const terrain::Dem& dem, const geodesy::GridPoint& observer,
                                        const ViewshedOptions& options, const RunControl* control = nullptr,
                                        gpu::ContextPool* gpu = nullptr, const BackendPolicy* policy = nullptr,
                                        ResultStorage storage = {});

// The same for a caller done with the DEM's elevations (the one-shot CLI):
// when the window covers the whole grid, result.terrain takes over
// dem.elevation instead of copying it (dem.elevation is left empty; the rest
// of `dem` is untouched). On an error dem.elevation is untouched too.
Result<ViewshedResult> compute_viewshed_taking_elevation(terrain::Dem& dem, const geodesy::GridPoint& observer,
                                                         const ViewshedOptions& options,
                                                         const RunControl* control = nullptr,
                                                         gpu::ContextPool* gpu = nullptr,
                                                         const BackendPolicy* policy = nullptr,
                                                         ResultStorage storage = {});

// The elevations as the options' NodataPolicy reads them: voids
// transparent, or at nodata_fill_height (kFill). Borrows `elevation`.
terrain::HeightView elevation_view(const terrain::Grid<float>& elevation, const ViewshedOptions& options);

// Metres: an occlusion height at most this far above the ground counts as the ground itself.
inline constexpr float kTieTolerance = 1.0e-3f;

// The rule every raster derives from the OHF: the height above the ground
// `ground` a target needs to be seen under an OHF value `ohf` (float32
// arithmetic, 0 within kTieTolerance). A target of height h is visible when
// h >= min_target_height_at(ohf, ground).
inline float min_target_height_at(float ohf, float ground) {
  const float above = ohf - ground;
  return above > kTieTolerance ? above : 0.0f;
}

// Output rasters, all window-sized.
inline constexpr std::uint8_t kVisible = 1, kHidden = 0, kNoAnswer = 255;

// 1 visible / 0 hidden / 255 no answer (out of range, void target); rows
// on `threads` threads (0 = all hardware threads); the classes' counts in
// `counts` when given.
terrain::Grid<std::uint8_t> visibility_mask(const ViewshedResult& result, double target_height, unsigned threads = 1,
                                            AnswerCounts* counts = nullptr);
// The result's mask at its own target height with its counts
// (result.mask_counts): the one a mask_only run made, or visibility_mask()
// made now on `threads` threads and kept in the result.
const terrain::Grid<std::uint8_t>& ensure_mask(ViewshedResult& result, unsigned threads = 1);
// Minimum target height above ground that is visible, metres, >= 0; NaN for no answer.
terrain::Grid<float> min_target_height(const ViewshedResult& result);
// OHF floored at the terrain (equal to the terrain where the ground is visible); NaN for no answer.
terrain::Grid<float> ohf_raster(const ViewshedResult& result);

// Georeference of the window-sized outputs.
terrain::Georeference window_georef(const terrain::Dem& dem, const ViewshedResult& result);

// Preview settings for a picture of the result's window (metric cell sizes at
// the eye, the observer in window cells), for terrain::write_viewshed_preview
// with result.terrain and a visibility_mask().
terrain::PreviewOptions preview_options(const ViewshedResult& result);

}  // namespace horizon::visibility
