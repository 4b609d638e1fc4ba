// Private to the exact sweep (exact.cpp): the screen of a sight line's
// crossings with one family of grid lines.
//
// The exact sweep proves, stretch by stretch, that no crossing of a target's
// sight line rises above the slope to beat. Where the max-pyramid cannot
// prune a stretch, each crossing in it is screened with cheap arithmetic
// (a reciprocal for R3's division, the terrain linearly interpolated from
// absolute coordinates) against the height that slope needs at the
// crossing's distance, with a margin that outweighs the rounding of both
// sums. Only a crossing that may reach it, or reads a void, is then taken
// exactly as R3 takes it (crossings.hpp): the screen decides which samples
// are looked at, never their values.
//
// This is a large share of exact's time, so it has three kernels with the same
// arithmetic, double operation for double operation: a scalar one, an AVX2
// one (four crossings a step, hardware gathers) and an AVX-512 one (eight),
// chosen at run time (simd_isa::kernel_isa()); runs of up to 8 lines take
// the scalar one, cheaper than a vector call's set-up. All return the same mask
// (tests/visibility/test_exact_screen.cpp); the file is built without fused
// multiply-adds.
#pragma once

#include <cstddef>
#include <cstdint>

#include "crossings.hpp"
#include "horizon/terrain/height_view.hpp"

namespace horizon::visibility::detail {

// One sight line's crossings with the lines of one family (column lines or
// row lines). Line `line` is crossed at t = (line - a0) * inv_da of the way
// from the eye, at position b0 + t * db along the line, clamped to
// [0, pos_max]; the terrain there interpolates the cells at positions p0 and
// p0 + 1, p0 = min(int(position), p_max), read at
// cells[line * line_stride + p0 * pos_stride] (+ pos_stride), voids (NaN)
// read as `fill` (HeightView::fill).
struct CrossingScreen {
  const float* cells = nullptr;
  std::ptrdiff_t line_stride = 0, pos_stride = 0;
  double a0 = 0, inv_da = 0;  // the eye's coordinate across the lines, 1 / (target's - eye's)
  double b0 = 0, db = 0;      // the eye's coordinate along the lines, target's - eye's
  double pos_max = 0;         // positions along a line: 0 .. pos_max
  int p_max = 0;              // pos_max - 1: the last cell an interpolation starts from
  float fill = 0;             // what a void reads as (NaN: voids are transparent)
  double total = 0;           // the sight line's length, metres
  double eye = 0;             // the eye's height, metres
  double curvature = 0;       // curvature per metre^2 (ViewFrame::curvature)
};

// The screen of segment (c0, r0) -> (c1, r1)'s crossings with one family
// of `z`'s grid lines, the segment `total` metres long from an eye at
// `eye` metres with `curvature`; [first, last] are the lines it crosses
// strictly between its ends inside the grid (none when first > last).
struct ScreenedFamily {
  CrossingScreen screen;
  int first = 0, last = -1;
};
ScreenedFamily screen_family(const terrain::HeightView& z, Axis axis, double c0, double r0, double c1, double r1,
                             double total, double eye, double curvature);

// Which of the `count` lines first, first + 1, ... (count in [1, 64]; every
// line and its cells inside the grid) may hold a crossing whose slope beats
// `slope`: bit i set for line first + i when its interpolated terrain is not
// below eye + slope d + curvature d^2 - 1e-6 (1 + |that|) at its distance d,
// or is NaN. A crossing whose R3 slope exceeds `slope` always has its bit
// set.
std::uint64_t screen_crossings(const CrossingScreen& screen, int first, int count, double slope);

// The same with the scalar kernel whatever the CPU, for the tests.
std::uint64_t screen_crossings_scalar(const CrossingScreen& screen, int first, int count, double slope);

}  // namespace horizon::visibility::detail
