// Camera traces planned on a source's header, then run (trace_plan.hpp).
#include "horizon/trace/trace_plan.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>

#include "horizon/common/parallel.hpp"
#include "horizon/visibility/view_frame.hpp"
#include "silhouette.hpp"

namespace horizon::trace {
namespace {

constexpr int kReadMargin = 2;
// Measured on one core (docs/benchmarks.md, "Camera traces"): estimates for
// admission, not promises.
constexpr double kSecondsPerCrossing = 4e-9;
constexpr double kSecondsPerPixelRead = 3e-9;
constexpr double kSecondsPerBoxPixel = 5e-9;

Error prefixed(const Error& e, const std::string& prefix) {
  Error out = e;
  out.field = prefix + e.field;
  out.message = prefix + (e.message.rfind("camera ", 0) == 0 ? e.message.substr(7) : e.message);
  return out;
}

// The bounding box, in continuous cells, of the ground wedge between
// azimuths [a0, a1] (radians, a1 - a0 < 2 pi: a wedge; else the whole disc)
// out to `reach` metres from `eye`.
void wedge_box(const geodesy::GridPoint& eye, double a0, double a1, double reach, double per_col, double per_row,
               double& c0, double& r0, double& c1, double& r1) {
  c0 = c1 = eye.col;
  r0 = r1 = eye.row;
  auto take = [&](double az) {
    const double c = eye.col + reach * std::sin(az) / per_col, r = eye.row - reach * std::cos(az) / per_row;
    c0 = std::min(c0, c);
    c1 = std::max(c1, c);
    r0 = std::min(r0, r);
    r1 = std::max(r1, r);
  };
  if (a1 - a0 >= 2.0 * std::numbers::pi) {
    for (int q = 0; q < 4; ++q) take(q * std::numbers::pi / 2.0);
    return;
  }
  take(a0);
  take(a1);
  // The compass points the wedge spans are its extremes: at most four in a
  // wedge narrower than a turn. Counted, not only compared, since a yaw of
  // 1e20 degrees is finite but adding a quarter turn to it changes nothing.
  const double quarter = std::numbers::pi / 2.0;
  int points = 0;
  for (double q = std::ceil(a0 / quarter) * quarter; q < a1 && points < 4; q += quarter, ++points) take(q);
}

}  // namespace

Result<TracePlan> plan_trace(const terrain::ElevationSource& source, const TraceQuery& query, unsigned threads) {
  if (Status s = validate_camera(query.camera); !s.ok()) return prefixed(s.error(), "camera.");
  HORIZON_RETURN_IF_ERROR(validate_trace_options(query.options));
  const terrain::DemHeader& h = source.header();
  if (h.width < 2 || h.height < 2)
    return make_error(ErrorCode::kDataError,
                      "dem '" + h.source + "': a trace needs at least 2x2 cells, the DEM has " +
                          std::to_string(h.width) + "x" + std::to_string(h.height),
                      "dem");
  HORIZON_RETURN_IF_ERROR(terrain::validate_edits(query.edits, h.width, h.height));

  TracePlan plan;
  plan.query = query;
  auto eye = geodesy::locate_point(h.georef, h.width, h.height, query.camera.position, "camera.position", h.source);
  if (!eye.ok()) return eye.error();
  plan.eye = *eye;
  auto cell = visibility::metric_cell_size(h.georef, plan.eye.x, plan.eye.y, h.source);
  if (!cell.ok()) return cell.error();
  // The camera's columns without its eye height (make_camera needs none for
  // its azimuths): the wedge and the boxes' pixel bound come from them.
  auto camera = make_camera(query.camera, plan.eye, cell->per_col, cell->per_row);
  if (!camera.ok()) return prefixed(camera.error(), "camera.");

  // The wedge out to max_distance, or to the source's farthest corner.
  double reach = query.options.max_distance;
  if (!std::isfinite(reach)) {
    reach = 0.0;
    for (double c : {-0.5, h.width - 0.5})
      for (double r : {-0.5, h.height - 0.5})
        reach = std::max(reach, std::hypot((c - plan.eye.col) * cell->per_col, (r - plan.eye.row) * cell->per_row));
  }
  const double half_column = query.camera.hfov * std::numbers::pi / 180.0 / query.camera.width;
  double c0 = 0, r0 = 0, c1 = 0, r1 = 0;
  wedge_box(plan.eye, camera->azimuth.front() - half_column, camera->azimuth.back() + half_column, reach, cell->per_col,
            cell->per_row, c0, r0, c1, r1);
  auto clamp_to = [](double v, int n) { return static_cast<int>(std::clamp(v, 0.0, static_cast<double>(n))); };
  plan.read = {clamp_to(std::floor(c0) - kReadMargin, h.width), clamp_to(std::floor(r0) - kReadMargin, h.height),
               clamp_to(std::ceil(c1) + kReadMargin + 1, h.width), clamp_to(std::ceil(r1) + kReadMargin + 1, h.height)};
  // At least 2 x 2 cells around the eye's cell.
  const int ec = std::clamp(static_cast<int>(std::floor(plan.eye.col)), 0, h.width - 2);
  const int er = std::clamp(static_cast<int>(std::floor(plan.eye.row)), 0, h.height - 2);
  plan.read = {std::min(plan.read.col0, ec), std::min(plan.read.row0, er), std::max(plan.read.col1, ec + 2),
               std::max(plan.read.row1, er + 2)};
  plan.blocks = source.blocks_in(plan.read);

  if (!query.boxes.empty()) {
    auto boxes =
        visibility::resolve_boxes(h.georef, h.width, h.height, h.source, query.boxes, visibility::OffMap::kAnswer);
    if (!boxes.ok()) return boxes.error();
    plan.boxes = std::move(*boxes);
  }

  TraceCost& cost = plan.cost;
  cost.pixels = static_cast<std::uint64_t>(query.camera.width) * static_cast<std::uint64_t>(query.camera.height);
  cost.read_cells = plan.read.cell_count();
  cost.blocks = plan.blocks.size();
  for (std::uint64_t b : plan.blocks) cost.block_bytes += source.block_bytes(b);
  cost.lines = static_cast<std::uint64_t>(std::max(plan.read.width(), plan.read.height()));
  const std::uint64_t families = query.options.column_crossings ? 2 : 1;
  cost.crossings = families * static_cast<std::uint64_t>(query.camera.width) * cost.lines;
  std::vector<ViewBox> boxes;
  for (const visibility::BoxFootprint& f : plan.boxes)
    if (f.on_map) boxes.push_back({f.col_min, f.col_max, f.row_min, f.row_max, f.z_min, f.z_max});
  cost.box_pixel_tests = box_pixel_bound(*camera, boxes);
  if (cost.box_pixel_tests > kMaxBoxPixelTests)
    return make_error(ErrorCode::kResourceExhausted,
                      "boxes: " + std::to_string(plan.boxes.size()) + " boxes span " +
                          std::to_string(cost.box_pixel_tests) + " pixel tests in a " +
                          std::to_string(query.camera.width) + "x" + std::to_string(query.camera.height) +
                          " frame, over the limit of " + std::to_string(kMaxBoxPixelTests) +
                          "; send fewer or smaller boxes, or a smaller frame",
                      "boxes");
  for (const terrain::HeightEdit& e : query.edits) cost.edit_cells += e.cells.cell_count();
  // Each thread's block: kBlock columns of map and tree (4/3 of the map in
  // RGBA texels), per family.
  const std::uint64_t per_thread = families * detail::kBlock * cost.lines * sizeof(float) * 3;
  cost.bytes = cost.read_cells * sizeof(float) + cost.pixels * (sizeof(float) + sizeof(std::int32_t) + 1) +
               resolve_thread_count(threads) * per_thread + cost.pixels * sizeof(float) * 4 + cost.read_cells +
               2 * cost.edit_cells * sizeof(float);  // the plan's copy of the edits and the caller's
  const double levels = std::ceil(std::log2(std::max<double>(2.0, static_cast<double>(cost.lines))) / 2.0);
  cost.seconds =
      static_cast<double>(cost.crossings) * kSecondsPerCrossing +
      static_cast<double>(cost.pixels) * static_cast<double>(families) * (levels + 2) * kSecondsPerPixelRead +
      static_cast<double>(cost.box_pixel_tests) * kSecondsPerBoxPixel;
  return plan;
}

Result<TraceRun> run_trace(const TracePlan& plan, const terrain::ElevationSource& source, terrain::BlockCache* cache,
                           const RunControl* control, gpu::Lease* gpu, TraceRun* previous) {
  TraceRun run;
  if (previous) run.frame = std::move(previous->frame);
  auto dem = source.read(plan.read, cache, control, &run.read, plan.query.options.threads);
  if (!dem.ok()) return dem.error();
  run.dem = std::move(*dem);
  run.window = run.read.window;
  run.georef = source.header().georef;
  run.georef.transform = source.header().georef.transform.shifted(run.window.col0, run.window.row0);
  run.edited_cells = terrain::apply_edits(run.dem, run.window.col0, run.window.row0, plan.query.edits);

  geodesy::GridPoint eye = plan.eye;
  eye.col -= run.window.col0;
  eye.row -= run.window.row0;
  auto placed =
      geodesy::place_on_ground(run.dem, eye, plan.query.camera.position, "camera", run.window.col0, run.window.row0);
  if (!placed.ok()) return placed.error();
  auto cell = visibility::metric_cell_size(source.header().georef, plan.eye.x, plan.eye.y, source.header().source);
  if (!cell.ok()) return cell.error();
  auto camera = make_camera(plan.query.camera, *placed, cell->per_col, cell->per_row);
  if (!camera.ok()) return prefixed(camera.error(), "camera.");
  run.eye = *placed;
  run.eye.col += run.window.col0;
  run.eye.row += run.window.row0;

  HORIZON_RETURN_IF_ERROR(trace_frame(run.view(), *camera, plan.query.options, run.frame, control, gpu));

  std::vector<ViewBox> boxes(plan.boxes.size());
  std::vector<std::size_t> on_map;
  for (std::size_t i = 0; i < plan.boxes.size(); ++i) {
    const visibility::BoxFootprint& f = plan.boxes[i];
    if (!f.on_map) continue;
    boxes[on_map.size()] = {f.col_min - run.window.col0,
                            f.col_max - run.window.col0,
                            f.row_min - run.window.row0,
                            f.row_max - run.window.row0,
                            f.z_min,
                            f.z_max};
    on_map.push_back(i);
  }
  boxes.resize(on_map.size());
  auto views = box_views(run.frame, boxes, plan.query.options, control);
  if (!views.ok()) return views.error();
  run.boxes.assign(plan.boxes.size(), BoxView{});
  for (std::size_t k = 0; k < on_map.size(); ++k) run.boxes[on_map[k]] = (*views)[k];
  return run;
}

}  // namespace horizon::trace
