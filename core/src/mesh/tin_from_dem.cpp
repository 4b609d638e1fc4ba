#include "horizon/mesh/tin_from_dem.hpp"

#include <CGAL/Delaunay_triangulation_2.h>
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Triangulation_face_base_with_info_2.h>
#include <CGAL/Triangulation_vertex_base_with_info_2.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <queue>
#include <string>
#include <vector>

namespace horizon::mesh {
namespace {

using Kernel = CGAL::Exact_predicates_inexact_constructions_kernel;
using VertexBase = CGAL::Triangulation_vertex_base_with_info_2<std::uint32_t, Kernel>;  // our vertex index
using FaceBase = CGAL::Triangulation_face_base_with_info_2<std::uint64_t, Kernel>;      // the face's stamp
using Delaunay = CGAL::Delaunay_triangulation_2<Kernel, CGAL::Triangulation_data_structure_2<VertexBase, FaceBase>>;
using Face = Delaunay::Face_handle;

constexpr std::uint32_t kMaxVertices = 16'000'000;

// A point of the grid frame: (col, row) of a cell centre, and its height.
struct GridPoint {
  double col = 0.0, row = 0.0, z = 0.0;
};

// Calls visit(col, row, weights) for each cell centre inside the closed
// triangle (a, b, c) of the grid frame, and inside the grid; weights are
// the centre's barycentric coordinates. Edge functions of integer corners
// are exact in double, so then a centre on an edge is inside both its
// triangles.
template <class Visit>
void for_cells_in(const GridPoint& a, const GridPoint& b, const GridPoint& c, int width, int height,
                  Visit&& visit) {
  const double area = (b.col - a.col) * (c.row - a.row) - (c.col - a.col) * (b.row - a.row);
  if (area == 0.0) return;
  const int c0 = std::max(0, static_cast<int>(std::ceil(std::min({a.col, b.col, c.col}))));
  const int c1 = std::min(width - 1, static_cast<int>(std::floor(std::max({a.col, b.col, c.col}))));
  const int r0 = std::max(0, static_cast<int>(std::ceil(std::min({a.row, b.row, c.row}))));
  const int r1 = std::min(height - 1, static_cast<int>(std::floor(std::max({a.row, b.row, c.row}))));
  auto edge = [](const GridPoint& p, const GridPoint& q, double col, double row) {
    return (q.col - p.col) * (row - p.row) - (col - p.col) * (q.row - p.row);
  };
  const double sign = area > 0.0 ? 1.0 : -1.0, inv = 1.0 / std::fabs(area);
  for (int r = r0; r <= r1; ++r)
    for (int col = c0; col <= c1; ++col) {
      const double wa = sign * edge(b, c, col, r), wb = sign * edge(c, a, col, r), wc = sign * edge(a, b, col, r);
      if (wa < 0.0 || wb < 0.0 || wc < 0.0) continue;
      visit(col, r, std::array<double, 3>{wa * inv, wb * inv, wc * inv});
    }
}

double interpolate(const GridPoint& a, const GridPoint& b, const GridPoint& c, const std::array<double, 3>& w) {
  return w[0] * a.z + w[1] * b.z + w[2] * c.z;
}

// An error no larger than this at height h is the interpolation's rounding
// (a millionth of the height, a few float32 steps), not the terrain's:
// the greedy stops there, so a plane takes its corners alone.
double exact_within(double h) { return 1e-6 * std::max(1.0, std::fabs(h)); }

// A grid coordinate within 1e-9 of a whole cell, made whole: a vertex at a
// cell centre, carried through the CRS and back.
double snapped(double v) {
  const double whole = std::nearbyint(v);
  return std::fabs(v - whole) < 1e-9 ? whole : v;
}

// The valid cell nearest (Chebyshev) to (col, row), scanning rings
// outwards; false when the grid has none.
bool nearest_valid(const terrain::Grid<float>& z, int col, int row, GridPoint& out) {
  const int limit = std::max(z.width(), z.height());
  for (int ring = 0; ring < limit; ++ring) {
    for (int r = row - ring; r <= row + ring; ++r)
      for (int c = col - ring; c <= col + ring; ++c) {
        if (std::max(std::abs(r - row), std::abs(c - col)) != ring) continue;
        if (c < 0 || r < 0 || c >= z.width() || r >= z.height() || std::isnan(z.at(c, r))) continue;
        out = {static_cast<double>(c), static_cast<double>(r), z.at(c, r)};
        return true;
      }
  }
  return false;
}

// The worst cell of a face, waiting in the queue; stale once the face's
// stamp moves on (an insertion changed it).
struct Candidate {
  double error;  // metres, as measure_fit computes it
  int col, row;
  std::uint64_t stamp;
  Face face;
  bool operator<(const Candidate& o) const {
    // Largest error first; ties to the lowest row, then column: one order, so
    // one TIN for one DEM.
    if (error != o.error) return error < o.error;
    if (row != o.row) return row > o.row;
    return col > o.col;
  }
};

class Greedy {
 public:
  explicit Greedy(const terrain::Grid<float>& z) : z_(z) {}

