#include "horizon/region/region.hpp"

#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <cmath>
#include <limits>
#include <string>

#include "horizon/common/parallel.hpp"
#include "horizon/geodesy/crs.hpp"
#include "horizon/visibility/view_frame.hpp"
#include "region/fuzzy_faces.hpp"
#include "region/hull_clearance.hpp"

namespace horizon::region {
namespace {

constexpr std::uint8_t kNoFace = 255;

Error bad_option(const char* field, const std::string& what) {
  return make_error(ErrorCode::kInvalidArgument, std::string(field) + ": " + what, field);
}

// An error about boxes[0] from resolve_boxes, reworded for the region.
Error as_region_error(Error e) {
  const std::string from = "boxes[0]";
  for (std::string* s : {&e.message, &e.field}) {
    const auto at = s->find(from);
    if (at != std::string::npos) s->replace(at, from.size(), "region");
  }
  return e;
}

terrain::HeightView terrain_view(const terrain::Dem& dem, const RegionOptions& o) {
  const terrain::HeightView view(dem.elevation);
  return o.nodata == visibility::NodataPolicy::kFill ? view.with_void_fill(static_cast<float>(o.nodata_fill_height))
                                                     : view;
}

// The nodes bounding the region's footprint and `cells`, clipped to the DEM.
terrain::Window node_window(const RegionFrame& f, const terrain::Window& cells, int width, int height) {
  terrain::Window w;
  w.col0 = std::max(0, std::min(cells.col0, static_cast<int>(std::floor(f.col_min))));
  w.row0 = std::max(0, std::min(cells.row0, static_cast<int>(std::floor(f.row_min))));
  w.col1 = std::min(width, std::max(cells.col1, static_cast<int>(std::ceil(f.col_max)) + 1));
  w.row1 = std::min(height, std::max(cells.row1, static_cast<int>(std::ceil(f.row_max)) + 1));
  return w;
}

std::array<FaceGeometry, kFaceCount> face_geometries(const RegionFrame& f, const terrain::Dem& dem, int resolution) {
  return {FaceGeometry(Face::kEast, f, dem.width(), dem.height(), resolution),
          FaceGeometry(Face::kWest, f, dem.width(), dem.height(), resolution),
          FaceGeometry(Face::kSouth, f, dem.width(), dem.height(), resolution),
          FaceGeometry(Face::kNorth, f, dem.width(), dem.height(), resolution)};
}

// The face on which the item's directions from the region sit most
// squarely, and its fit there (`*best_fit`, when given).
std::uint8_t best_face(const std::array<FaceGeometry, kFaceCount>& faces, const FaceItem& item,
                       FaceFit* best_fit = nullptr) {
  std::uint8_t best = kNoFace;
  double spread = std::numeric_limits<double>::infinity();
  for (std::uint8_t k = 0; k < kFaceCount; ++k) {
    FaceFit fit;
    if (faces[k].fit(item, fit) && fit.spread < spread) {
      spread = fit.spread;
      best = k;
      if (best_fit) *best_fit = fit;
    }
  }
  return best;
}

std::uint64_t sweep_bound(const terrain::Dem& dem, int resolution) {
  const std::uint64_t w = static_cast<std::uint64_t>(dem.width()), h = static_cast<std::uint64_t>(dem.height());
  return 2 * (w * (h + resolution) + h * (w + resolution));
}

std::uint64_t pieces_of(const RegionOptions& o) {
  return static_cast<std::uint64_t>(o.footprint_splits) * o.footprint_splits;
}

void count(Verdict v, RegionStats& s) {
  ++s.items;
  if (v == Verdict::kAlwaysHidden) ++s.always_hidden;
  if (v == Verdict::kAlwaysVisible) ++s.always_visible;
  if (v == Verdict::kUndetermined) ++s.undetermined;
}

// The four wall sweeps, one per face, in parallel; each marks its items.
Status sweep_faces(const std::array<FaceGeometry, kFaceCount>& faces, const terrain::HeightView& terrain,
                   const std::array<int, kFaceCount>& wall_end, unsigned threads, const RunControl* control,
                   const std::function<void(int, int, const std::vector<double>&)>& test, RegionStats& stats) {
  std::array<Status, kFaceCount> status{};
  std::array<RegionStats, kFaceCount> face_stats{};
  parallel_for(kFaceCount, std::min(threads, 4u), [&](std::size_t k) {
    status[k] = sweep_face(
        faces[k], terrain, wall_end[k], control,
        [&](int w, const std::vector<double>& cover) { test(static_cast<int>(k), w, cover); }, face_stats[k]);
  });
  for (std::size_t k = 0; k < kFaceCount; ++k) {
    HORIZON_RETURN_IF_ERROR(status[k]);
    stats.walls_swept += face_stats[k].walls_swept;
    stats.wall_nodes_read += face_stats[k].wall_nodes_read;
  }
  return Status::Ok();
}

double seconds_since(std::chrono::steady_clock::time_point t) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t).count();
}

}  // namespace

