// Ring-and-direction bounds of R3's crossing slopes near the eye (see
// polar_bounds.hpp).
#include "polar_bounds.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <mutex>

#include "horizon/common/parallel.hpp"

namespace horizon::visibility::detail {
namespace {

constexpr float kNone = -std::numeric_limits<float>::infinity();
constexpr int kTasks = 16;
// The first ring's outer radius, in cells, and each next ring's ratio to it
// (on the 12 M-cell Everest case, 1.5 left 0.69 G crossings to screen, 2
// left 0.80 G, 1.25 left 0.67 G in more rings).
constexpr double kFirstRing = 8, kRingGrowth = 1.5;
// Within kNearCells cells of the eye, where one cell spans a wide angle, a
// grid segment is cut into kNearPieces pieces, each with its own bound.
constexpr double kNearCells = 8;
constexpr int kNearPieces = 8;

// The double rounded up to a float.
float round_up(double s) {
  const float f = static_cast<float>(s);
  return f < s ? std::nextafter(f, std::numeric_limits<float>::infinity()) : f;
}

struct Builder {
  const ViewFrame& f;
  const std::vector<double>& outer;
  const std::vector<int>& bins;
  std::vector<std::vector<float>> bound;  // this task's maxima

  // A piece of a grid line from (x0, y0) to (x1, y1), grid coordinates,
  // whose terrain is linear from z0 to z1.
  void piece(double x0, double y0, double x1, double y1, double z0, double z1) {
    if (std::isnan(z0) || std::isnan(z1)) return;  // a crossing there reads a void: it never wins
    const double mx = f.metres_per_col, my = f.metres_per_row;
    const double ax = (x0 - f.observer_col) * mx, ay = (y0 - f.observer_row) * my;
    const double bx = (x1 - f.observer_col) * mx, by = (y1 - f.observer_row) * my;
    // Nearest point of the piece to the eye, and the farther end.
    const double ux = bx - ax, uy = by - ay, uu = ux * ux + uy * uy;
    const double u = uu > 0 ? std::clamp(-(ax * ux + ay * uy) / uu, 0.0, 1.0) : 0.0;
    const double nx = ax + u * ux, ny = ay + u * uy;
    // Slack for the rounding of R3's own distances (t * total) and of these.
    const double d_lo = std::sqrt(nx * nx + ny * ny) * (1 - 1e-12);
    const double d_hi = std::max(std::sqrt(ax * ax + ay * ay), std::sqrt(bx * bx + by * by)) * (1 + 1e-12);
    const double top = std::max(z0, z1);
    const double above = top + 1e-9 * (1.0 + std::abs(top)) - f.eye;
    float s = std::numeric_limits<float>::infinity();
    if (above < 0 || d_lo > 0)
      s = round_up(above / (above >= 0 ? d_lo : d_hi) - f.curvature * (f.curvature >= 0 ? d_lo : d_hi));
    // Its directions: the shorter arc between its ends (a piece that does
    // not hold the eye spans less than half a turn), or every direction for
    // a piece through the eye or so close to it (a micrometre) that
    // rounding could pick the wrong arc.
    const bool holds_eye = !(d_lo > 1e-6);
    double lo = 0, hi = 4;
    if (!holds_eye) {
      const double a0 = PolarBounds::pseudo_angle(x0 - f.observer_col, y0 - f.observer_row);
      const double a1 = PolarBounds::pseudo_angle(x1 - f.observer_col, y1 - f.observer_row);
      lo = std::min(a0, a1);
      hi = std::max(a0, a1);
      if (hi - lo > 2) {
        const double wrap = lo + 4;
        lo = hi;
        hi = wrap;
      }
    }
    for (std::size_t k = 0; k < outer.size(); ++k) {
      const double inner = k == 0 ? 0.0 : outer[k - 1];
      if (d_hi < inner || d_lo > outer[k]) continue;
      const int n = bins[k];
      std::vector<float>& b = bound[k];
      // One direction more on each side than the span touches: the sight
      // line's own pseudo-angle is rounded too.
      const long first = holds_eye ? 0 : static_cast<long>(std::floor(lo * n / 4)) - 1;
      const long last = holds_eye ? n - 1 : static_cast<long>(std::floor(hi * n / 4)) + 1;
      if (last - first + 1 >= n) {
        for (float& v : b) v = std::max(v, s);
      } else {
        for (long i = first; i <= last; ++i) {
          float& v = b[static_cast<std::size_t>(i & (n - 1))];
          v = std::max(v, s);
        }
      }
    }
  }

