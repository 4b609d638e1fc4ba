// From-region visibility over a terrain source (region_plan.hpp): the window
// bounding the region and its items, sized from the header, read once and
// classified on its own.
#include "horizon/region/region_plan.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <span>
#include <string>
#include <utility>

#include "horizon/visibility/view_frame.hpp"

namespace horizon::region {
namespace {

// What a run holds per window cell, bound: the elevations (4 bytes), the
// answer raster (1), and the classification's pyramids over the window
// (max and clearance levels, each under 4/3 of 4 bytes a cell: 11).
constexpr std::uint64_t kBytesPerCell = 16;

// An error about boxes[0] from resolve_boxes, reworded for the region.
Error as_region_error(Error e) {
  const std::string from = "boxes[0]";
  for (std::string* s : {&e.message, &e.field}) {
    const auto at = s->find(from);
    if (at != std::string::npos) s->replace(at, from.size(), "region");
  }
  return e;
}

terrain::Window merged(const terrain::Window& a, const terrain::Window& b) {
  if (a.empty()) return b;
  return {std::min(a.col0, b.col0), std::min(a.row0, b.row0), std::max(a.col1, b.col1), std::max(a.row1, b.row1)};
}

terrain::Window grown(const terrain::Window& w, std::int64_t cols, std::int64_t rows, int width, int height) {
  const auto clamp = [](std::int64_t v, int hi) { return static_cast<int>(std::clamp<std::int64_t>(v, 0, hi)); };
  return {clamp(w.col0 - cols, width), clamp(w.row0 - rows, height), clamp(w.col1 + cols, width),
          clamp(w.row1 + rows, height)};
}

}  // namespace

Result<RegionSourcePlan> plan_region(const terrain::ElevationSource& source, RegionQuery query) {
  HORIZON_RETURN_IF_ERROR(validate_region_options(query.options));
  if (!query.cells && query.boxes.empty())
    return make_error(ErrorCode::kInvalidArgument, "boxes: at least one box is needed (or ask for cells)", "boxes");
  const terrain::DemHeader& h = source.header();
  const RegionSpec& r = query.region;
  const visibility::BoxSpec as_box{r.frame, r.x_min, r.y_min, r.x_max, r.y_max, r.z_min, r.z_max};
  auto footprint = visibility::resolve_boxes(h.georef, h.width, h.height, h.source,
                                             std::span<const visibility::BoxSpec>(&as_box, 1));
  if (!footprint.ok()) return as_region_error(footprint.error());
  terrain::Window window = (*footprint)[0].cells;

  if (query.cells) {
    // Every cell within max_distance of the footprint: that many cells of
    // the smaller metric size at the region's centre, each way.
    const double d = query.options.max_distance;
    if (std::isfinite(d)) {
      const auto& t = h.georef.transform;
      const double x = t.x_at(0.5 * (window.col0 + window.col1 - 1)), y = t.y_at(0.5 * (window.row0 + window.row1 - 1));
      auto cell = visibility::metric_cell_size(h.georef, x, y, h.source);
      if (!cell.ok()) return cell.error();
      const auto reach = [&](double per) { return static_cast<std::int64_t>(std::min(std::ceil(d / per), 4.0e9)) + 1; };
      window = grown(window, reach(cell->per_col), reach(cell->per_row), h.width, h.height);
    } else {
      window = {0, 0, h.width, h.height};
    }
  } else {
    auto boxes = visibility::resolve_boxes(h.georef, h.width, h.height, h.source, query.boxes);
    if (!boxes.ok()) return boxes.error();
    for (const visibility::BoxFootprint& f : *boxes) window = merged(window, f.cells);
  }
  // One cell more each way: the nodes bracketing every crossing.
  window = grown(window, 1, 1, h.width, h.height);

  RegionSourcePlan plan;
  plan.window = window;
  plan.cells = window.cell_count();
  plan.bytes = plan.cells * kBytesPerCell + query.boxes.size() * kBytesPerBox;
  plan.query = std::move(query);
  return plan;
}

Result<RegionRun> run_region(const RegionSourcePlan& plan, const terrain::ElevationSource& source,
                             terrain::BlockCache* cache, const RunControl* control) {
  RegionRun run;
  auto dem = source.read(plan.window, cache, control, &run.read, plan.query.options.threads);
  if (!dem.ok()) return dem.error();
  const terrain::Window& got = run.read.window;
  const RegionQuery& q = plan.query;
  if (q.cells) {
    auto res = classify_cells(*dem, q.region, q.options, control);
    if (!res.ok()) return res.error();
    run.codes = std::move(res->codes);
    run.window = {res->window.col0 + got.col0, res->window.row0 + got.row0, res->window.col1 + got.col0,
                  res->window.row1 + got.row0};
    run.stats = res->stats;
  } else {
    auto res = classify_boxes(*dem, q.region, q.boxes, q.options, control);
    if (!res.ok()) return res.error();
    run.verdicts = std::move(res->verdicts);
    run.window = got;
    run.stats = res->stats;
  }
  return run;
}

}  // namespace horizon::region