  void insert(const GridPoint& p, Face hint = Face()) {
    const auto v = dt_.insert(Delaunay::Point(p.col, p.row), hint);
    v->info() = static_cast<std::uint32_t>(points_.size());
    points_.push_back(p);
    if (dt_.dimension() < 2) return;  // the first corners: no triangle yet
    auto f = dt_.incident_faces(v), done = f;
    do {
      if (!dt_.is_infinite(f)) rescan(f);
    } while (++f != done);
  }

  // Every face stamped and scanned anew (entries queued before are stale).
  void rescan_all() {
    for (auto f = dt_.finite_faces_begin(); f != dt_.finite_faces_end(); ++f) rescan(f);
  }

  // Inserts worst cells until the budget or the error bound is reached.
  void run(std::uint32_t max_vertices, double max_error) {
    while (points_.size() < max_vertices && !queue_.empty()) {
      const Candidate top = queue_.top();
      queue_.pop();
      if (top.face->info() != top.stamp) continue;
      if (top.error <= max_error) break;
      insert({static_cast<double>(top.col), static_cast<double>(top.row), z_.at(top.col, top.row)}, top.face);
    }
  }

  std::size_t vertex_count() const { return points_.size(); }
  int face_count() const { return static_cast<int>(dt_.number_of_faces()); }

  // The TIN in the grid frame: its triangles counter-clockwise in (col, row).
  void emit(std::vector<GridPoint>& points, std::vector<TinTriangle>& triangles) const {
    points = points_;
    for (auto f = dt_.finite_faces_begin(); f != dt_.finite_faces_end(); ++f)
      triangles.push_back({f->vertex(0)->info(), f->vertex(1)->info(), f->vertex(2)->info()});
  }

 private:
  void rescan(Face f) {
    f->info() = ++stamp_;
    const GridPoint &a = points_[f->vertex(0)->info()], &b = points_[f->vertex(1)->info()],
                    &c = points_[f->vertex(2)->info()];
    Candidate worst{0.0, 0, 0, stamp_, f};
    for_cells_in(a, b, c, z_.width(), z_.height(), [&](int col, int row, const std::array<double, 3>& w) {
      const float h = z_.at(col, row);
      if (std::isnan(h)) return;
      const double e = std::fabs(h - interpolate(a, b, c, w));
      if (e > worst.error && e > exact_within(h)) {  // row-major order: a tie keeps the lowest row, then column
        worst.error = e;
        worst.col = col;
        worst.row = row;
      }
    });
    if (worst.error > 0.0) queue_.push(worst);
  }