RegionSpec swept_region(double x0, double y0, double x1, double y1, double half_x, double half_y, double z_min,
                        double z_max, geodesy::HeightMode height_mode) {
  RegionSpec r;
  r.x_min = std::min(x0, x1) - half_x;
  r.x_max = std::max(x0, x1) + half_x;
  r.y_min = std::min(y0, y1) - half_y;
  r.y_max = std::max(y0, y1) + half_y;
  r.z_min = z_min;
  r.z_max = z_max;
  r.height_mode = height_mode;
  return r;
}

std::string_view verdict_name(Verdict v) {
  switch (v) {
    case Verdict::kAlwaysHidden:
      return "always_hidden";
    case Verdict::kAlwaysVisible:
      return "always_visible";
    case Verdict::kUndetermined:
      return "undetermined";
  }
  return "?";
}

Status validate_region_options(const RegionOptions& o) {
  if (o.face_resolution < 8 || o.face_resolution > 65536)
    return bad_option("face_resolution", "must be an integer in [8, 65536], got " + std::to_string(o.face_resolution));
  // The fields a viewshed has too, under the viewshed's own rules and words.
  visibility::ViewshedOptions shared;
  shared.curvature_coefficient = o.curvature_coefficient;
  shared.nodata = o.nodata;
  shared.nodata_fill_height = o.nodata_fill_height;
  shared.target_height = o.target_height;
  shared.max_distance = o.max_distance;
  HORIZON_RETURN_IF_ERROR(visibility::validate_options(shared));
  if (o.footprint_splits < 1 || o.footprint_splits > 16)
    return bad_option("footprint_splits", "must be an integer in [1, 16], got " + std::to_string(o.footprint_splits));
  if (o.fuzzy_rows != 0 && (o.fuzzy_rows < 2 || o.fuzzy_rows > 65536))
    return bad_option("fuzzy_rows",
                      "must be 0 (continuous) or an integer in [2, 65536], got " + std::to_string(o.fuzzy_rows));
  if (o.visible_test_budget < 16 || o.visible_test_budget > (1 << 24))
    return bad_option("visible_test_budget",
                      "must be an integer in [16, 16777216], got " + std::to_string(o.visible_test_budget));
  return Status::Ok();
}

