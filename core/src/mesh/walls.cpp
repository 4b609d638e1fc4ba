// The conservative mode's walls.
//
// The argument. Take a group inside circle (m, ρ) whose triangles are
// nowhere higher than z_top (their highest vertex: each triangle is a
// plane piece), a point q of it, and a camera c at horizontal distance D
// from m. Past radius √2 ρ from m, the ground track of the sight line from
// q to c moves steadily away from m (it is past its closest approach),
// and its azimuth from m stays within asin(ρ / r0) of c's once it is
// farther than r0. So inside the annular sector S of radii [r0, r1]
// (r0 > √2 ρ, r1 < D) and azimuths [a − ε, b + ε], ε = asin(ρ / r0),
// where [a, b] is the sector holding c's azimuth, the track runs from the
// inner arc to the outer one. Any curve inside S from its side at a − ε to
// its side at b + ε must then meet the track (two paths across a
// rectangle, one joining its short sides and one its long sides, cross).
// At the meeting point p, a fraction λ = |p − q| / |c − q| <=
// (r1 + ρ) / (D − ρ) along the sight line, the sight line is at most
//     z_top + max(0, z_c − z_top) · (r1 + ρ) / (D − ρ)
// high. If the terrain is higher than Z > z_top all along such a curve,
// every camera of that sector with D > r1 and
//     z_c < z_top + (Z − z_top) · (D − ρ) / (r1 + ρ)
// sees no point of the group: a sound test of whole triangles.
//
// Finding Z. S is cut into cells (4 azimuth bins a sector, 6 radial
// bins); a cell's floor is a lower bound of the surface over it, from the
// floor pyramid below, or −∞ where it is not wholly on the mesh. Z is the
// best bottleneck over chains of 8-adjacent cells from the first azimuth
// bin to the last (moving across the bins in order, and along the radius
// within one): a curve runs through such a chain, and the surface along
// it is at least the chain's lowest floor.
//
// Floors. The mesh's box is cut into a grid of about two triangles a
// cell. A cell's floor is the lowest point of the surface over the cell:
// each triangle meeting it clipped to it, the plane's lowest corner of the
// clipped piece, less a micrometre for rounding; a cell
// is whole when no border edge's box meets it and its centre is on the
// mesh (then all of it is). A pyramid of 2×2 minima (whole when all four
// are) serves large radii. A polar cell's floor is the lowest floor of the
// pyramid cells its box covers, on the finest level whose cells are half
// as wide as the box (3 x 3 cells at most).
//
// Each group keeps, per sector, the bands [1.5ρ·2^j, 3ρ·2^j] out to the
// mesh's diagonal that give a bound, reduced to those no nearer band
// beats: ascending outer radius and slope (Z − z_top) / (r1 + ρ), so the
// camera's best band is the last one it is beyond.
#include "mesh/walls.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>

#include "horizon/common/parallel.hpp"

