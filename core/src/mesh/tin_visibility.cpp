#include "horizon/mesh/tin_visibility.hpp"

#include <algorithm>
#include <cmath>
#include <utility>

namespace horizon::mesh {
namespace {

// Counting sort of (cell, item) pairs into CSR form.
void bucket(std::size_t cells, const std::vector<std::pair<std::uint32_t, std::uint32_t>>& pairs,
            std::vector<std::uint32_t>& start, std::vector<std::uint32_t>& items) {
  start.assign(cells + 1, 0);
  for (const auto& [cell, item] : pairs) ++start[cell + 1];
  for (std::size_t c = 0; c < cells; ++c) start[c + 1] += start[c];
  items.resize(pairs.size());
  std::vector<std::uint32_t> fill(start.begin(), start.end() - 1);
  for (const auto& [cell, item] : pairs) items[fill[cell]++] = item;
}

}  // namespace

TinVisibility::TinVisibility(const Tin& tin) : tin_(tin) {
  for (const TinTriangle& t : tin.triangles)
    for (int e = 0; e < 3; ++e) {
      std::uint32_t a = t[e], b = t[(e + 1) % 3];
      if (a > b) std::swap(a, b);
      edges_.push_back({a, b});
    }
  std::sort(edges_.begin(), edges_.end());
  edges_.erase(std::unique(edges_.begin(), edges_.end()), edges_.end());

  double x1 = -INFINITY, y1 = -INFINITY;
  x0_ = y0_ = INFINITY;
  for (const TinVertex& v : tin.vertices) {
    x0_ = std::min(x0_, v.x), y0_ = std::min(y0_, v.y);
    x1 = std::max(x1, v.x), y1 = std::max(y1, v.y);
  }
  const double w = std::max(x1 - x0_, 1e-9), h = std::max(y1 - y0_, 1e-9);
  const double cells = std::max<double>(1.0, static_cast<double>(edges_.size()) / 2.0);
  cell_ = std::sqrt(w * h / cells);
  // Clamped as doubles: a sliver of a mesh makes one ratio huge.
  nx_ = static_cast<int>(std::clamp(std::ceil(w / cell_), 1.0, 16384.0));
  ny_ = static_cast<int>(std::clamp(std::ceil(h / cell_), 1.0, 16384.0));
  cell_ = std::max(w / nx_, h / ny_) * (1 + 1e-12);

  auto box_cells = [&](double bx0, double by0, double bx1, double by1, std::uint32_t item, auto& pairs) {
    const int cx0 = std::clamp(static_cast<int>((bx0 - x0_) / cell_), 0, nx_ - 1);
    const int cy0 = std::clamp(static_cast<int>((by0 - y0_) / cell_), 0, ny_ - 1);
    const int cx1 = std::clamp(static_cast<int>((bx1 - x0_) / cell_), 0, nx_ - 1);
    const int cy1 = std::clamp(static_cast<int>((by1 - y0_) / cell_), 0, ny_ - 1);
    for (int cy = cy0; cy <= cy1; ++cy)
      for (int cx = cx0; cx <= cx1; ++cx) pairs.emplace_back(static_cast<std::uint32_t>(cell_of(cx, cy)), item);
  };
  std::vector<std::pair<std::uint32_t, std::uint32_t>> pairs;
  for (std::uint32_t e = 0; e < edges_.size(); ++e) {
    const TinVertex& a = tin.vertices[edges_[e][0]];
    const TinVertex& b = tin.vertices[edges_[e][1]];
    box_cells(std::min(a.x, b.x), std::min(a.y, b.y), std::max(a.x, b.x), std::max(a.y, b.y), e, pairs);
  }
  const std::size_t cell_count = static_cast<std::size_t>(nx_) * static_cast<std::size_t>(ny_);
  bucket(cell_count, pairs, edge_start_, edge_items_);
  pairs.clear();
  for (std::uint32_t t = 0; t < tin.triangles.size(); ++t) {
    const TinVertex& a = tin.vertices[tin.triangles[t][0]];
    const TinVertex& b = tin.vertices[tin.triangles[t][1]];
    const TinVertex& c = tin.vertices[tin.triangles[t][2]];
    box_cells(std::min({a.x, b.x, c.x}), std::min({a.y, b.y, c.y}), std::max({a.x, b.x, c.x}),
              std::max({a.y, b.y, c.y}), t, pairs);
  }
  bucket(cell_count, pairs, triangle_start_, triangle_items_);
}

std::optional<double> TinVisibility::height_at(double x, double y) const {
  const double fx = std::floor((x - x0_) / cell_), fy = std::floor((y - y0_) / cell_);
  if (!(fx >= 0 && fy >= 0 && fx < nx_ && fy < ny_)) return std::nullopt;  // NaN too
  const int cx = static_cast<int>(fx), cy = static_cast<int>(fy);
  const std::size_t cell = cell_of(cx, cy);
  for (std::uint32_t k = triangle_start_[cell]; k < triangle_start_[cell + 1]; ++k) {
    const TinTriangle& t = tin_.triangles[triangle_items_[k]];
    const TinVertex& a = tin_.vertices[t[0]];
    const TinVertex& b = tin_.vertices[t[1]];
    const TinVertex& c = tin_.vertices[t[2]];
    const double area = (b.x - a.x) * (c.y - a.y) - (b.y - a.y) * (c.x - a.x);
    const double wa = ((b.x - x) * (c.y - y) - (b.y - y) * (c.x - x)) / area;
    const double wb = ((c.x - x) * (a.y - y) - (c.y - y) * (a.x - x)) / area;
    const double wc = 1.0 - wa - wb;
    constexpr double kEdge = -1e-12;
    if (wa >= kEdge && wb >= kEdge && wc >= kEdge) return wa * a.z + wb * b.z + wc * c.z;
  }
  return std::nullopt;
}

// Visits every cell the segment's ground track passes through (a grid
// walk, clipped to the grid), possibly a cell twice at a corner.
template <class Visit>
void TinVisibility::walk_cells(double x0, double y0, double x1, double y1, Visit&& visit) const {
  // Clip to the grid's box (Liang–Barsky).
  double t0 = 0.0, t1 = 1.0;
  const double dx = x1 - x0, dy = y1 - y0;
  const double gx1 = x0_ + cell_ * nx_, gy1 = y0_ + cell_ * ny_;
  const double p[4] = {-dx, dx, -dy, dy};
  const double q[4] = {x0 - x0_, gx1 - x0, y0 - y0_, gy1 - y0};
  for (int i = 0; i < 4; ++i) {
    if (p[i] == 0.0) {
      if (q[i] < 0.0) return;
      continue;
    }
    const double r = q[i] / p[i];
    if (p[i] < 0.0) t0 = std::max(t0, r);
    else t1 = std::min(t1, r);
  }
  if (t0 > t1) return;
  const double sx = x0 + t0 * dx, sy = y0 + t0 * dy;
  int cx = std::clamp(static_cast<int>((sx - x0_) / cell_), 0, nx_ - 1);
  int cy = std::clamp(static_cast<int>((sy - y0_) / cell_), 0, ny_ - 1);
  const int ex = std::clamp(static_cast<int>((x0 + t1 * dx - x0_) / cell_), 0, nx_ - 1);
  const int ey = std::clamp(static_cast<int>((y0 + t1 * dy - y0_) / cell_), 0, ny_ - 1);
  const int step_x = dx > 0 ? 1 : -1, step_y = dy > 0 ? 1 : -1;
  // Parameter t at which the track crosses the next vertical / horizontal cell line.
  auto next_line = [&](int c, int step, double origin, double d, double start) {
    if (d == 0.0) return static_cast<double>(INFINITY);
    const double line = origin + cell_ * (c + (step > 0 ? 1 : 0));
    return (line - start) / d;
  };
  double tx = next_line(cx, step_x, x0_, dx, x0), ty = next_line(cy, step_y, y0_, dy, y0);
  const double dtx = dx == 0.0 ? INFINITY : cell_ / std::abs(dx);
  const double dty = dy == 0.0 ? INFINITY : cell_ / std::abs(dy);
  const int limit = nx_ + ny_ + 2;
  for (int steps = 0; steps < limit; ++steps) {
    visit(cell_of(cx, cy));
    if (cx == ex && cy == ey) return;
    if (tx <= ty) {
      if (tx > t1) return;
      cx += step_x, tx += dtx;
    } else {
      if (ty > t1) return;
      cy += step_y, ty += dty;
    }
    if (cx < 0 || cy < 0 || cx >= nx_ || cy >= ny_) return;
  }
}

bool TinVisibility::visible(const TinVertex& eye, const TinVertex& target, double tolerance) const {
  const double dx = target.x - eye.x, dy = target.y - eye.y, dz = target.z - eye.z;
  const double length = std::hypot(dx, dy);
  if (length == 0.0) return true;
  const double end_guard = 1e-6;
  bool hidden = false;
  walk_cells(eye.x, eye.y, target.x, target.y, [&](std::size_t cell) {
    if (hidden) return;
    for (std::uint32_t k = edge_start_[cell]; k < edge_start_[cell + 1] && !hidden; ++k) {
      const auto& e = edges_[edge_items_[k]];
      const TinVertex& a = tin_.vertices[e[0]];
      const TinVertex& b = tin_.vertices[e[1]];
      // Solve eye + t (target - eye) = a + u (b - a) on the ground.
      const double ex = b.x - a.x, ey = b.y - a.y;
      const double denom = dx * ey - dy * ex;
      if (denom == 0.0) continue;  // parallel: the edges either side are crossed instead
      const double ax = a.x - eye.x, ay = a.y - eye.y;
      const double t = (ax * ey - ay * ex) / denom;
      const double u = (ax * dy - ay * dx) / denom;
      if (t <= end_guard || t >= 1.0 - end_guard || u < 0.0 || u > 1.0) continue;
      const double ground = a.z + u * (b.z - a.z);
      const double sight = eye.z + t * dz;
      if (ground > sight + tolerance) hidden = true;
    }
  });
  return !hidden;
}

std::uint64_t TinVisibility::memory_bytes() const {
  return edges_.capacity() * sizeof(edges_[0]) +
         (edge_start_.capacity() + edge_items_.capacity() + triangle_start_.capacity() + triangle_items_.capacity()) *
             sizeof(std::uint32_t);
}

}  // namespace horizon::mesh