Result<RegionFrame> resolve_region(const terrain::Dem& dem, const RegionSpec& region, const RegionOptions& options) {
  HORIZON_RETURN_IF_ERROR(validate_region_options(options));
  if (dem.width() < 2 || dem.height() < 2)
    return make_error(ErrorCode::kUnsupported, "region visibility needs a DEM of at least 2 x 2 cells; '" + dem.source +
                                                   "' has " + std::to_string(dem.width()) + " x " +
                                                   std::to_string(dem.height()));
  visibility::BoxSpec box;
  box.frame = region.frame;
  box.x_min = region.x_min;
  box.y_min = region.y_min;
  box.x_max = region.x_max;
  box.y_max = region.y_max;
  box.z_min = region.z_min;
  box.z_max = region.z_max;
  auto footprint = visibility::resolve_boxes(dem, std::span<const visibility::BoxSpec>(&box, 1));
  if (!footprint.ok()) return as_region_error(footprint.error());
  const visibility::BoxFootprint& fp = (*footprint)[0];

  RegionFrame f;
  f.col_min = fp.col_min;
  f.col_max = fp.col_max;
  f.row_min = fp.row_min;
  f.row_max = fp.row_max;
  f.z_min = region.z_min;
  f.z_max = region.z_max;
  if (region.height_mode == geodesy::HeightMode::kAboveGround) {
    // The bilinear ground under the footprint lies between its nodes' extremes.
    const terrain::HeightView view = terrain_view(dem, options);
    float lo = std::numeric_limits<float>::infinity(), hi = -lo;
    for (int r = fp.cells.row0; r < fp.cells.row1; ++r)
      for (int c = fp.cells.col0; c < fp.cells.col1; ++c) {
        const float z = view.at(c, r);
        if (z == z) {
          lo = std::min(lo, z);
          hi = std::max(hi, z);
        }
      }
    if (!(lo <= hi))
      return make_error(ErrorCode::kDataError,
                        "region: heights are above ground but the ground under it in '" + dem.source +
                            "' is all void; give absolute heights",
                        "region");
    f.z_min = lo + region.z_min;
    f.z_max = hi + region.z_max;
  }
  const auto& t = dem.georef.transform;
  auto size = visibility::metric_cell_size(dem.georef, t.x_at(0.5 * (f.col_min + f.col_max)),
                                           t.y_at(0.5 * (f.row_min + f.row_max)), dem.source);
  if (!size.ok()) return size.error();
  f.metres_per_col = size->per_col;
  f.metres_per_row = size->per_row;
  f.curvature = options.curvature_coefficient / (2.0 * geodesy::kEarthRadiusMetres);
  return f;
}

Result<RegionPlan> plan_region_cells(const terrain::Dem& dem, const RegionSpec& region, const RegionOptions& options) {
  auto frame = resolve_region(dem, region, options);
  if (!frame.ok()) return frame.error();
  RegionPlan plan;
  plan.frame = *frame;
  const RegionFrame& f = plan.frame;
  terrain::Window w{0, 0, dem.width(), dem.height()};
  if (std::isfinite(options.max_distance)) {
    const double gc = options.max_distance / f.metres_per_col, gr = options.max_distance / f.metres_per_row;
    const auto clip = [](double v, int hi) { return static_cast<int>(std::clamp(v, 0.0, static_cast<double>(hi))); };
    w.col0 = clip(std::ceil(f.col_min - gc), dem.width());
    w.row0 = clip(std::ceil(f.row_min - gr), dem.height());
    w.col1 = clip(std::floor(f.col_max + gc) + 1, dem.width());
    w.row1 = clip(std::floor(f.row_max + gr) + 1, dem.height());
  }
  plan.window = w;
  const std::uint64_t n = pieces_of(options);
  plan.sweep_work = n * sweep_bound(dem, options.face_resolution);
  plan.test_work =
      n * static_cast<std::uint64_t>(w.cell_count()) * static_cast<std::uint64_t>(options.visible_test_budget);
  return plan;
}

// Boxes test at most this many covered centres each for "always visible".
constexpr int kBoxCandidates = 5;

Result<RegionPlan> plan_region_boxes(const terrain::Dem& dem, const RegionSpec& region,
                                     std::span<const visibility::BoxSpec> boxes, const RegionOptions& options) {
  auto frame = resolve_region(dem, region, options);
  if (!frame.ok()) return frame.error();
  if (boxes.empty()) return make_error(ErrorCode::kInvalidArgument, "boxes: none given", "boxes");
  RegionPlan plan;
  plan.frame = *frame;
  const std::uint64_t n = pieces_of(options);
  plan.sweep_work = n * sweep_bound(dem, options.face_resolution);
  plan.test_work = n * boxes.size() * kBoxCandidates * static_cast<std::uint64_t>(options.visible_test_budget);
  return plan;
}