namespace horizon::mesh {
namespace {

constexpr double kTwoPi = 2 * std::numbers::pi;

// The lowest height of triangle abc's plane over its part inside the box
// [x0, x1] x [y0, y1] (the triangle clipped to the box, Sutherland and
// Hodgman; a plane's minimum over a polygon is at a corner), less a
// micrometre for the clipping's rounding; +inf when they do not meet.
double lowest_in_box(const TinVertex& a, const TinVertex& b, const TinVertex& c, double x0, double y0, double x1,
                     double y1) {
  struct P {
    double x, y;
  };
  P poly[12] = {{a.x, a.y}, {b.x, b.y}, {c.x, c.y}};
  int n = 3;
  P next[12];
  // Keep the side where f(p) >= 0 of each of the box's four edges.
  auto clip = [&](auto&& f) {
    int m = 0;
    for (int i = 0; i < n; ++i) {
      const P& p = poly[i];
      const P& q = poly[(i + 1) % n];
      const double fp = f(p), fq = f(q);
      if (fp >= 0) next[m++] = p;
      if ((fp >= 0) != (fq >= 0)) {
        const double t = fp / (fp - fq);
        next[m++] = {p.x + t * (q.x - p.x), p.y + t * (q.y - p.y)};
      }
    }
    n = m;
    std::copy(next, next + m, poly);
  };
  clip([&](const P& p) { return p.x - x0; });
  if (n) clip([&](const P& p) { return x1 - p.x; });
  if (n) clip([&](const P& p) { return p.y - y0; });
  if (n) clip([&](const P& p) { return y1 - p.y; });
  if (n == 0) return INFINITY;
  const double denom = (b.x - a.x) * (c.y - a.y) - (c.x - a.x) * (b.y - a.y);
  if (denom == 0) return std::min({a.z, b.z, c.z});
  const double gx = ((b.z - a.z) * (c.y - a.y) - (c.z - a.z) * (b.y - a.y)) / denom;
  const double gy = ((c.z - a.z) * (b.x - a.x) - (b.z - a.z) * (c.x - a.x)) / denom;
  double low = INFINITY;
  for (int i = 0; i < n; ++i) low = std::min(low, a.z + gx * (poly[i].x - a.x) + gy * (poly[i].y - a.y));
  // Never below the triangle's lowest corner (rounding at a sliver).
  return std::max(low, std::min({a.z, b.z, c.z})) - 1e-6;
}

// A direction's cosine and sine.
struct Direction {
  double cos, sin;
  explicit Direction(double angle) : cos(std::cos(angle)), sin(std::sin(angle)) {}
};

// The azimuths [lo, lo + width] of a polar cell: its edges' directions and
// those of the axes it crosses, whose trigonometry every group's cells in
// that bin share (so it is worked out once a bin, not once a cell).
struct AzimuthBin {
  Direction lo, hi;
  std::vector<Direction> axes;
  AzimuthBin(double from, double width) : lo(from), hi(from + width) {
    for (int quarter = static_cast<int>(std::ceil(from / (kTwoPi / 4))); quarter * (kTwoPi / 4) <= from + width; ++quarter)
      axes.emplace_back(quarter * (kTwoPi / 4));
  }
};

struct Level {
  int nx = 0, ny = 0;
  double cell = 0;
  std::vector<double> floor;        // lowest surface height in the cell
  std::vector<std::uint8_t> whole;  // the cell lies wholly on the mesh
};

}  // namespace

// The floor pyramid (see the comment at the top).
class FloorPyramid {
 public:
  explicit FloorPyramid(const Tin& tin) {
    double x1 = -INFINITY, y1 = -INFINITY;
    for (const TinVertex& v : tin.vertices) {
      x0_ = std::min(x0_, v.x), y0_ = std::min(y0_, v.y);
      x1 = std::max(x1, v.x), y1 = std::max(y1, v.y);
    }
    const double w = std::max(x1 - x0_, 1e-9), h = std::max(y1 - y0_, 1e-9);
    diagonal_ = std::hypot(w, h);
    Level base;
    base.cell = std::sqrt(w * h / std::max<double>(1.0, static_cast<double>(tin.triangles.size()) / 2.0));
    // Clamped as doubles: a sliver of a mesh makes one ratio huge.
    base.nx = static_cast<int>(std::clamp(std::ceil(w / base.cell), 1.0, 8192.0));
    base.ny = static_cast<int>(std::clamp(std::ceil(h / base.cell), 1.0, 8192.0));
    base.cell = std::max(w / base.nx, h / base.ny) * (1 + 1e-12);
    const std::size_t cells = static_cast<std::size_t>(base.nx) * static_cast<std::size_t>(base.ny);
    base.floor.assign(cells, INFINITY);
    std::vector<std::uint8_t> border(cells, 0);
    std::vector<std::uint8_t> centre_on(cells, 0);
    auto each_cell = [&](double bx0, double by0, double bx1, double by1, auto&& visit) {
      const int cx0 = std::clamp(static_cast<int>((bx0 - x0_) / base.cell), 0, base.nx - 1);
      const int cy0 = std::clamp(static_cast<int>((by0 - y0_) / base.cell), 0, base.ny - 1);
      const int cx1 = std::clamp(static_cast<int>((bx1 - x0_) / base.cell), 0, base.nx - 1);
      const int cy1 = std::clamp(static_cast<int>((by1 - y0_) / base.cell), 0, base.ny - 1);
      for (int cy = cy0; cy <= cy1; ++cy)
        for (int cx = cx0; cx <= cx1; ++cx) visit(cx, cy, static_cast<std::size_t>(cy) * static_cast<std::size_t>(base.nx) + static_cast<std::size_t>(cx));
    };
    std::vector<std::array<std::uint32_t, 2>> edges;
    for (const TinTriangle& t : tin.triangles) {
      const TinVertex& a = tin.vertices[t[0]];
      const TinVertex& b = tin.vertices[t[1]];
      const TinVertex& c = tin.vertices[t[2]];
      each_cell(std::min({a.x, b.x, c.x}), std::min({a.y, b.y, c.y}), std::max({a.x, b.x, c.x}),
                std::max({a.y, b.y, c.y}), [&](int cx, int cy, std::size_t k) {
                  const double x0 = x0_ + cx * base.cell, y0 = y0_ + cy * base.cell;
                  base.floor[k] = std::min(base.floor[k], lowest_in_box(a, b, c, x0, y0, x0 + base.cell, y0 + base.cell));
                  // Is the cell's centre inside this (counter-clockwise) triangle?
                  const double px = x0_ + (cx + 0.5) * base.cell, py = y0_ + (cy + 0.5) * base.cell;
                  bool inside = true;
                  for (int e = 0; e < 3 && inside; ++e) {
                    const TinVertex& p = tin.vertices[t[e]];
                    const TinVertex& q = tin.vertices[t[(e + 1) % 3]];
                    if ((q.x - p.x) * (py - p.y) - (q.y - p.y) * (px - p.x) < 0) inside = false;
                  }
                  if (inside) centre_on[k] = 1;
                });
      for (int e = 0; e < 3; ++e) edges.push_back({std::min(t[e], t[(e + 1) % 3]), std::max(t[e], t[(e + 1) % 3])});
    }
    std::sort(edges.begin(), edges.end());
    for (std::size_t i = 0; i < edges.size();) {
      std::size_t j = i;
      while (j < edges.size() && edges[j] == edges[i]) ++j;
      if (j - i == 1) {  // a border edge
        const TinVertex& a = tin.vertices[edges[i][0]];
        const TinVertex& b = tin.vertices[edges[i][1]];
        each_cell(std::min(a.x, b.x), std::min(a.y, b.y), std::max(a.x, b.x), std::max(a.y, b.y),
                  [&](int, int, std::size_t k) { border[k] = 1; });
      }
      i = j;
    }
    base.whole.resize(cells);
    for (std::size_t k = 0; k < cells; ++k) base.whole[k] = !border[k] && centre_on[k];
    levels_.push_back(std::move(base));
    while (levels_.back().nx > 1 || levels_.back().ny > 1) {
      const Level& fine = levels_.back();
      Level coarse;
      coarse.nx = (fine.nx + 1) / 2, coarse.ny = (fine.ny + 1) / 2, coarse.cell = fine.cell * 2;
      const std::size_t n = static_cast<std::size_t>(coarse.nx) * static_cast<std::size_t>(coarse.ny);
      coarse.floor.assign(n, INFINITY);
      coarse.whole.assign(n, 1);
      for (int y = 0; y < fine.ny; ++y)
        for (int x = 0; x < fine.nx; ++x) {
          const std::size_t f = static_cast<std::size_t>(y) * static_cast<std::size_t>(fine.nx) + static_cast<std::size_t>(x);
          const std::size_t c = static_cast<std::size_t>(y / 2) * static_cast<std::size_t>(coarse.nx) + static_cast<std::size_t>(x / 2);
          coarse.floor[c] = std::min(coarse.floor[c], fine.floor[f]);
          coarse.whole[c] = coarse.whole[c] && fine.whole[f];
        }
      // A coarse cell past the fine grid's edge covers ground off the mesh.
      if (fine.nx % 2)
        for (int y = 0; y < coarse.ny; ++y) coarse.whole[static_cast<std::size_t>(y) * static_cast<std::size_t>(coarse.nx) + static_cast<std::size_t>(coarse.nx - 1)] = 0;
      if (fine.ny % 2)
        for (int x = 0; x < coarse.nx; ++x) coarse.whole[static_cast<std::size_t>(coarse.ny - 1) * static_cast<std::size_t>(coarse.nx) + static_cast<std::size_t>(x)] = 0;
      levels_.push_back(std::move(coarse));
    }
  }

