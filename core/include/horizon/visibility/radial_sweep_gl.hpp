// horizon/visibility/radial_sweep_gl.hpp — the fast occlusion height field as GL passes.
//
// The GL form of the CPU radial sweep (radial_sweep.hpp): the same rays, as patent
// 7,027,046 does them on graphics hardware, in three kinds of pass over a
// "disk" image whose rows are the rays of the four sweep sectors and whose
// columns are the steps outward from the eye:
//   1. perspective modulation: one texel per (ray, step) holds the terrain
//      sample the ray takes at that step (R3's grid-line crossings, exactly as
//      the CPU marches them) as a height relative to the eye divided by the
//      distance, together with where the sample lies;
//   2. propagation (the shift disk): passes that shift the disk radially away
//      from the eye and keep the larger value, until every texel holds the
//      maximum over its ray from the eye (the horizon). GpuOptions::log_step
//      doubles the shift each pass (shifts 1, 2, 4, ...: log2(N) passes);
//      without it every pass shifts one texel (N passes);
//   3. resolve: every DEM cell of the window reads the horizons of the two
//      rays that bracket it and blends them (RayBlend, as on the CPU), then
//      multiplies back by the distance into an OHF relative to the eye.
// GpuMethod::kFragment renders each pass as a full-screen triangle into
// RG32F/R32F targets; kCompute runs the same passes as compute shaders on
// image load/store.
//
// Precision: float32 throughout, like the CPU sweep, in coordinates relative
// to the eye: positions are window-relative cell offsets, heights are
// (z - eye_hi) - eye_lo with the eye split into two floats, and the OHF
// leaves the GPU relative to the eye and has the eye added in double on the
// way out. The near field needs no clamp: a step is never closer than the
// first grid line past the eye (> 0), and the distance a sample is divided by
// is that of the grid line it lies on. Measured tolerance against the CPU
// sweep: tests/gpu/test_gpu_ohf.cpp and docs/accuracy.md.
//
// RadialOptions::thinning_levels is not used: every ray runs the whole way.
#pragma once

#include "horizon/common/control.hpp"
#include "horizon/common/error.hpp"
#include "horizon/gpu/context_pool.hpp"
#include "horizon/terrain/grid.hpp"
#include "horizon/terrain/height_view.hpp"
#include "horizon/visibility/options.hpp"
#include "horizon/visibility/view_frame.hpp"
#include "horizon/visibility/work_stats.hpp"

namespace horizon::visibility {

// Same contract as radial_ohf(): fills `ohf` (sized frame.window)
// with the OHF of every in-range cell, NaN out of range or on a transparent
// void, -inf where nothing can block. The lease's context must be current.
// On a GL failure the lease is marked failed and the error returned
// (kResourceExhausted for sizes past the device's limits, kInternal for GL
// errors), for the caller to answer on the CPU.
Status radial_ohf_gl(gpu::Lease& lease, const terrain::HeightView& elevation, const ViewFrame& frame,
                     const RadialOptions& radial, const GpuOptions& options, const RunControl* control,
                     terrain::Grid<float>& ohf, WorkStats& stats);

// Builds the programs and objects of radial_ohf_gl() on every context of the
// pool now (11-21 ms for two contexts on llvmpipe, measured; a driver may
// still finish some work at a program's first draw), so that no request pays
// for compiling. Borrows all contexts at once: call it before
// serving. A context whose programs do not build is reported, not fatal:
// its requests will fall back to the CPU.
Status prepare_radial_gl(gpu::ContextPool& pool);

}  // namespace horizon::visibility