namespace {

// The cells of `win` from one sub-box `f` of the region. `open` (may be
// null): the verdicts of the sub-boxes done so far; a cell already
// undetermined is not worked on again.
Result<RegionCellsResult> classify_cells_from(const terrain::Dem& dem, const RegionFrame& f, const terrain::Window& win,
                                              const RegionFrame& whole, const HullClearance& hull,
                                              const RegionOptions& options, const terrain::Grid<std::uint8_t>* open,
                                              const RunControl* control) {
  const terrain::HeightView terrain = terrain_view(dem, options);
  const unsigned threads = resolve_thread_count(options.threads);
  const double th = options.target_height;
  const double mx = f.metres_per_col, my = f.metres_per_row;

  RegionCellsResult out;
  out.frame = f;
  out.window = win;
  out.codes = terrain::Grid<std::uint8_t>(win.width(), win.height(), static_cast<std::uint8_t>(Verdict::kUndetermined));
  terrain::Grid<std::uint8_t> face_of(win.width(), win.height(), kNoFace);
  const auto faces = face_geometries(f, dem, options.face_resolution);
  const auto target = [&](int c, int r) {
    const double z = terrain.at(c, r);
    return FaceItem{double(c), double(c), double(r), double(r), z + th};
  };

  // Which cells are answered, and on which face each is tested for "hidden".
  HORIZON_RETURN_IF_ERROR(parallel_for(
      static_cast<std::size_t>(win.height()), threads, control,
      [&](std::size_t jj) {
        const int r = win.row0 + static_cast<int>(jj);
        std::uint8_t* code = out.codes.row(static_cast<int>(jj));
        std::uint8_t* face = face_of.row(static_cast<int>(jj));
        for (int c = win.col0; c < win.col1; ++c) {
          const int i = c - win.col0;
          const double dx = std::max({whole.col_min - c, 0.0, c - whole.col_max}) * mx;
          const double dy = std::max({whole.row_min - r, 0.0, r - whole.row_max}) * my;
          const FaceItem item = target(c, r);
          if (!(item.z == item.z) || std::hypot(dx, dy) > options.max_distance) {
            code[i] = kNoAnswer;
            continue;
          }
          if (open && open->row(static_cast<int>(jj))[i] == static_cast<std::uint8_t>(Verdict::kUndetermined)) continue;
          face[i] = best_face(faces, item);
        }
      },
      0.0, 0.05));

  std::array<int, kFaceCount> wall_end{};
  for (std::size_t k = 0; k < kFaceCount; ++k) {
    const FaceGeometry& g = faces[k];
    wall_end[k] = std::max(g.wall_of(win.col0, win.row0), g.wall_of(win.col1 - 1, win.row1 - 1)) + 1;
  }
  HORIZON_RETURN_IF_ERROR(sweep_faces(
      faces, terrain, wall_end, threads, control,
      [&](int k, int w, const std::vector<double>& cover) {
        const FaceGeometry& g = faces[static_cast<std::size_t>(k)];
        if (w >= g.wall_count()) return;
        // The window's cells on wall w.
        const bool cols = k < 2;
        const int line = cols ? g.node_col(w, 0) : g.node_row(w, 0);
        const int lo = cols ? win.row0 : win.col0, hi = cols ? win.row1 : win.col1;
        if (cols ? (line < win.col0 || line >= win.col1) : (line < win.row0 || line >= win.row1)) return;
        for (int v = lo; v < hi; ++v) {
          const int c = cols ? line : v, r = cols ? v : line;
          const int i = c - win.col0, j = r - win.row0;
          if (face_of.row(j)[i] != k) continue;
          FaceFit fit;
          if (g.fit(target(c, r), fit) && fit.wall_limit == w && covered(fit, cover, options.fuzzy_rows))
            out.codes.row(j)[i] = static_cast<std::uint8_t>(Verdict::kAlwaysHidden);
        }
      },
      out.stats));
  report_progress(control, 0.3);

  std::atomic<std::uint64_t> reads{0};
  HORIZON_RETURN_IF_ERROR(parallel_for(
      static_cast<std::size_t>(win.height()), threads, control,
      [&](std::size_t jj) {
        const int r = win.row0 + static_cast<int>(jj);
        std::uint8_t* code = out.codes.row(static_cast<int>(jj));
        std::uint64_t n = 0;
        for (int c = win.col0; c < win.col1; ++c) {
          std::uint8_t& v = code[c - win.col0];
          if (v != static_cast<std::uint8_t>(Verdict::kUndetermined)) continue;
          // Only a cell every sub-box so far sees can still be always visible.
          if (open &&
              open->row(static_cast<int>(jj))[c - win.col0] != static_cast<std::uint8_t>(Verdict::kAlwaysVisible))
            continue;
          if (hull.clear(f, c, r, terrain.at(c, r) + th, options.visible_test_budget, &n))
            v = static_cast<std::uint8_t>(Verdict::kAlwaysVisible);
        }
        reads.fetch_add(n, std::memory_order_relaxed);
      },
      0.3, 1.0));
  out.stats.pyramid_cells_read = reads.load();
  return out;
}

// The footprint cut into splits x splits rectangles: every viewpoint of the
// region lies in one of them,
// so an item hidden (visible) from each is hidden (visible) from the region.
// Heights above ground then resolve against each piece's own ground, far
// tighter than the whole footprint's on steep terrain.
std::vector<RegionSpec> pieces(const RegionSpec& r, const RegionOptions& o) {
  std::vector<RegionSpec> out;
  const int n = o.footprint_splits;
  const auto cut = [](double lo, double hi, int k, int i) { return lo + (hi - lo) * i / k; };
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      RegionSpec p = r;
      p.x_min = cut(r.x_min, r.x_max, n, i);
      p.x_max = i + 1 == n ? r.x_max : cut(r.x_min, r.x_max, n, i + 1);
      p.y_min = cut(r.y_min, r.y_max, n, j);
      p.y_max = j + 1 == n ? r.y_max : cut(r.y_min, r.y_max, n, j + 1);
      out.push_back(p);
    }
  return out;
}

