#include "region/fuzzy_faces.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace horizon::region {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
// Grid-unit slack applied outward wherever a floor, ceil or strict
// comparison decides which nodes or walls count: a rounding can then only
// widen an interval or drop a wall, never the reverse.
constexpr double kGridSlack = 1e-7;
// Metres by which a cover must clear an item, as seen at the item: R3's OHF
// is stored as float32 (half an ulp is 0.24 mm at 4 000 m), and a verdict
// must hold for the stored answer too.
constexpr double kHeightSlack = 5e-4;

bool along_columns(Face f) {
  return f == Face::kEast || f == Face::kWest;
}

}  // namespace

FaceGeometry::FaceGeometry(Face face, const RegionFrame& frame, int dem_width, int dem_height, int resolution)
    : face_(face), resolution_(resolution), dem_w_(dem_width), dem_h_(dem_height) {
  const bool cols = along_columns(face);
  walls_ = cols ? dem_width : dem_height;
  lateral_ = cols ? dem_height : dem_width;
  axial_m_ = cols ? frame.metres_per_col : frame.metres_per_row;
  lateral_m_ = cols ? frame.metres_per_row : frame.metres_per_col;
  const double ua = u_of(frame.col_min, frame.row_min), ub = u_of(frame.col_max, frame.row_max);
  u0_ = std::min(ua, ub);
  u1_ = std::max(ua, ub);
  v0_ = v_of(frame.col_min, frame.row_min);
  v1_ = v_of(frame.col_max, frame.row_max);
  z0_ = frame.z_min;
  z1_ = frame.z_max;
  column_width_ = 2.0 * kFaceSpan / resolution;
  first_wall_ = static_cast<int>(std::floor(u1_ + kGridSlack)) + 1;
}

double FaceGeometry::u_of(double col, double row) const {
  switch (face_) {
    case Face::kEast:
      return col;
    case Face::kWest:
      return (dem_w_ - 1) - col;
    case Face::kSouth:
      return row;
    case Face::kNorth:
      return (dem_h_ - 1) - row;
  }
  return col;
}

double FaceGeometry::v_of(double col, double row) const {
  return along_columns(face_) ? row : col;
}

int FaceGeometry::node_col(int w, int v) const {
  switch (face_) {
    case Face::kEast:
      return w;
    case Face::kWest:
      return dem_w_ - 1 - w;
    default:
      return v;
  }
}

int FaceGeometry::node_row(int w, int v) const {
  switch (face_) {
    case Face::kSouth:
      return w;
    case Face::kNorth:
      return dem_h_ - 1 - w;
    default:
      return v;
  }
}

int FaceGeometry::wall_of(int col, int row) const {
  return static_cast<int>(u_of(col, row));
}

bool FaceGeometry::fit(const FaceItem& item, FaceFit& out) const {
  const double ua = u_of(item.col_min, item.row_min), ub = u_of(item.col_max, item.row_max);
  const double uq0 = std::min(ua, ub), uq1 = std::max(ua, ub);
  const double vq0 = v_of(item.col_min, item.row_min), vq1 = v_of(item.col_max, item.row_max);
  if (uq0 - u1_ <= kGridSlack) return false;  // not wholly beyond the region along this axis
  const double dp_min = (uq0 - u1_) * axial_m_, dp_max = (uq1 - u0_) * axial_m_;
  const double dl_lo = (vq0 - v1_) * lateral_m_, dl_hi = (vq1 - v0_) * lateral_m_;
  // a = dl / dp over the box of differences: extremes at its corners.
  const double a_lo = std::min(dl_lo / dp_min, dl_lo / dp_max);
  const double a_hi = std::max(dl_hi / dp_min, dl_hi / dp_max);
  if (!(a_lo >= -kFaceSpan && a_hi <= kFaceSpan)) return false;
  const double c_lo = std::floor((a_lo + kFaceSpan) / column_width_ - 1e-9);
  const double c_hi = std::floor((a_hi + kFaceSpan) / column_width_ + 1e-9);
  out.column_lo = static_cast<int>(std::clamp(c_lo, 0.0, resolution_ - 1.0));
  out.column_hi = static_cast<int>(std::clamp(c_hi, 0.0, resolution_ - 1.0));
  // A viewpoint lower than another by h sees along lines lower all the way
  // to the item, so the region's top face is the one to hide from: slopes
  // are taken from z_max on both sides, and only the horizontal extents are
  // bounded apart.
  const double dz = item.z - z1_;
  out.slope_max = dz >= 0.0 ? dz / dp_min : dz / dp_max;
  const double limit = std::ceil(uq0 - kGridSlack);
  out.wall_limit = static_cast<int>(std::clamp(limit, 0.0, static_cast<double>(walls_)));
  out.spread = std::max(std::abs(a_lo), std::abs(a_hi));
  // A slope gap g under every ray holds the item g * (its distance) below the OHF.
  out.slope_slack = kHeightSlack / dp_min;
  return true;
}