  double diagonal() const { return diagonal_; }

  // A lower bound of the surface over the polar cell of radii [r0, r1]
  // and azimuths [lo, lo + width] about (mx, my): the lowest floor of the
  // pyramid cells its box covers, on the finest level whose cells are at
  // least half as wide as the box (so 3 x 3 of them at most); −∞ when one
  // of them is not wholly on the mesh.
  double polar_floor(double mx, double my, double r0, double r1, const AzimuthBin& bin) const {
    // The box: the four corners, and the outer arc's extremes where it
    // crosses an axis.
    double bx0 = INFINITY, by0 = INFINITY, bx1 = -INFINITY, by1 = -INFINITY;
    auto take = [&](double r, const Direction& d) {
      const double x = mx + r * d.cos, y = my + r * d.sin;
      bx0 = std::min(bx0, x), by0 = std::min(by0, y), bx1 = std::max(bx1, x), by1 = std::max(by1, y);
    };
    take(r0, bin.lo), take(r0, bin.hi), take(r1, bin.lo), take(r1, bin.hi);
    for (const Direction& d : bin.axes) take(r1, d);
    const double size = std::max(bx1 - bx0, by1 - by0);
    std::size_t l = 0;
    while (l + 1 < levels_.size() && levels_[l].cell < size / 2) ++l;
    const Level& level = levels_[l];
    const int cx0 = static_cast<int>(std::floor((bx0 - x0_) / level.cell));
    const int cy0 = static_cast<int>(std::floor((by0 - y0_) / level.cell));
    const int cx1 = static_cast<int>(std::floor((bx1 - x0_) / level.cell));
    const int cy1 = static_cast<int>(std::floor((by1 - y0_) / level.cell));
    if (cx0 < 0 || cy0 < 0 || cx1 >= level.nx || cy1 >= level.ny) return -INFINITY;
    double lowest = INFINITY;
    for (int y = cy0; y <= cy1; ++y)
      for (int x = cx0; x <= cx1; ++x) {
        const std::size_t c = static_cast<std::size_t>(y) * static_cast<std::size_t>(level.nx) + static_cast<std::size_t>(x);
        if (!level.whole[c]) return -INFINITY;
        lowest = std::min(lowest, level.floor[c]);
      }
    return lowest;
  }