// A verdict for the union of two sets of viewpoints.
std::uint8_t merge(std::uint8_t a, std::uint8_t b) {
  if (a == kNoAnswer || b == kNoAnswer) return kNoAnswer;
  return a == b ? a : static_cast<std::uint8_t>(Verdict::kUndetermined);
}

void add_work(const RegionStats& from, RegionStats& to) {
  to.walls_swept += from.walls_swept;
  to.wall_nodes_read += from.wall_nodes_read;
  to.pyramid_cells_read += from.pyramid_cells_read;
}

// One piece resolved; a piece whose ground is all void (heights above
// ground) takes the whole region's heights.
Result<RegionFrame> resolve_piece(const terrain::Dem& dem, const RegionSpec& piece, const RegionOptions& options,
                                  const RegionFrame& whole) {
  auto f = resolve_region(dem, piece, options);
  if (f.ok() || f.error().code != ErrorCode::kDataError) return f;
  RegionSpec absolute = piece;
  absolute.height_mode = geodesy::HeightMode::kAbsolute;
  absolute.z_min = whole.z_min;
  absolute.z_max = whole.z_max;
  return resolve_region(dem, absolute, options);
}

}  // namespace

Result<RegionCellsResult> classify_cells(const terrain::Dem& dem, const RegionSpec& region,
                                         const RegionOptions& options, const RunControl* control) {
  const auto started = std::chrono::steady_clock::now();
  auto plan = plan_region_cells(dem, region, options);
  if (!plan.ok()) return plan.error();
  RegionCellsResult out;
  out.frame = plan->frame;
  out.window = plan->window;
  const HullClearance hull(terrain_view(dem, options),
                           node_window(plan->frame, plan->window, dem.width(), dem.height()),
                           resolve_thread_count(options.threads));
  bool first = true;
  for (const RegionSpec& piece : pieces(region, options)) {
    auto f = resolve_piece(dem, piece, options, plan->frame);
    if (!f.ok()) return f.error();
    auto part =
        classify_cells_from(dem, *f, plan->window, plan->frame, hull, options, first ? nullptr : &out.codes, control);
    if (!part.ok()) return part.error();
    add_work(part->stats, out.stats);
    if (first) {
      out.codes = std::move(part->codes);
      first = false;
      continue;
    }
    for (int j = 0; j < out.codes.height(); ++j) {
      std::uint8_t* a = out.codes.row(j);
      const std::uint8_t* b = part->codes.row(j);
      for (int i = 0; i < out.codes.width(); ++i) a[i] = merge(a[i], b[i]);
    }
  }
  for (int j = 0; j < out.codes.height(); ++j)
    for (int i = 0; i < out.codes.width(); ++i)
      if (out.codes.row(j)[i] != kNoAnswer) count(static_cast<Verdict>(out.codes.row(j)[i]), out.stats);
  out.stats.seconds = seconds_since(started);
  return out;
}