  const terrain::Grid<float>& z_;
  Delaunay dt_;
  std::vector<GridPoint> points_;
  std::priority_queue<Candidate> queue_;
  std::uint64_t stamp_ = 0;
};

}  // namespace

Result<DemTin> tin_from_dem(const terrain::Dem& dem, const GreedyOptions& options) {
  if (options.max_vertices < 4)
    return make_error(ErrorCode::kInvalidArgument,
                      "max_vertices is " + std::to_string(options.max_vertices) +
                          "; a TIN from a DEM starts from its four corners, so it must be at least 4",
                      "max_vertices");
  if (options.max_vertices > kMaxVertices)
    return make_error(ErrorCode::kResourceExhausted,
                      "max_vertices is " + std::to_string(options.max_vertices) + "; at most " +
                          std::to_string(kMaxVertices) + " vertices are built",
                      "max_vertices");
  if (!std::isfinite(options.max_error) || options.max_error < 0.0)
    return make_error(ErrorCode::kInvalidArgument, "max_error must be a number of metres >= 0", "max_error");
  const terrain::Grid<float>& z = dem.elevation;
  if (z.width() < 2 || z.height() < 2)
    return make_error(ErrorCode::kDataError,
                      dem.source + ": a TIN needs a DEM of at least 2 x 2 cells, not " + std::to_string(z.width()) +
                          " x " + std::to_string(z.height()),
                      "dem");
  // The corners, or the valid cells nearest them.
  std::vector<GridPoint> corners;
  for (auto [c, r] : {std::pair(0, 0), std::pair(z.width() - 1, 0), std::pair(z.width() - 1, z.height() - 1),
                      std::pair(0, z.height() - 1)}) {
    GridPoint p;
    if (!nearest_valid(z, c, r, p)) break;
    if (std::none_of(corners.begin(), corners.end(), [&](const GridPoint& q) { return q.col == p.col && q.row == p.row; }))
      corners.push_back(p);
  }
  Greedy greedy(z);
  for (const GridPoint& p : corners) greedy.insert(p);
  if (greedy.face_count() == 0)
    return make_error(ErrorCode::kDataError,
                      dem.source + ": the valid cells nearest the DEM's corners lie on one line (or there are fewer "
                                   "than three); no TIN spans it",
                      "dem");
  greedy.rescan_all();
  greedy.run(options.max_vertices, options.max_error);

  std::vector<GridPoint> points;
  DemTin out;
  greedy.emit(points, out.tin.triangles);
  const terrain::GeoTransform& t = dem.georef.transform;
  out.tin.vertices.reserve(points.size());
  for (const GridPoint& p : points) out.tin.vertices.push_back({t.x_at(p.col), t.y_at(p.row), p.z});
  // Counter-clockwise in (col, row) is clockwise in (x, y) when one axis
  // flips (north-up: rows run south).
  if ((t.pixel_width > 0.0) != (t.pixel_height > 0.0))
    for (TinTriangle& tri : out.tin.triangles) std::swap(tri[1], tri[2]);
  out.fit = measure_fit(out.tin, dem);
  return out;
}

TinFit measure_fit(const Tin& tin, const terrain::Dem& dem) {
  const terrain::Grid<float>& z = dem.elevation;
  const terrain::GeoTransform& t = dem.georef.transform;
  std::vector<std::uint8_t> measured(static_cast<std::size_t>(z.width()) * static_cast<std::size_t>(z.height()), 0);
  TinFit fit;
  double squares = 0.0;
  for (const TinTriangle& tri : tin.triangles) {
    std::array<GridPoint, 3> p;
    for (int i = 0; i < 3; ++i) {
      const TinVertex& v = tin.vertices[tri[i]];
      p[i] = {snapped(t.col_at(v.x)), snapped(t.row_at(v.y)), v.z};
    }
    for_cells_in(p[0], p[1], p[2], z.width(), z.height(), [&](int col, int row, const std::array<double, 3>& w) {
      const std::size_t i = static_cast<std::size_t>(row) * static_cast<std::size_t>(z.width()) +
                            static_cast<std::size_t>(col);
      const float h = z.at(col, row);
      if (measured[i] || std::isnan(h)) return;
      measured[i] = 1;
      const double e = std::fabs(h - interpolate(p[0], p[1], p[2], w));
      fit.max_error = std::max(fit.max_error, e);
      squares += e * e;
      ++fit.cells;
    });
  }
  for (int row = 0; row < z.height(); ++row)
    for (int col = 0; col < z.width(); ++col)
      fit.outside += !std::isnan(z.at(col, row)) &&
                     !measured[static_cast<std::size_t>(row) * static_cast<std::size_t>(z.width()) +
                               static_cast<std::size_t>(col)];
  fit.rmse = fit.cells ? std::sqrt(squares / static_cast<double>(fit.cells)) : 0.0;
  return fit;
}

}  // namespace horizon::mesh
