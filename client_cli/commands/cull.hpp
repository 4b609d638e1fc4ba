// cull.hpp — what `horizon cull` prints, shared by embedded and --server mode
// so both report a culling identically.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "horizon/geodesy/crs.hpp"
#include "horizon/geodesy/observer.hpp"
#include "horizon/visibility/cull.hpp"

namespace horizon::cli {

struct CullReport {
  std::string dem;  // path, or dataset name
  std::string boxes_path;
  std::string where;  // "" embedded, else "on HOST:PORT"
  geodesy::GridPoint observer;
  std::optional<geodesy::LonLat> observer_lonlat;
  bool geographic = false;
  bool conservative = false;
  visibility::CullResult result;
  std::vector<std::uint64_t> ids;  // the boxes' ids from the file, one per box, or none
  double total_seconds = 0;
};

// Text: a summary, then one line per box, labelled by its id or its index
// ("  12  hidden        ohf_min 1234.56 m  (34.56 m short)").
// JSON: the summary and "boxes": [{"id":..,"visible":..,"state":..,"ohf_min":..}, ...]
// ("id" only when the file gave ids; "visible" is false only for hidden boxes).
void print_cull(const CullReport& report, const std::vector<visibility::BoxSpec>& boxes, bool json);

}  // namespace horizon::cli
