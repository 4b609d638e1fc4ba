#include "region/hull_clearance.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

#include "horizon/common/parallel.hpp"

namespace horizon::region {
namespace {

constexpr float kNone = -std::numeric_limits<float>::infinity();
// Metres a sight line must clear the bound by: R3 compares slopes, this
// compares heights, and R3's OHF is stored as float32 (half an ulp is
// 0.24 mm at 4 000 m); a margin d at a crossing is at least d at the target.
constexpr double kHeightSlack = 5e-4;
// Metric cell sizes vary across a region (CRS scale, latitude); the
// curvature margin uses distances inflated by this factor.
constexpr double kScaleSlack = 1.02;

struct Vec {
  double x, y;
};

double cross(Vec o, Vec a, Vec b) {
  return (a.x - o.x) * (b.y - o.y) - (a.y - o.y) * (b.x - o.x);
}

// Convex hull (counter-clockwise, no repeated point) of up to 5 points.
int convex_hull(std::array<Vec, 5> pts, std::array<Vec, 10>& hull) {
  std::sort(pts.begin(), pts.end(), [](Vec a, Vec b) { return a.x < b.x || (a.x == b.x && a.y < b.y); });
  int k = 0;
  for (int i = 0; i < 5; ++i) {
    while (k >= 2 && cross(hull[k - 2], hull[k - 1], pts[i]) <= 0) --k;
    hull[k++] = pts[i];
  }
  for (int i = 3, t = k + 1; i >= 0; --i) {
    while (k >= t && cross(hull[k - 2], hull[k - 1], pts[i]) <= 0) --k;
    hull[k++] = pts[i];
  }
  return k > 1 ? k - 1 : 1;
}

double distance_to_rect(Vec p, double x0, double x1, double y0, double y1) {
  const double dx = std::max({x0 - p.x, 0.0, p.x - x1}), dy = std::max({y0 - p.y, 0.0, p.y - y1});
  return std::hypot(dx, dy);
}

double farthest_in_rect(Vec p, double x0, double x1, double y0, double y1) {
  return std::hypot(std::max(p.x - x0, x1 - p.x), std::max(p.y - y0, y1 - p.y));
}

terrain::Grid<float> square_maxima(const terrain::HeightView& terrain, const terrain::Window& nodes, unsigned threads) {
  const int w = std::max(0, nodes.width() - 1), h = std::max(0, nodes.height() - 1);
  terrain::Grid<float> squares(w, h);
  parallel_for(static_cast<std::size_t>(h), threads, [&](std::size_t jj) {
    const int j = static_cast<int>(jj);
    float* out = squares.row(j);
    for (int i = 0; i < w; ++i) {
      float m = kNone;
      for (int dj = 0; dj < 2; ++dj)
        for (int di = 0; di < 2; ++di) {
          const float z = terrain.at(nodes.col0 + i + di, nodes.row0 + j + dj);
          if (z == z && z > m) m = z;  // a void's crossings are skipped: it raises nothing
        }
      out[i] = m;
    }
  });
  return squares;
}

}  // namespace

HullClearance::HullClearance(const terrain::HeightView& terrain, const terrain::Window& nodes, unsigned threads)
    : nodes_(nodes), squares_(square_maxima(terrain, nodes, threads)), pyramid_(squares_, terrain::Reduction::kMax) {}

bool HullClearance::clear(const RegionFrame& f, double col, double row, double z, int budget,
                          std::uint64_t* reads) const {
  const double mx = f.metres_per_col, my = f.metres_per_row;
  const Vec q{col * mx, row * my};
  const double bx0 = f.col_min * mx, bx1 = f.col_max * mx, by0 = f.row_min * my, by1 = f.row_max * my;
  const double far_b = farthest_in_rect(q, bx0, bx1, by0, by1);
  if (far_b == 0.0) return true;  // straight down: no crossing lies between
  if (pyramid_.width() == 0) return false;
  const double near_b = distance_to_rect(q, bx0, bx1, by0, by1);
  std::array<Vec, 10> hull{};
  const int n = convex_hull({Vec{bx0, by0}, Vec{bx1, by0}, Vec{bx1, by1}, Vec{bx0, by1}, q}, hull);
  const double hx0 = std::min(bx0, q.x), hx1 = std::max(bx1, q.x), hy0 = std::min(by0, q.y), hy1 = std::max(by1, q.y);
  const double curve = f.curvature * (far_b * kScaleSlack) * (far_b * kScaleSlack);
  const double bottom = f.z_min;
  const double nearest_crossing = std::min(mx, my);

  struct Tile {
    int level, i, j;
  };
  thread_local std::vector<Tile> stack;  // kept between calls: one test per cell is the hot path
  stack.clear();
  stack.push_back({pyramid_.level_count() - 1, 0, 0});
  std::uint64_t visits = 0;
  bool ok = true;
  while (!stack.empty()) {
    const Tile t = stack.back();
    stack.pop_back();
    if (++visits > static_cast<std::uint64_t>(budget)) {
      ok = false;
      break;
    }
    // The tile's squares [a, b) span nodes a .. b: grid columns col0 + a .. col0 + b.
    const int side = pyramid_.cell_side(t.level);
    const int a_c = t.i * side, b_c = std::min((t.i + 1) * side, pyramid_.width());
    const int a_r = t.j * side, b_r = std::min((t.j + 1) * side, pyramid_.height());
    const double x0 = (nodes_.col0 + a_c) * mx, x1 = (nodes_.col0 + b_c) * mx;
    const double y0 = (nodes_.row0 + a_r) * my, y1 = (nodes_.row0 + b_r) * my;
    if (x1 < hx0 || x0 > hx1 || y1 < hy0 || y0 > hy1) continue;
    bool separated = false;
    for (int e = 0; e < n && n > 1 && !separated; ++e) {
      const Vec p = hull[e], r = hull[(e + 1) % n];
      separated = cross(p, r, {x0, y0}) < -1e-9 && cross(p, r, {x1, y0}) < -1e-9 && cross(p, r, {x1, y1}) < -1e-9 &&
                  cross(p, r, {x0, y1}) < -1e-9;
    }
    if (separated) continue;
    const float top = pyramid_.value(t.level, t.i, t.j);
    if (!(top > kNone)) continue;
    // Segments V -> q cross this tile at fractions u = |p - q| / |V - q| of the way back from q.
    // q is a cell centre, so no crossing lies nearer to it than one cell.
    const double u_lo = std::max(distance_to_rect(q, x0, x1, y0, y1), nearest_crossing) / far_b;
    const double u_hi = near_b > 0.0 ? std::min(1.0, farthest_in_rect(q, x0, x1, y0, y1) / near_b) : 1.0;
    const double low = bottom >= z ? z + u_lo * (bottom - z) : z + u_hi * (bottom - z);
    const double margin = curve * std::min(0.25, u_hi);
    if (top <= low - margin - kHeightSlack) continue;
    if (t.level == 0) {
      ok = false;
      break;
    }
    const int lw = pyramid_.level_width(t.level - 1), lh = pyramid_.level_height(t.level - 1);
    for (int dj = 0; dj < 2; ++dj)
      for (int di = 0; di < 2; ++di) {
        const int ci = 2 * t.i + di, cj = 2 * t.j + dj;
        if (ci < lw && cj < lh) stack.push_back({t.level - 1, ci, cj});
      }
  }
  if (reads) *reads += visits;
  return ok;
}

}  // namespace horizon::region
