// cull.hpp — what `horizon cull` prints, shared by embedded and --server mode
// so both report a culling identically.
#pragma once

#include <string>
#include <vector>

#include "horizon/geodesy/crs.hpp"
#include "horizon/geodesy/observer.hpp"
#include "horizon/visibility/cull.hpp"

namespace horizon::cli {

struct CullReport {
  std::string dem;               // path, or dataset name
  std::string boxes_path;
  std::string where;             // "" embedded, else "on HOST:PORT"
  geodesy::GridPoint observer;
  std::optional<geodesy::LonLat> observer_lonlat;
  bool geographic = false;
  bool conservative = false;
  visibility::CullResult result;
  double total_seconds = 0;
};

// Text: a summary, then one line per box ("  12  hidden   ohf_min 1234.56 m  (z_max 1200.00, 34.56 m short)").
// JSON: the summary and "boxes": [{"visible":..,"ohf_min":..}, ...].
void print_cull(const CullReport& report, const std::vector<visibility::BoxSpec>& boxes, bool json);

}  // namespace horizon::cli
