// Private to the radial sweep: the cells of one line, RayBlend::kResample.
//
// After the rays have crossed into a line (radial_sweep.cpp, step 1), each
// cell of the line re-samples its own sight line where its two bracketing
// rays found their horizons and on the line before it (sweep_samples.hpp),
// keeps the highest sample and writes its occlusion height. This is most of
// the fast viewshed's time, so it has three kernels with the same
// arithmetic, float operation for float operation: a scalar one, an AVX2 one
// that evaluates eight cells at once with hardware gathers, and an AVX-512
// one that evaluates sixteen, chosen at run time (simd::kernel_isa()). All
// give the same bits (tests/visibility/test_resample_cells.cpp).
//
// A cell's code (ResampleLine::mask) needs less than its height. The code
// only moves towards hidden as the highest sample rises (the height is
// eye + k * best + curvature d^2, rounded, and min_target_height_at grows
// with it), so once one sample hides a cell no other can show it. The
// kernels take first the sample where the cell's lower ray found its horizon
// and, when that alone hides every cell of the group, code them from it and
// skip the rest: behind a ridge, most of a viewshed. The codes are the bits
// a full evaluation gives.
#pragma once

#include <cstddef>
#include <cstdint>

#include "sweep_samples.hpp"

namespace horizon::visibility::sweep {

// One line of one task of the sweep.
struct ResampleLine {
  const CellLine* cells = nullptr;  // the line's sampling geometry
  // Per marching ray of the task (index i): where its horizon lies once this
  // step's v-line crossing is counted, as sample_at's code (u line step >= 0,
  // -2 - v for v line v, -1 for none).
  const int* code = nullptr;
  int n = 0;                         // the line's step index (step k = k0 + n)
  int ra = 0;                        // the task's first ray (plan index)
  int level = 0;                     // thinning level: marching ray i is plan ray ra + (i << level)
  int ray_half = 0;                  // plan rays r in [-ray_half, ray_half], slope r / ray_half
  double eye_v = 0.0;                // the eye's v position
  double inv_k = 0.0;                // 1 / k
  double k = 0.0;                    // the line's step
  double eye = 0.0;                  // the eye's height (metres)
  double curvature = 0.0;            // curvature per metre^2
  double du2 = 0.0;                  // (k * metres along u)^2
  double metres_v = 0.0;             // metres per v index
  const float* elevation = nullptr;  // the line's elevation: v index j at elevation[j * zv]
  float* out = nullptr;              // the line's output: v index j at out[j * o_v]
  std::ptrdiff_t o_v = 0;
  // The visibility mask instead of the heights (radial_mask): when set, each
  // cell's code at `target_height` goes to mask[j * o_v] and `out` is not
  // used. The code is visibility_mask()'s, by min_target_height_at's rule on
  // the height the cell would have had: kVisible, kHidden, kNoAnswer on a
  // void target. The cells coded kVisible are added to *visible.
  std::uint8_t* mask = nullptr;
  float target_height = 0.0f;
  std::uint64_t* visible = nullptr;
};

// Evaluates the cells j in [j_begin, j_end] of `line`. Every one must belong
// to the task (its bracketing rays are marching rays i0, i0 + 1 with i0 =
// (floor(rho) - ra) >> level, rho = (j - eye_v) / k * ray_half) and lie
// inside max distance. Writes each cell's occlusion height (-inf when no
// sample was taken; NaN, no answer, on a void target), or its code when
// `line.mask` is set, and returns how many non-void cells it answered.
std::uint64_t resample_cells(const ResampleLine& line, int j_begin, int j_end);

// The same with the scalar kernel whatever the CPU, for the tests.
std::uint64_t resample_cells_scalar(const ResampleLine& line, int j_begin, int j_end);

}  // namespace horizon::visibility::sweep