std::uint64_t FaceGeometry::add_wall(int w, const std::vector<float>& nodes, std::vector<int>& deque,
                                     std::vector<double>& cover) const {
  const double dp_min = (w - u1_) * axial_m_, dp_max = (w - u0_) * axial_m_;
  // Sliding minimum over the wall's nodes: both ends of the lateral interval
  // grow with the column (floating-point +, *, / and floor are monotone), so
  // a deque of candidate indices gives each column's minimum in O(1) amortised.
  int head = 0, tail = 0;  // deque[head, tail)
  int pushed = 0;          // nodes 0 .. pushed - 1 have entered
  for (int c = 0; c < resolution_; ++c) {
    const double a0 = -kFaceSpan + c * column_width_, a1 = -kFaceSpan + (c + 1) * column_width_;
    const double lo = v0_ + std::min(a0 * dp_min, a0 * dp_max) / lateral_m_;
    const double hi = v1_ + std::max(a1 * dp_min, a1 * dp_max) / lateral_m_;
    const double jlo_d = std::floor(lo - kGridSlack), jhi_d = std::ceil(hi + kGridSlack);
    if (jlo_d < 0.0) continue;          // some rays pass west/north of the DEM here
    if (jhi_d > lateral_ - 1.0) break;  // and from here on, east/south of it
    const int jlo = static_cast<int>(jlo_d), jhi = static_cast<int>(jhi_d);
    for (; pushed <= jhi; ++pushed) {
      const float z = nodes[static_cast<std::size_t>(pushed)];
      while (tail > head && nodes[static_cast<std::size_t>(deque[static_cast<std::size_t>(tail - 1)])] >= z) --tail;
      deque[static_cast<std::size_t>(tail++)] = pushed;
    }
    while (deque[static_cast<std::size_t>(head)] < jlo) ++head;
    const double lowest = nodes[static_cast<std::size_t>(deque[static_cast<std::size_t>(head)])];
    if (lowest == -kInf) continue;
    // min over viewpoints of (lowest - V.z) / (p_w - V.p): the highest
    // viewpoint, and the distance that makes the ratio smallest.
    const double rise = lowest - z1_;
    const double slope = rise >= 0.0 ? rise / dp_max : rise / dp_min;
    double& best = cover[static_cast<std::size_t>(c)];
    if (slope > best) best = slope;
  }
  return static_cast<std::uint64_t>(pushed);
}

bool covered(const FaceFit& fit, const std::vector<double>& cover, int rows) {
  double lowest = kInf;
  for (int c = fit.column_lo; c <= fit.column_hi; ++c) lowest = std::min(lowest, cover[static_cast<std::size_t>(c)]);
  const double top = fit.slope_max + fit.slope_slack;
  if (rows == 0) return lowest > top;
  // Rows [-1 + k * width, -1 + (k + 1) * width); the item's top row is the
  // one holding `top`, and it must lie wholly below the cover.
  if (top >= 1.0) return false;
  const double width = 2.0 / rows;
  const double row = std::floor((std::max(top, -1.0) + 1.0) / width);
  return -1.0 + (row + 1.0) * width < lowest;
}

Status sweep_face(const FaceGeometry& geometry, const terrain::HeightView& terrain, int wall_end,
                  const RunControl* control, const std::function<void(int, const std::vector<double>&)>& test,
                  RegionStats& stats) {
  std::vector<double> cover(static_cast<std::size_t>(geometry.resolution()), -kInf);
  std::vector<float> nodes(static_cast<std::size_t>(geometry.lateral_count()));
  std::vector<int> deque(nodes.size());
  const int end = std::min(wall_end, geometry.wall_count());
  for (int w = std::max(0, geometry.first_wall()); w < end; ++w) {
    if ((w & 63) == 0) HORIZON_RETURN_IF_ERROR(check_control(control));
    test(w, cover);
    for (int v = 0; v < geometry.lateral_count(); ++v) {
      const float z = terrain.at(geometry.node_col(w, v), geometry.node_row(w, v));
      nodes[static_cast<std::size_t>(v)] = z == z ? z : -std::numeric_limits<float>::infinity();
    }
    geometry.add_wall(w, nodes, deque, cover);
    stats.wall_nodes_read += nodes.size();
    ++stats.walls_swept;
  }
  test(std::max(end, geometry.first_wall()), cover);
  return Status::Ok();
}

}  // namespace horizon::region