namespace {

// The boxes from one sub-box `f` of the region; `open` (may be null) as
// classify_cells_from takes it.
Result<RegionBoxesResult> classify_boxes_from(const terrain::Dem& dem, const RegionFrame& f,
                                              const std::vector<visibility::BoxFootprint>* footprints,
                                              const HullClearance& hull, const RegionOptions& options,
                                              const std::vector<Verdict>* open, const RunControl* control) {
  const std::size_t box_count = footprints->size();
  const terrain::HeightView terrain = terrain_view(dem, options);
  const unsigned threads = resolve_thread_count(options.threads);
  const auto faces = face_geometries(f, dem, options.face_resolution);

  RegionBoxesResult out;
  out.frame = f;
  out.verdicts.assign(box_count, Verdict::kUndetermined);
  // Each box's top over the centres it covers; bucketed by face and wall limit.
  std::vector<FaceItem> items(box_count);
  std::array<std::vector<std::vector<std::size_t>>, kFaceCount> buckets;
  std::array<int, kFaceCount> wall_end{};
  for (std::size_t b = 0; b < box_count; ++b) {
    const terrain::Window& cells = (*footprints)[b].cells;
    items[b] = {double(cells.col0), double(cells.col1 - 1), double(cells.row0), double(cells.row1 - 1),
                (*footprints)[b].z_max};
    if (open && (*open)[b] == Verdict::kUndetermined) continue;
    FaceFit fit;
    const std::uint8_t k = best_face(faces, items[b], &fit);
    if (k == kNoFace) continue;
    auto& bucket = buckets[k];
    if (bucket.size() <= static_cast<std::size_t>(fit.wall_limit)) bucket.resize(fit.wall_limit + 1);
    bucket[static_cast<std::size_t>(fit.wall_limit)].push_back(b);
    wall_end[k] = std::max(wall_end[k], fit.wall_limit);
  }
  HORIZON_RETURN_IF_ERROR(sweep_faces(
      faces, terrain, wall_end, threads, control,
      [&](int k, int w, const std::vector<double>& cover) {
        const auto& bucket = buckets[static_cast<std::size_t>(k)];
        if (static_cast<std::size_t>(w) >= bucket.size()) return;
        for (std::size_t b : bucket[static_cast<std::size_t>(w)]) {
          FaceFit fit;
          if (faces[static_cast<std::size_t>(k)].fit(items[b], fit) && covered(fit, cover, options.fuzzy_rows))
            out.verdicts[b] = Verdict::kAlwaysHidden;
        }
      },
      out.stats));

  // Always visible: one covered centre (not a void) seen from all of the region.
  std::atomic<std::uint64_t> reads{0};
  HORIZON_RETURN_IF_ERROR(parallel_for(box_count, threads, control, [&](std::size_t b) {
    if (out.verdicts[b] != Verdict::kUndetermined) return;
    if (open && (*open)[b] != Verdict::kAlwaysVisible) return;
    const terrain::Window& cells = (*footprints)[b].cells;
    const double z = (*footprints)[b].z_max;
    const double mc = 0.5 * ((*footprints)[b].col_min + (*footprints)[b].col_max);
    const double mr = 0.5 * ((*footprints)[b].row_min + (*footprints)[b].row_max);
    const std::array<std::pair<int, int>, kBoxCandidates> candidates{{
        {std::clamp(static_cast<int>(std::lround(mc)), cells.col0, cells.col1 - 1),
         std::clamp(static_cast<int>(std::lround(mr)), cells.row0, cells.row1 - 1)},
        {cells.col0, cells.row0},
        {cells.col1 - 1, cells.row0},
        {cells.col0, cells.row1 - 1},
        {cells.col1 - 1, cells.row1 - 1},
    }};
    std::uint64_t n = 0;
    for (std::size_t k = 0; k < candidates.size(); ++k) {
      const auto [c, r] = candidates[k];
      if (k > 0 && candidates[k] == candidates[0]) continue;
      const float ground = terrain.at(c, r);
      if (!(ground == ground)) continue;  // no target on a void
      if (hull.clear(f, c, r, z, options.visible_test_budget, &n)) {
        out.verdicts[b] = Verdict::kAlwaysVisible;
        break;
      }
    }
    reads.fetch_add(n, std::memory_order_relaxed);
  }));
  out.stats.pyramid_cells_read = reads.load();
  return out;
}

}  // namespace

