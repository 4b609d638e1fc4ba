// viewshed_many_call.hpp — ComputeViewshed with many observers
// (ViewshedRequest.observers): what the stream sends, computed here and
// sent by viewshed_call.cpp's write chain like a single viewshed's.
#pragma once

#include <cstddef>
#include <string>

#include <grpcpp/grpcpp.h>

#include "call_scope.hpp"
#include "horizon/v1/visibility.pb.h"

namespace horizon::server {

struct ViewshedParts {
  v1::ViewshedHeader header;
  v1::ViewshedSummary summary;
  std::string raster;  // raw little-endian rows, when asked for
  std::string geotiff, png;
  std::size_t row_bytes = 0;
};

// Checks the request (limits.max_observers, each site, the union window
// against limits.max_cells, the memory), reads the window once and
// accumulates; errors name the field ("observers[3].point", "observers").
grpc::Status compute_many_viewshed(CallScope& scope, const v1::ViewshedRequest& request, ViewshedParts& out);

}  // namespace horizon::server
