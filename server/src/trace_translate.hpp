// trace_translate.hpp — a TraceCamera request (protos/horizon/v1/trace.proto)
// as the engine's trace::TraceQuery. Nothing here computes: enum values,
// required messages, channels and edit rectangles are checked here, naming
// the request's field ("camera", "edits[2].rect", "channels[1]"); the
// engine's own checks (plan_trace) name their fields as the engine does,
// and rename_trace_field turns those into the API's paths.
#pragma once

#include <string_view>
#include <vector>

#include "horizon/common/error.hpp"
#include "horizon/terrain/dem_reader.hpp"
#include "horizon/trace/trace_plan.hpp"
#include "horizon/v1/trace.pb.h"

namespace horizon::server {

struct TraceAsk {
  trace::TraceQuery query;
  bool gpu = false;                        // options.backend BACKEND_GPU
  std::vector<v1::TraceChannel> channels;  // in request order, each once
};

// The request against a dataset of header `header` (edit rectangles become
// the cells whose centres they hold). `threads`: the engine threads a call
// may use. The caller bounds boxes_size() by limits.max_boxes first; the
// edits' cells are bounded by the engine (terrain::validate_edits, in
// plan_trace), and their conversion here costs O(1) an edit.
Result<TraceAsk> to_trace_ask(const v1::TraceRequest& request, const terrain::DemHeader& header, unsigned threads);

// An engine error of plan_trace / run_trace with its field as the API names
// it: options ("near", "curvature_coefficient") under "options.", WGS84
// coordinates "camera.position.lon"/".lat" as ".x"/".y".
Error rename_trace_field(Error error);

// Bytes a pixel of `channel` takes on the wire (TraceChannel's layout).
std::size_t channel_pixel_bytes(v1::TraceChannel channel);

}  // namespace horizon::server