Result<RegionBoxesResult> classify_boxes(const terrain::Dem& dem, const RegionSpec& region,
                                         std::span<const visibility::BoxSpec> boxes, const RegionOptions& options,
                                         const RunControl* control) {
  const auto started = std::chrono::steady_clock::now();
  auto plan = plan_region_boxes(dem, region, boxes, options);
  if (!plan.ok()) return plan.error();
  auto footprints = visibility::resolve_boxes(dem, boxes);
  if (!footprints.ok()) return footprints.error();
  RegionBoxesResult out;
  out.frame = plan->frame;
  // One clearance over the nodes every box and the region stand on.
  terrain::Window all = (*footprints)[0].cells;
  for (const visibility::BoxFootprint& fp : *footprints)
    all = {std::min(all.col0, fp.cells.col0), std::min(all.row0, fp.cells.row0), std::max(all.col1, fp.cells.col1),
           std::max(all.row1, fp.cells.row1)};
  const HullClearance hull(terrain_view(dem, options), node_window(plan->frame, all, dem.width(), dem.height()),
                           resolve_thread_count(options.threads));
  bool first = true;
  for (const RegionSpec& piece : pieces(region, options)) {
    auto f = resolve_piece(dem, piece, options, plan->frame);
    if (!f.ok()) return f.error();
    auto part = classify_boxes_from(dem, *f, &*footprints, hull, options, first ? nullptr : &out.verdicts, control);
    if (!part.ok()) return part.error();
    add_work(part->stats, out.stats);
    if (first) {
      out.verdicts = std::move(part->verdicts);
      first = false;
      continue;
    }
    for (std::size_t b = 0; b < out.verdicts.size(); ++b)
      if (out.verdicts[b] != part->verdicts[b]) out.verdicts[b] = Verdict::kUndetermined;
  }
  for (Verdict v : out.verdicts) count(v, out.stats);
  out.stats.seconds = seconds_since(started);
  return out;
}

}  // namespace horizon::region
