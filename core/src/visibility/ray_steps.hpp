// Private to the radial sweep: the per-line loops over the marching rays.
//
// Walking from line n-1 to line n (steps k-1 to k), each ray first finds its
// crossing of a v grid line inside the step, if any (step_cross); the line's
// cells are then evaluated (resample_cells.hpp); finally each ray folds that
// crossing and its crossing of line n itself into its running maximum
// (step_line). When the cells need only where each ray's horizon lies (the
// default re-sampling blend), step_rays does both loops in one pass before
// them. Together they are about half of the fast viewshed's time.
// Each has a scalar loop, an AVX2 kernel (eight rays at once, hardware
// gathers for the terrain reads, or loads of one run of each line when v is
// contiguous: see LineStep::run_last) and an AVX-512 kernel (sixteen), with the
// same float operations in the same order, chosen at run time
// (simd::kernel_isa()); all give the same bits
// (tests/visibility/test_ray_steps.cpp).
#pragma once

#include "sweep_samples.hpp"

namespace horizon::visibility::sweep {

// One line step's constants.
struct LineStep {
  float eye, eye_lo, eye_v;             // the eye's height as eye_hi + eye_lo (see eye_relative), its v position
  float v_min, v_max, kf, kp, k_start;  // v_min / v_max: the window's first and last v line
  int j_max, zv;                        // last v index a bracket may start at; v stride of the elevation
  float fill;                           // what a void reads as (Sector::fill)
  // Where v is contiguous (zv == 1: the north and south sectors, and the
  // east and west ones reading a transposed copy), the last v
  // index of `prev` and `cur` that may be read, inside the window or not:
  // the vector kernels then read a group's samples as one run of each line
  // (plain loads and in-register permutes) instead of hardware gathers,
  // whenever the run fits. -1: gathers only. The bits are the same.
  int run_last = -1;
};

// Crossing of a v grid line strictly inside (k_start, k) for rays [0, count)
// (|slope| <= 1: at most one). Rays that cross none get cross_v = -1 and a
// slope that never wins (kNoHorizon, or NaN where the clamped position reads
// a void). `prev` and `cur` are lines n-1 and n of the elevation. Also writes
// each ray's `code`: where its horizon lies once this crossing is counted
// (sample_at's code: the crossing's v line when it beats the running maximum
// `h`, else `arg`), which the line's cells re-sample.
void step_cross(const LineStep& ls, int count, const float* slope, const float* inv_slope, const float* curv_k,
                const float* prev, const float* cur, const float* h, const int* arg, float* cross_slope, int* cross_v,
                int* code);

// Folds each ray's v-line crossing of this step and its crossing of line n
// (`cur`) into its running maximum `h` and records where it lies in `arg`
// (line step n, or -2 - v for v line v). NaN slopes (voids) never win.
void step_line(const LineStep& ls, int count, const float* slope, const float* curv_k, const float* cur,
               const float* cross_slope, const int* cross_v, float* h, int* arg, int n);

// step_cross and step_line in one pass, for sweeps whose cells need only
// `code` (RayBlend::kResample): the same h, arg and code bits, without
// writing the crossings out and reading them back.
void step_rays(const LineStep& ls, int count, const float* slope, const float* inv_slope, const float* curv_k,
               const float* prev, const float* cur, float* h, int* arg, int* code, int n);

// The scalar loops whatever the CPU, for the tests.
void step_cross_scalar(const LineStep& ls, int count, const float* slope, const float* inv_slope, const float* curv_k,
                       const float* prev, const float* cur, const float* h, const int* arg, float* cross_slope,
                       int* cross_v, int* code);
void step_line_scalar(const LineStep& ls, int count, const float* slope, const float* curv_k, const float* cur,
                      const float* cross_slope, const int* cross_v, float* h, int* arg, int n);
void step_rays_scalar(const LineStep& ls, int count, const float* slope, const float* inv_slope, const float* curv_k,
                      const float* prev, const float* cur, float* h, int* arg, int* code, int n);

}  // namespace horizon::visibility::sweep