 private:
  double x0_ = INFINITY, y0_ = INFINITY, diagonal_ = 0;
  std::vector<Level> levels_;
};

namespace {

struct Arc {
  double radius, slope;
};

constexpr int kBinsPerSector = 4;
constexpr int kRadialBins = 6;

// The bands of one item (a group, a box) inside `circle`, no point of it
// higher than `top`, per sector.
void bands_for(const FloorPyramid& floors, std::span<const AzimuthBin> azimuths, const Circle& circle, double top,
               int s, std::vector<std::vector<Arc>>& walls) {
  walls.assign(static_cast<std::size_t>(s), {});
  const int bins = s * kBinsPerSector;
  const double bin = kTwoPi / bins;
  std::vector<double> floor(static_cast<std::size_t>(bins * kRadialBins));
  std::vector<double> best(kRadialBins), next(kRadialBins);
  for (double r0 = 1.5 * std::max(circle.radius, 1e-3); r0 <= floors.diagonal(); r0 *= 2) {
    const double r1 = 2 * r0;
    for (int a = 0; a < bins; ++a)
      for (int b = 0; b < kRadialBins; ++b)
        floor[static_cast<std::size_t>(a * kRadialBins + b)] =
            floors.polar_floor(circle.x, circle.y, r0 + (r1 - r0) * b / kRadialBins, r0 + (r1 - r0) * (b + 1) / kRadialBins,
                               azimuths[static_cast<std::size_t>(a)]);
    const double widen = std::asin(circle.radius / r0) + 1e-9;
    const int reach = static_cast<int>(std::ceil(widen / bin));  // bins the widening adds either side
    for (int i = 0; i < s; ++i) {
      // Bins from the one holding a − ε to the one holding b + ε.
      const int first = i * kBinsPerSector - reach, last = (i + 1) * kBinsPerSector - 1 + reach;
      if (last - first + 1 > bins) continue;  // the widened sector wraps all round
      auto cell = [&](int a, int b) { return floor[static_cast<std::size_t>(((a % bins + bins) % bins) * kRadialBins + b)]; };
      for (int b = 0; b < kRadialBins; ++b) best[static_cast<std::size_t>(b)] = cell(first, b);
      for (int a = first;; ++a) {
        // Along the radius within bin a, both ways.
        for (int b = 1; b < kRadialBins; ++b)
          best[b] = std::max(best[b], std::min(best[b - 1], cell(a, b)));
        for (int b = kRadialBins - 2; b >= 0; --b)
          best[b] = std::max(best[b], std::min(best[b + 1], cell(a, b)));
        if (a == last) break;
        for (int b = 0; b < kRadialBins; ++b) {
          double from = best[b];
          if (b > 0) from = std::max(from, best[b - 1]);
          if (b + 1 < kRadialBins) from = std::max(from, best[b + 1]);
          next[b] = std::min(from, cell(a + 1, b));
        }
        std::swap(best, next);
      }
      const double z = *std::max_element(best.begin(), best.end());
      if (!(z > top)) continue;
      const double slope = (z - top) / (r1 + circle.radius);
      auto& arcs = walls[static_cast<std::size_t>(i)];
      if (arcs.empty() || slope > arcs.back().slope) arcs.push_back({r1, slope});
    }
  }
}

}  // namespace

std::shared_ptr<const FloorPyramid> build_floors(const Tin& tin) { return std::make_shared<const FloorPyramid>(tin); }

Walls build_walls(const Tin& tin, int sectors, std::span<const Circle> circles, std::span<const double> tops,
                  unsigned threads) {
  return build_walls(FloorPyramid(tin), sectors, circles, tops, threads);
}

Walls build_walls(const FloorPyramid& floors, int sectors, std::span<const Circle> circles, std::span<const double> tops,
                  unsigned threads) {
  const std::size_t items = circles.size();
  const auto s = static_cast<std::size_t>(sectors);
  std::vector<std::vector<std::vector<Arc>>> bands(items);
  std::vector<AzimuthBin> azimuths;
  const int bins = sectors * kBinsPerSector;
  for (int a = 0; a < bins; ++a) azimuths.emplace_back(kTwoPi / bins * a, kTwoPi / bins);
  parallel_for(items, threads, [&](std::size_t k) { bands_for(floors, azimuths, circles[k], tops[k], sectors, bands[k]); });
  Walls walls;
  walls.top.assign(tops.begin(), tops.end());
  walls.begin.assign(1, 0);
  for (std::size_t k = 0; k < items; ++k)
    for (std::size_t i = 0; i < s; ++i) {
      for (const Arc& arc : bands[k][i]) {
        walls.radius.push_back(arc.radius);
        walls.slope.push_back(arc.slope);
      }
      walls.begin.push_back(static_cast<std::uint32_t>(walls.radius.size()));
    }
  return walls;
}

void build_walls(PreparedMesh& mesh, unsigned threads) { build_walls(mesh, FloorPyramid(mesh.tin), threads); }

void build_walls(PreparedMesh& mesh, const FloorPyramid& floors, unsigned threads) {
  std::vector<Circle> circles;
  std::vector<double> tops;
  for (const MeshGroup& group : mesh.groups) {
    double top = -INFINITY;
    for (std::uint32_t t = group.first_triangle; t < group.first_triangle + group.triangle_count; ++t)
      for (std::uint32_t v : mesh.tin.triangles[t]) top = std::max(top, mesh.tin.vertices[v].z);
    circles.push_back(group.circle);
    tops.push_back(top);
  }
  Walls walls = build_walls(floors, mesh.sectors, circles, tops, threads);
  mesh.group_top = std::move(walls.top);
  mesh.wall_begin = std::move(walls.begin);
  mesh.wall_radius = std::move(walls.radius);
  mesh.wall_slope = std::move(walls.slope);
}

}  // namespace horizon::mesh
