// Occlusion culling of object boxes against the occlusion height field.
// The OHF as the culling surface is the method of US patent 7,027,046
// ("Method, system, and computer program product for visibility culling of
// terrain"); the per-box test reads a hierarchical minimum of it (Greene et
// al., "Hierarchical Z-Buffer Visibility", 1993), see terrain/pyramid.hpp.
#include "horizon/visibility/cull.hpp"

#include <algorithm>
#include <array>
#include <cassert>
#include <cmath>
#include <limits>
#include <optional>
#include <string>
#include <utility>

#include "horizon/geodesy/crs.hpp"

namespace horizon::visibility {
namespace {

constexpr float kMinusInf = -std::numeric_limits<float>::infinity();

std::string box_field(std::size_t i, const char* field) {
  std::string name = "boxes[" + std::to_string(i) + "]";
  if (field && *field) name += std::string(".") + field;
  return name;
}

Status check_finite(std::size_t i, const BoxSpec& b) {
  const std::array<std::pair<const char*, double>, 6> values{{{"x_min", b.x_min},
                                                              {"y_min", b.y_min},
                                                              {"x_max", b.x_max},
                                                              {"y_max", b.y_max},
                                                              {"z_min", b.z_min},
                                                              {"z_max", b.z_max}}};
  for (const auto& [name, v] : values)
    if (!std::isfinite(v))
      return make_error(ErrorCode::kInvalidArgument, box_field(i, name) + ": not a finite number", box_field(i, name));
  if (b.x_max < b.x_min)
    return make_error(ErrorCode::kInvalidArgument, box_field(i, "x_max") + ": less than x_min", box_field(i, "x_max"));
  if (b.y_max < b.y_min)
    return make_error(ErrorCode::kInvalidArgument, box_field(i, "y_max") + ": less than y_min", box_field(i, "y_max"));
  if (b.z_max < b.z_min)
    return make_error(ErrorCode::kInvalidArgument, box_field(i, "z_max") + ": less than z_min", box_field(i, "z_max"));
  return Status::Ok();
}

struct Rect {
  double x_min, y_min, x_max, y_max;
};

// Bounding rectangle in the dataset CRS of a WGS84 rectangle: its corners and
// edge midpoints converted (exact for geographic CRSs; within centimetres for
// object-sized boxes in a projected one).
Result<Rect> to_dataset_crs(const geodesy::Crs& crs, const BoxSpec& b, std::size_t i) {
  const double xm = (b.x_min + b.x_max) / 2, ym = (b.y_min + b.y_max) / 2;
  const std::array<geodesy::LonLat, 8> points{{{b.x_min, b.y_min},
                                               {b.x_max, b.y_min},
                                               {b.x_min, b.y_max},
                                               {b.x_max, b.y_max},
                                               {xm, b.y_min},
                                               {xm, b.y_max},
                                               {b.x_min, ym},
                                               {b.x_max, ym}}};
  std::optional<Rect> r;
  for (const geodesy::LonLat& p : points) {
    auto xy = crs.from_lonlat(p);
    if (!xy.ok())
      return make_error(ErrorCode::kOutOfRange, box_field(i, "") + ": " + xy.error().message, box_field(i, ""));
    if (!r) r = Rect{xy->x, xy->y, xy->x, xy->y};
    r->x_min = std::min(r->x_min, xy->x);
    r->x_max = std::max(r->x_max, xy->x);
    r->y_min = std::min(r->y_min, xy->y);
    r->y_max = std::max(r->y_max, xy->y);
  }
  return *r;
}

BoxFootprint off_the_map() {
  BoxFootprint f;
  f.on_map = false;
  return f;
}

}  // namespace

Result<std::vector<BoxFootprint>> resolve_boxes(const terrain::Dem& dem, std::span<const BoxSpec> boxes,
                                                OffMap off_map) {
  return resolve_boxes(dem.georef, dem.width(), dem.height(), dem.source, boxes, off_map);
}

Result<std::vector<BoxFootprint>> resolve_boxes(const terrain::Georeference& georef, int width, int height,
                                                const std::string& source, std::span<const BoxSpec> boxes,
                                                OffMap off_map) {
  std::optional<geodesy::Crs> crs;
  const auto& t = georef.transform;
  const double w = width, h = height;
  std::vector<BoxFootprint> out;
  out.reserve(boxes.size());
  for (std::size_t i = 0; i < boxes.size(); ++i) {
    const BoxSpec& b = boxes[i];
    HORIZON_RETURN_IF_ERROR(check_finite(i, b));
    Rect r{b.x_min, b.y_min, b.x_max, b.y_max};
    if (b.frame == geodesy::PointFrame::kWgs84) {
      if (!crs) {
        if (!georef.has_crs())
          return make_error(
              ErrorCode::kUnsupported,
              box_field(i, "frame") + ": WGS84 boxes need a dataset with a CRS; '" + source + "' has none",
              box_field(i, "frame"));
        auto c = geodesy::Crs::of(georef);
        if (!c.ok()) return c.error();
        crs = *c;
      }
      for (const auto& [name, lat] : {std::pair{"y_min", b.y_min}, std::pair{"y_max", b.y_max}})
        if (std::abs(lat) > 90.0)
          return make_error(ErrorCode::kInvalidArgument, box_field(i, name) + ": latitude beyond +-90 degrees",
                            box_field(i, name));
      auto converted = to_dataset_crs(*crs, b, i);
      if (!converted.ok()) {
        if (off_map == OffMap::kReject) return converted.error();
        out.push_back(off_the_map());
        continue;
      }
      r = *converted;
    }
    // Continuous grid coordinates of the footprint (rows grow south, so y_max
    // gives the smaller row when pixel_height < 0).
    const double ca = t.col_at(r.x_min), cb = t.col_at(r.x_max);
    const double ra = t.row_at(r.y_min), rb = t.row_at(r.y_max);
    const double c0 = std::min(ca, cb), c1 = std::max(ca, cb);
    const double r0 = std::min(ra, rb), r1 = std::max(ra, rb);
    // Inside the raster's outer extent: grid coordinates [-0.5, size - 0.5].
    if (c0 < -0.5 || r0 < -0.5 || c1 > w - 0.5 || r1 > h - 0.5) {
      if (off_map == OffMap::kReject)
        return make_error(ErrorCode::kOutOfRange,
                          box_field(i, "") + ": footprint lies (partly) outside the dataset '" + source + "'",
                          box_field(i, ""));
      out.push_back(off_the_map());
      continue;
    }
    BoxFootprint f;
    f.cells.col0 = std::max(0, static_cast<int>(std::floor(c0)));
    f.cells.row0 = std::max(0, static_cast<int>(std::floor(r0)));
    f.cells.col1 = std::min(width, static_cast<int>(std::ceil(c1)) + 1);
    f.cells.row1 = std::min(height, static_cast<int>(std::ceil(r1)) + 1);
    f.z_min = b.z_min;
    f.z_max = b.z_max;
    f.col_min = c0;
    f.col_max = c1;
    f.row_min = r0;
    f.row_max = r1;
    out.push_back(f);
  }
  return out;
}

double cull_reach(const ViewFrame& frame, std::span<const BoxFootprint> footprints) {
  // Squared metres, one square root at the end (hypot per corner was 5 % of a
  // 10 000-box call).
  double reach2 = 0.0;
  for (const BoxFootprint& f : footprints)
    if (f.on_map) reach2 = std::max(reach2, frame.farthest_distance2(f.cells));
  return std::sqrt(reach2);
}

std::size_t cull_footprints(const ViewshedResult& result, const terrain::Pyramid& pyramid,
                            std::span<const BoxFootprint> footprints, std::span<BoxVisibility> out,
                            std::uint64_t* cells_read) {
  assert(out.size() == footprints.size());
  const terrain::Window& win = result.frame.window;
  std::uint64_t reads = 0;
  std::size_t visible = 0;
  // The least OHF over a footprint's cells that have one (voids read as
  // +inf), built for the footprints that meet a void.
  std::optional<terrain::Pyramid> known;
  for (std::size_t i = 0; i < footprints.size(); ++i) {
    const BoxFootprint& f = footprints[i];
    if (!f.on_map) {
      out[i] = {Visibility::kOutOfRange, kMinusInf};
      ++visible;
      continue;
    }
    const terrain::Window local{f.cells.col0 - win.col0, f.cells.row0 - win.row0, f.cells.col1 - win.col0,
                                f.cells.row1 - win.row0};
    // Wholly inside the computed window: the pyramid answers. Otherwise part
    // of the footprint has no answer, which never hides it.
    const bool inside = local.col0 >= 0 && local.row0 >= 0 && local.col1 <= pyramid.width() &&
                        local.row1 <= pyramid.height() && !local.empty();
    float ohf_min = inside ? pyramid.min_in(local, &reads) : kMinusInf;
    // In this form (not z_max >= ohf_min - tol) so that cull_batch's float
    // threshold gives the same answer bit for bit (cull_index.hpp).
    const double threshold = f.z_max + kTieTolerance;
    Visibility state = static_cast<double>(ohf_min) <= threshold ? Visibility::kSeen : Visibility::kOccluded;
    if (inside && ohf_min == kMinusInf) {
      // A void (or the eye's own cell, which is -inf there too): decide on the cells that have an OHF.
      if (!known)
        known.emplace(terrain::HeightView(result.ohf).with_void_fill(std::numeric_limits<float>::infinity()),
                      terrain::Reduction::kMin);
      const float least = known->min_in(local, &reads);
      const bool voids = least != kMinusInf;  // -inf there is a real OHF value: no void is needed to explain it
      state = !voids || static_cast<double>(least) <= threshold ? Visibility::kSeen : Visibility::kUndetermined;
      ohf_min = voids && least != std::numeric_limits<float>::infinity() ? least : kMinusInf;
    }
    out[i] = {state, ohf_min};
    visible += may_be_seen(state);
  }
  if (cells_read) *cells_read += reads;
  return visible;
}

Result<CullPlan> plan_cull(const terrain::Dem& dem, const geodesy::GridPoint& observer, std::span<const BoxSpec> boxes,
                           const CullOptions& options) {
  if (boxes.empty()) return make_error(ErrorCode::kInvalidArgument, "boxes: at least one box is needed", "boxes");
  auto footprints = resolve_boxes(dem, boxes, OffMap::kAnswer);
  if (!footprints.ok()) return footprints.error();

  CullPlan plan;
  plan.footprints = std::move(*footprints);
  plan.any_on_map =
      std::any_of(plan.footprints.begin(), plan.footprints.end(), [](const BoxFootprint& f) { return f.on_map; });
  ViewshedOptions& vs = plan.viewshed;
  vs = options.viewshed;
  vs.target_height = 0.0;
  vs.max_distance = std::numeric_limits<double>::infinity();
  if (options.conservative) vs.algorithm = Algorithm::kConservative;
  // The frame over the whole DEM gives the metric cell sizes at the eye; the
  // reach of the boxes then bounds the window actually computed.
  auto whole = make_view_frame(dem, observer, vs);
  if (!whole.ok()) return whole.error();
  const double reach = cull_reach(*whole, plan.footprints);
  // A hair beyond the farthest centre so that rounding never drops it, and
  // never zero (a box on the eye's own cell).
  vs.max_distance = std::max(reach * (1.0 + 1e-9) + 1e-6, std::min(whole->metres_per_col, whole->metres_per_row));
  auto frame = make_view_frame(dem, observer, vs);
  if (!frame.ok()) return frame.error();
  plan.frame = *frame;
  return plan;
}

Result<CullResult> run_cull(const terrain::Dem& dem, const geodesy::GridPoint& observer, const CullPlan& plan,
                            const RunControl* control, gpu::ContextPool* gpu, const BackendPolicy* policy,
                            ResultStorage storage) {
  CullResult result;
  result.algorithm = plan.viewshed.algorithm;
  if (!plan.any_on_map) {
    // Nothing to compute: every box is off the map.
    result.boxes.assign(plan.footprints.size(), {Visibility::kOutOfRange, kMinusInf});
    result.visible_count = result.out_of_range_count = plan.footprints.size();
    return result;
  }
  auto ohf = compute_viewshed(dem, observer, plan.viewshed, control, gpu, policy, storage);
  if (!ohf.ok()) return ohf.error();

  result.window = ohf->frame.window;
  result.stats = ohf->stats;
  // 2x2 levels; the blocks are built as the boxes' queries reach them.
  const terrain::Pyramid pyramid(ohf->ohf, terrain::Reduction::kMin);
  result.boxes.resize(plan.footprints.size());
  result.visible_count = cull_footprints(*ohf, pyramid, plan.footprints, result.boxes, &result.pyramid_cells_read);
  result.out_of_range_count = static_cast<std::size_t>(
      std::count_if(plan.footprints.begin(), plan.footprints.end(), [](const BoxFootprint& f) { return !f.on_map; }));
  if (storage.ohf) *storage.ohf = std::move(ohf->ohf);
  if (storage.terrain) *storage.terrain = std::move(ohf->terrain);
  return result;
}

Result<CullResult> cull_boxes(const terrain::Dem& dem, const geodesy::GridPoint& observer,
                              std::span<const BoxSpec> boxes, const CullOptions& options, const RunControl* control,
                              gpu::ContextPool* gpu, const BackendPolicy* policy) {
  auto plan = plan_cull(dem, observer, boxes, options);
  if (!plan.ok()) return plan.error();
  return run_cull(dem, observer, *plan, control, gpu, policy);
}

}  // namespace horizon::visibility
