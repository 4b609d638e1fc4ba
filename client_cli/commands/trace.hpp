// trace.hpp — what `horizon trace` prints for one frame, shared by embedded
// and --server mode so both report a trace identically.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "horizon/geodesy/crs.hpp"
#include "horizon/geodesy/observer.hpp"
#include "horizon/terrain/grid.hpp"
#include "horizon/trace/camera.hpp"
#include "horizon/trace/products.hpp"
#include "horizon/trace/trace.hpp"

namespace horizon::cli {

struct TraceReport {
  std::string dem;         // path, or dataset name
  std::string server;      // "" embedded, else HOST:PORT
  geodesy::GridPoint eye;  // on the ground, in the DEM's grid
  std::optional<geodesy::LonLat> eye_lonlat;
  bool geographic = false;
  trace::CameraSpec camera;  // as asked
  bool columns = false;      // --columns
  trace::TraceStats stats;
  terrain::Window window;  // the cells read
  std::uint64_t dem_cells = 0, blocks = 0, blocks_total = 0, edited_cells = 0;
  std::vector<trace::BoxView> boxes;  // per --boxes line
  std::vector<std::uint64_t> ids;     // the boxes' ids from the file, one per box, or none
  double total_seconds = 0, write_seconds = 0;
};

// Text: the camera, view, mode, sky, work, reads and a line per box. JSON:
// the same figures, "boxes": [{"id":..,"pixels":..,"visible_pixels":..,
// "fraction":..}] ("id" only when the file gave ids), and with a server
// "server": {"address": ..}.
void print_trace(const TraceReport& report, bool json);

}  // namespace horizon::cli
