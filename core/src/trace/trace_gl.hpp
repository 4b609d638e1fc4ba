// Private to core/trace: the GL form of the trace (trace.hpp), on a context
// borrowed from gpu::ContextPool. The same sub-frusta and per-column
// constants as the CPU (frustum.hpp); the map drawn as the paper draws it
// (line strips of the DEM's lines), the tree and the trace as fragment
// passes (trace_gl_shaders.hpp).
#pragma once

#include "frustum.hpp"
#include "horizon/gpu/context_pool.hpp"
#include "horizon/trace/trace.hpp"

namespace horizon::trace::detail {

// Traces `camera` over `view` into `image` (sized by the caller) on the
// leased context, filling `stats`' work counters. kUnsupported (and no GL
// call) for what the GL form does not do: the cylindrical projection (its
// lines do not project to straight segments) and column crossings; a
// sub-frustum larger than the device's textures is kResourceExhausted; a
// GL failure marks the lease failed. Polls `control` between sub-frusta.
Status trace_gl(const terrain::HeightView& view, const Camera& camera, const FrameGeometry& g,
                const TraceOptions& options, gpu::Lease& lease, const RunControl* control, TraceImage& image,
                TraceStats& stats);

}  // namespace horizon::trace::detail
