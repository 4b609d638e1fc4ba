// Plans: a query checked and placed on a source's header, its cells and cost
// known; runs: the planned cells read and the engine run on them.
#include "horizon/visibility/plan.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>
#include <utility>

#include "horizon/common/large_allocator.hpp"

namespace horizon::visibility {
namespace {

// Cells beyond the window that a read adds, so that the window the engine
// finds on the read cells equals the one it would find on the whole source
// (cells_within and make_view_frame round the disc's edge separately).
constexpr int kReadMargin = 2;

// Measured single-core costs per answered cell (docs/benchmarks.md, the
// 12 M-cell case): estimates for admission, not promises.
// One ray's step of the sweep: ~2.2 per cell at the default spacing, 16 ns
// a cell in all.
constexpr double kSweepSecondsPerRayStep = 7e-9;
// A ray's table entry (slope, inverse, curvature: sweep_geometry.hpp's
// RayTable) and its share of the per-task scratch (radial_sweep.cpp).
constexpr std::uint64_t kSweepBytesPerRay = 12 + 32;
// Conservative's re-sampling on top of the sweep: 19 ns (AVX-512 kernels)
// and 31 ns (AVX2) measured; exact's search, R3's whole OHF: 0.18 us and
// 0.21 us on the 12 M-cell case, 0.35 us on Rainier's SRTM tile and
// 0.41 us on Gabon's from its summit (thread time per cell). Scalar-only
// CPUs take several times longer.
constexpr double kConservativeSecondsPerCell = 40e-9;
constexpr double kExactSecondsPerCell = 0.5e-6;
constexpr double kR3SecondsPerCellPerCrossing = 12e-9;  // R3 walks ~ the distance in cells per target
constexpr double kLineSecondsPerCrossing = 20e-9;

// Tables of exact (sector_bounds.hpp): near the eye at most 12 MB; beyond
// it 4 KB per 64 cells of the window's diagonal (1024 sectors, a float per
// band of distance).
constexpr std::uint64_t kExactFixedBytes = 16ull << 20;
constexpr double kExactBytesPerDiagonalCell = 1024.0 * sizeof(float) / 64.0;

ReadPlan plan_read(const terrain::ElevationSource& source, const terrain::Window& read) {
  return {read, source.blocks_in(read)};
}

void add_read_cost(const terrain::ElevationSource& source, const ReadPlan& read, Cost& cost) {
  cost.read_cells = read.read.cell_count();
  cost.blocks = read.blocks.size();
  for (std::uint64_t b : read.blocks) cost.block_bytes += source.block_bytes(b);
  cost.bytes += cost.read_cells * sizeof(float);
}

// The OHF and the terrain crop per answered cell, and what the algorithm adds.
Status add_ohf_cost(const ViewshedOptions& o, const terrain::Window& output, double radius_cells, Cost& cost) {
  const auto cells = static_cast<double>(output.cell_count());
  cost.cells = output.cell_count();
  cost.bytes += cost.cells * 2 * sizeof(float);
  if (o.algorithm != Algorithm::kR3) HORIZON_RETURN_IF_ERROR(add_sweep_cost(o, output, cost));
  switch (o.algorithm) {
    case Algorithm::kRadial:
      // With a workspace, the east and west sectors' transposed lines fill
      // the OHF raster's share (mask_only) or the terrain's (filled after
      // the sweep), and one cell more around the window.
      cost.bytes +=
          (2 * (static_cast<std::uint64_t>(output.width()) + static_cast<std::uint64_t>(output.height())) + 4) *
          sizeof(float);
      break;  // the sweep's steps are its time
    case Algorithm::kConservative:
      cost.seconds += cells * kConservativeSecondsPerCell;
      break;
    case Algorithm::kExact:
      // The max-pyramid (~1 B a cell) and the sector bounds.
      cost.bytes += cost.cells + kExactFixedBytes +
                    static_cast<std::uint64_t>(kExactBytesPerDiagonalCell *
                                               std::hypot(double(output.width()), double(output.height())));
      cost.seconds += cells * kExactSecondsPerCell;
      break;
    case Algorithm::kR3:
      cost.seconds += cells * radius_cells * kR3SecondsPerCellPerCrossing;
      break;
  }
  return Status::Ok();
}

// Puts a located point on the ground of a window read from the source: the
// exact integer shift, then place_on_ground, whose messages name the cell in
// the source's grid.
Result<geodesy::GridPoint> on_ground(const terrain::Dem& dem, const terrain::Window& read, geodesy::GridPoint located,
                                     const geodesy::PointSpec& spec, const char* what) {
  located.col -= read.col0;
  located.row -= read.row0;
  return geodesy::place_on_ground(dem, located, spec, what, read.col0, read.row0);
}

template <class T>
bool keepable(const terrain::Grid<T>& g) {
  return g.capacity() * sizeof(T) <= Workspace::kMaxKeptBytes;
}

// Keeps `done`'s storage in `kept` when it is within the limit and larger,
// backed by huge pages from then on (the next runs read and write it across
// rows; the first call collapses its pages once, later ones cost
// microseconds).
template <class T>
void keep(terrain::Grid<T>& kept, terrain::Grid<T>&& done) {
  if (keepable(done) && done.capacity() >= kept.capacity()) kept = std::move(done);
  done = terrain::Grid<T>();
  if (kept.capacity() > 0) back_with_huge_pages(kept.data(), kept.capacity() * sizeof(T));
}

// Hands a run's cells back to its workspace (or frees them).
void keep_or_release(terrain::Grid<float>& cells, Workspace* workspace) {
  if (workspace) keep(workspace->cells, std::move(cells));
  cells = terrain::Grid<float>();
}

ResultStorage storage_of(Workspace* workspace) {
  if (!workspace) return {};
  return {&workspace->ohf, &workspace->terrain, &workspace->mask};
}

geodesy::GridPoint to_source(geodesy::GridPoint p, const terrain::Window& read) {
  p.col += read.col0;
  p.row += read.row0;
  return p;
}

terrain::Window shifted(const terrain::Window& w, int dc, int dr) {
  return {w.col0 + dc, w.row0 + dr, w.col1 + dc, w.row1 + dr};
}

Result<geodesy::GridPoint> locate(const terrain::ElevationSource& source, const geodesy::PointSpec& spec,
                                  const char* what) {
  const terrain::DemHeader& h = source.header();
  return geodesy::locate_point(h.georef, h.width, h.height, spec, what, h.source);
}

}  // namespace

// The radial sweep's rays over `output` (sweep_geometry.hpp's ray_half for
// the farthest line a sector can have), their tables and their steps.
// kResourceExhausted naming ray_spacing beyond kMaxSweepRays a sector.
Status add_sweep_cost(const ViewshedOptions& o, const terrain::Window& output, Cost& cost) {
  const double reach = std::max(output.width(), output.height());  // lines in the longest sector, at most
  const double half = std::ceil(reach / o.radial.ray_spacing);
  const double per_sector = 2 * half + 1;
  if (per_sector > static_cast<double>(kMaxSweepRays)) {
    const double floor_spacing = reach / (0.5 * static_cast<double>(kMaxSweepRays));
    return make_error(ErrorCode::kResourceExhausted,
                      "ray_spacing: " + number_text(o.radial.ray_spacing, 3) + " cells over a reach of " +
                          number_text(reach, 3) + " cells needs " + number_text(per_sector, 3) +
                          " rays a sector, more than the sweep's limit of " + std::to_string(kMaxSweepRays) +
                          "; use a ray_spacing of at least " + number_text(floor_spacing, 3) +
                          " or a smaller max_distance",
                      "ray_spacing");
  }
  cost.sweep_rays = static_cast<std::uint64_t>(4 * per_sector);
  cost.sweep_bytes = cost.sweep_rays * kSweepBytesPerRay;
  cost.bytes += cost.sweep_bytes;
  // Every ray marches through the lines of its sector's wedge: about half
  // the reach for an observer inside the window, all of it at an edge.
  cost.seconds += static_cast<double>(cost.sweep_rays) * (0.5 * reach) * kSweepSecondsPerRayStep;
  return Status::Ok();
}

void Workspace::recycle(ViewshedResult&& done) {
  keep(ohf, std::move(done.ohf));
  // A run over its whole read window takes the read buffer over as its
  // terrain (compute_viewshed_taking_elevation) and leaves `cells` empty:
  // the terrain buffer it displaces becomes the next read buffer, so the two
  // alternate instead of a new one being mapped and populated every run.
  if (keepable(done.terrain) && done.terrain.capacity() >= terrain.capacity()) std::swap(terrain, done.terrain);
  keep(cells, std::move(done.terrain));
  if (terrain.capacity() > 0) back_with_huge_pages(terrain.data(), terrain.capacity() * sizeof(float));
  if (done.mask) keep(mask, std::move(*done.mask));
  done.mask.reset();
}

void Workspace::trim() {
  for (terrain::Grid<float>* g : {&cells, &ohf, &terrain})
    if (!keepable(*g)) *g = terrain::Grid<float>();
  if (!keepable(mask)) mask = terrain::Grid<std::uint8_t>();
}

std::uint64_t Workspace::kept_bytes() const {
  std::uint64_t bytes = mask.capacity() * sizeof(std::uint8_t);
  for (const terrain::Grid<float>* g : {&cells, &ohf, &terrain}) bytes += g->capacity() * sizeof(float);
  return bytes;
}

geodesy::GridPoint ViewshedRun::observer_in_source() const {
  return to_source(observer, read.window);
}

Result<ViewshedPlan> plan_viewshed(const terrain::ElevationSource& source, const ViewshedQuery& query) {
  HORIZON_RETURN_IF_ERROR(validate_options(query.options));
  const terrain::DemHeader& h = source.header();
  if (h.width < 2 || h.height < 2)
    return make_error(ErrorCode::kDataError,
                      "dem '" + h.source + "': a viewshed needs at least 2x2 cells, the DEM has " +
                          std::to_string(h.width) + "x" + std::to_string(h.height),
                      "dem");
  ViewshedPlan plan;
  plan.query = query;
  auto located = locate(source, query.observer, "observer");
  if (!located.ok()) return located.error();
  plan.observer = *located;
  const double radius = query.options.max_distance;
  plan.output = geodesy::cells_within(h.georef, h.width, h.height, plan.observer, radius, 0);
  plan.read = plan_read(source, geodesy::cells_within(h.georef, h.width, h.height, plan.observer, radius, kReadMargin));
  add_read_cost(source, plan.read, plan.cost);
  auto cell = metric_cell_size(h.georef, plan.observer.x, plan.observer.y, h.source);
  if (!cell.ok()) return cell.error();
  const double radius_cells =
      0.5 * std::hypot(plan.output.width(), plan.output.height());  // the farthest a target may be, in cells
  HORIZON_RETURN_IF_ERROR(add_ohf_cost(query.options, plan.output, radius_cells, plan.cost));
  return plan;
}

Result<ViewshedRun> run_viewshed(const ViewshedPlan& plan, const terrain::ElevationSource& source,
                                 terrain::BlockCache* cache, const RunControl* control, gpu::ContextPool* gpu,
                                 const BackendPolicy* policy, Workspace* workspace) {
  ViewshedRun run;
  // An uncached read decodes on every core: it is the file's work, not the engine's.
  auto dem = source.read(plan.read.read, cache, control, &run.read, 0, workspace ? &workspace->cells : nullptr);
  if (!dem.ok()) return dem.error();
  run.dem = std::move(*dem);
  auto observer = on_ground(run.dem, run.read.window, plan.observer, plan.query.observer, "observer");
  if (!observer.ok()) return observer.error();
  run.observer = *observer;
  // Voids are filled as the kernels read them (NodataPolicy, elevation_view).
  auto result = compute_viewshed_taking_elevation(run.dem, run.observer, plan.query.options, control, gpu, policy,
                                                  storage_of(workspace));
  if (!result.ok()) return result.error();
  run.result = std::move(*result);
  run.result.stats.dem_cells = static_cast<std::uint64_t>(source.width()) * static_cast<std::uint64_t>(source.height());
  run.window = shifted(run.result.frame.window, run.read.window.col0, run.read.window.row0);
  run.georef = source.header().georef;
  run.georef.transform = source.header().georef.transform.shifted(run.window.col0, run.window.row0);
  keep_or_release(run.dem.elevation, workspace);  // result.terrain holds the window's crop
  return run;
}

Result<CullBoxesPlan> plan_cull_boxes(const terrain::ElevationSource& source, CullQuery query) {
  if (query.boxes.empty()) return make_error(ErrorCode::kInvalidArgument, "boxes: at least one box is needed", "boxes");
  const terrain::DemHeader& h = source.header();
  CullBoxesPlan plan;
  auto located = locate(source, query.observer, "observer");
  if (!located.ok()) return located.error();
  plan.observer = *located;
  auto footprints = resolve_boxes(h.georef, h.width, h.height, h.source, query.boxes, OffMap::kAnswer);
  if (!footprints.ok()) return footprints.error();
  plan.footprints = std::move(*footprints);

  ViewshedOptions& vs = plan.viewshed;
  vs = query.options.viewshed;
  vs.target_height = 0.0;
  vs.max_distance = std::numeric_limits<double>::infinity();
  if (query.options.conservative) vs.algorithm = Algorithm::kConservative;
  HORIZON_RETURN_IF_ERROR(validate_options(vs));
  // The boxes' reach from the eye, as plan_cull finds it on a whole DEM.
  auto cell = metric_cell_size(h.georef, plan.observer.x, plan.observer.y, h.source);
  if (!cell.ok()) return cell.error();
  ViewFrame at_eye;
  at_eye.observer_col = plan.observer.col;
  at_eye.observer_row = plan.observer.row;
  at_eye.metres_per_col = cell->per_col;
  at_eye.metres_per_row = cell->per_row;
  const double reach = cull_reach(at_eye, plan.footprints);
  vs.max_distance = std::max(reach * (1.0 + 1e-9) + 1e-6, std::min(cell->per_col, cell->per_row));

  const terrain::Window output = geodesy::cells_within(h.georef, h.width, h.height, plan.observer, vs.max_distance, 0);
  plan.read = plan_read(
      source, geodesy::cells_within(h.georef, h.width, h.height, plan.observer, vs.max_distance, kReadMargin));
  add_read_cost(source, plan.read, plan.cost);
  HORIZON_RETURN_IF_ERROR(add_ohf_cost(vs, output, 0.5 * std::hypot(output.width(), output.height()), plan.cost));
  // The min-pyramids (each under 1.4 bytes a cell; 4/3 of the OHF, an upper
  // bound; the second, voids as +inf, only under boxes that meet a void)
  // and, per box, its spec, footprint and answer.
  plan.cost.bytes += 2 * (plan.cost.cells * sizeof(float) * 4 / 3) + plan.footprints.size() * kCullBytesPerBox;
  plan.query = std::move(query);
  return plan;
}

Result<CullBoxesRun> run_cull_boxes(const CullBoxesPlan& plan, const terrain::ElevationSource& source,
                                    terrain::BlockCache* cache, const RunControl* control, gpu::ContextPool* gpu,
                                    const BackendPolicy* policy, Workspace* workspace) {
  CullBoxesRun run;
  const terrain::Window& read = plan.read.read;
  auto dem = source.read(read, cache, control, &run.read, 0, workspace ? &workspace->cells : nullptr);
  if (!dem.ok()) return dem.error();
  const terrain::Window& got = run.read.window;
  auto observer = on_ground(*dem, got, plan.observer, plan.query.observer, "observer");
  if (!observer.ok()) return observer.error();
  // The footprints were resolved on the source's grid: shift them (integers)
  // rather than resolve them again on the window's georeference.
  CullPlan local;
  local.viewshed = plan.viewshed;
  local.any_on_map =
      std::any_of(plan.footprints.begin(), plan.footprints.end(), [](const BoxFootprint& f) { return f.on_map; });
  local.footprints.reserve(plan.footprints.size());
  for (BoxFootprint f : plan.footprints) {
    f.cells = shifted(f.cells, -got.col0, -got.row0);
    local.footprints.push_back(f);
  }
  auto frame = make_view_frame(*dem, *observer, local.viewshed);
  if (!frame.ok()) return frame.error();
  local.frame = *frame;
  auto result = run_cull(*dem, *observer, local, control, gpu, policy, storage_of(workspace));
  if (workspace) workspace->trim();
  if (!result.ok()) return result.error();
  run.result = std::move(*result);
  run.result.window = shifted(run.result.window, got.col0, got.row0);
  run.result.stats.dem_cells = static_cast<std::uint64_t>(source.width()) * static_cast<std::uint64_t>(source.height());
  run.observer = to_source(*observer, got);
  keep_or_release(dem->elevation, workspace);
  return run;
}

Result<LinePlan> plan_line(const terrain::ElevationSource& source, const LineQuery& query) {
  LinePlan plan;
  plan.query = query;
  auto from = locate(source, query.from, "from");
  if (!from.ok()) return from.error();
  auto to = locate(source, query.to, "to");
  if (!to.ok()) return to.error();
  plan.from = *from;
  plan.to = *to;
  const terrain::DemHeader& h = source.header();
  const terrain::Window read{
      std::max(0, static_cast<int>(std::floor(std::min(from->col, to->col))) - kReadMargin),
      std::max(0, static_cast<int>(std::floor(std::min(from->row, to->row))) - kReadMargin),
      std::min(h.width, static_cast<int>(std::ceil(std::max(from->col, to->col))) + 1 + kReadMargin),
      std::min(h.height, static_cast<int>(std::ceil(std::max(from->row, to->row))) + 1 + kReadMargin)};
  plan.read = plan_read(source, read);
  add_read_cost(source, plan.read, plan.cost);
  const std::uint64_t crossings = static_cast<std::uint64_t>(read.width() + read.height());
  plan.cost.bytes += crossings * sizeof(ProfileSample);
  plan.cost.seconds = static_cast<double>(crossings) * kLineSecondsPerCrossing;
  return plan;
}

Result<LineRun> run_line(const LinePlan& plan, const terrain::ElevationSource& source, terrain::BlockCache* cache,
                         const RunControl* control) {
  LineRun run;
  auto dem = source.read(plan.read.read, cache, control, &run.read, 1);
  if (!dem.ok()) return dem.error();
  const terrain::Window& got = run.read.window;
  auto from = on_ground(*dem, got, plan.from, plan.query.from, "from");
  if (!from.ok()) return from.error();
  auto to = on_ground(*dem, got, plan.to, plan.query.to, "to");
  if (!to.ok()) return to.error();
  auto los = line_of_sight(*dem, *from, *to, plan.query.options);
  if (!los.ok()) return los.error();
  run.result = std::move(*los);
  // Positions back in the source's grid, x/y from the source's own transform
  // (the window's shifted origin would round differently).
  const terrain::GeoTransform& t = source.header().georef.transform;
  auto back = [&](ProfileSample& s) {
    s.col += got.col0;
    s.row += got.row0;
    s.x = t.x_at(s.col);
    s.y = t.y_at(s.row);
  };
  for (ProfileSample& s : run.result.profile) back(s);
  if (run.result.first_block) back(*run.result.first_block);
  run.from = to_source(*from, got);
  run.to = to_source(*to, got);
  return run;
}

}  // namespace horizon::visibility