  // The grid segment on one line from position p to p + 1 (cells a and b),
  // or a half-cell stub past the grid's edge (R3 clamps positions there, so
  // the edge cell's height holds along it).
  void segment(bool column, double line, double p0, double p1, double za, double zb) {
    const double mid = (p0 + p1) / 2;
    const double dx = ((column ? line : mid) - f.observer_col) * f.metres_per_col;
    const double dy = ((column ? mid : line) - f.observer_row) * f.metres_per_row;
    const double near = kNearCells * std::max(f.metres_per_col, f.metres_per_row);
    const int pieces = dx * dx + dy * dy < near * near ? kNearPieces : 1;
    for (int j = 0; j < pieces; ++j) {
      const double w0 = double(j) / pieces, w1 = double(j + 1) / pieces;
      const double q0 = p0 + w0 * (p1 - p0), q1 = p0 + w1 * (p1 - p0);
      const double z0 = za + w0 * (zb - za), z1 = za + w1 * (zb - za);
      if (column)
        piece(line, q0, line, q1, z0, z1);
      else
        piece(q0, line, q1, line, z0, z1);
    }
  }

  // Every segment and edge stub of one grid line within [lo, hi] of positions.
  void line(const terrain::HeightView& z, bool column, int index, int lo, int hi) {
    const int count = column ? z.height() : z.width();
    const auto at = [&](int p) -> double { return column ? z.at(index, p) : z.at(p, index); };
    if (lo == 0) segment(column, index, -0.5, 0.0, at(0), at(0));
    if (hi == count - 1) segment(column, index, count - 1.0, count - 0.5, at(count - 1), at(count - 1));
    for (int p = lo; p < hi; ++p) segment(column, index, p, p + 1, at(p), at(p + 1));
  }
};

}  // namespace

double PolarBounds::pseudo_angle(double dx, double dy) {
  if (dy >= 0) return dx >= 0 ? dy / (dx + dy) : 1 - dx / (-dx + dy);
  return dx < 0 ? 2 - dy / (-dx - dy) : 3 + dx / (dx - dy);
}

PolarBounds::PolarBounds(const terrain::HeightView& z, const ViewFrame& f, double reach, unsigned threads) {
  const double cell = std::max(f.metres_per_col, f.metres_per_row);
  for (double r = kFirstRing * cell;; r *= kRingGrowth) {
    outer_.push_back(r);
    int n = 64;
    while (n < 8 * r / cell) n *= 2;
    bins_.push_back(n);
    if (r >= reach) break;
  }
  for (int n : bins_) bound_.emplace_back(static_cast<std::size_t>(n), kNone);

  // The lines and positions within the last ring (and a cell more).
  const double r = outer_.back();
  const int c_lo = std::max(0, static_cast<int>(std::floor(f.observer_col - r / f.metres_per_col)) - 1);
  const int c_hi = std::min(z.width() - 1, static_cast<int>(std::ceil(f.observer_col + r / f.metres_per_col)) + 1);
  const int r_lo = std::max(0, static_cast<int>(std::floor(f.observer_row - r / f.metres_per_row)) - 1);
  const int r_hi = std::min(z.height() - 1, static_cast<int>(std::ceil(f.observer_row + r / f.metres_per_row)) + 1);
  if (c_lo > c_hi || r_lo > r_hi) {
    gather_beyond();
    return;
  }
  const int columns = c_hi - c_lo + 1, lines = columns + (r_hi - r_lo + 1);
  std::mutex merge;
  parallel_for(kTasks, threads, [&](std::size_t task) {
    Builder b{f, outer_, bins_, {}};
    for (int n : bins_) b.bound.emplace_back(static_cast<std::size_t>(n), kNone);
    for (int i = static_cast<int>(task); i < lines; i += kTasks) {
      if (i < columns)
        b.line(z, true, c_lo + i, r_lo, r_hi);
      else
        b.line(z, false, r_lo + (i - columns), c_lo, c_hi);
    }
    const std::lock_guard<std::mutex> lock(merge);
    for (std::size_t k = 0; k < bound_.size(); ++k)
      for (std::size_t i = 0; i < bound_[k].size(); ++i) bound_[k][i] = std::max(bound_[k][i], b.bound[k][i]);
  });
  gather_beyond();
}

void PolarBounds::gather_beyond() {
  // Outer rings have as many directions or more (powers of two): direction
  // i of ring k covers directions [i r, (i + 1) r) of ring k + 1, r the ratio.
  beyond_ = bound_;
  for (int k = rings() - 2; k >= 0; --k) {
    const int ratio = bins_[k + 1] / bins_[k];
    for (int i = 0; i < bins_[k]; ++i)
      for (int j = i * ratio; j < (i + 1) * ratio; ++j)
        beyond_[k][i] = std::max(beyond_[k][i], beyond_[k + 1][j]);
  }
}

std::size_t PolarBounds::direction(int ring, double angle) const {
  const int n = bins_[ring];
  const long i = static_cast<long>(angle * n / 4);  // angle >= 0: truncation is floor
  return static_cast<std::size_t>(i & (n - 1));
}

float PolarBounds::beyond(int ring, double angle) const {
  return beyond_[ring][direction(ring, angle)];
}

float PolarBounds::bound(int ring, double angle) const {
  return bound_[ring][direction(ring, angle)];
}

}  // namespace horizon::visibility::detail
