// Sector-and-line bounds of R3's crossing slopes near the eye (see
// sector_bounds.hpp).
#include "sector_bounds.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <mutex>

#include "horizon/common/parallel.hpp"

namespace horizon::visibility::detail {
namespace {

constexpr float kNone = -std::numeric_limits<float>::infinity();

// The highest slope (terrain - curvature d^2 - eye) / d of a crossing whose
// terrain is at most `top` and whose distance lies in [d_lo, d_hi] (slack
// for rounding already in both), rounded up to a float; the terrain gets
// slack for R3's own interpolation. +inf when d_lo is 0 and top reaches the
// eye.
float slope_bound(const ViewFrame& f, double top, double d_lo, double d_hi) {
  const double above = top + 1e-6 * (1.0 + std::abs(top)) - f.eye;
  if (!(above < 0 || d_lo > 0)) return std::numeric_limits<float>::infinity();
  // Curvature is never negative (ViewshedOptions' check): -curvature d is
  // highest at d_lo.
  return SectorBounds::round_up(above / (above >= 0 ? d_lo : d_hi) - f.curvature * d_lo);
}

// A direction (dx, dy) whose pseudo-angle is `a` (in [0, 4]).
void direction_of(double a, double& dx, double& dy) {
  if (a <= 1) {
    dx = 1 - a, dy = a;
  } else if (a <= 2) {
    dx = 1 - a, dy = 2 - a;
  } else if (a <= 3) {
    dx = a - 3, dy = 2 - a;
  } else {
    dx = a - 3, dy = a - 4;
  }
}

// The terrain of line `cells` (positions 0 .. p_max + 1, `stride` floats
// apart, voids read as `fill`, a void left out) at its highest between
// positions lo <= hi: linear between cell centres, so at an end or at a
// cell centre between them. NaN when all of it reads voids.
double highest(const float* cells, std::ptrdiff_t stride, int p_max, float fill, double lo, double hi) {
  const auto at = [&](int p) -> double {
    const float raw = cells[p * stride];
    return raw == raw ? double(raw) : double(fill);
  };
  const auto interpolate = [&](double p) {
    const int k = std::min(static_cast<int>(p), p_max);
    const double za = at(k), zb = at(k + 1);
    return za + (p - double(k)) * (zb - za);
  };
  double top = std::fmax(interpolate(lo), interpolate(hi));
  for (int k = static_cast<int>(lo) + 1; k <= static_cast<int>(hi); ++k) top = std::fmax(top, at(k));
  return top;
}

}  // namespace

double SectorBounds::pseudo_angle(double dx, double dy) {
  if (dy >= 0) return dx >= 0 ? dy / (dx + dy) : 1 - dx / (-dx + dy);
  return dx < 0 ? 2 - dy / (-dx - dy) : 3 + dx / (dx - dy);
}

SectorBounds::SectorBounds(const terrain::HeightView& z, const terrain::Pyramid& maxima, const ViewFrame& f,
                           double reach, unsigned threads)
    : reach_(reach) {
  // Cover two cells more than the reach: a sight line's own arithmetic may
  // put a crossing a rounding error past it.
  const double cover = reach + 2 * std::max(f.metres_per_col, f.metres_per_row);
  const double spacing[2] = {f.metres_per_col, f.metres_per_row};
  for (int i = 0; i < 2; ++i) {
    Family& family = families_[i];
    family.count = static_cast<int>(std::ceil(cover / spacing[i])) + 1;
    family.first.assign(kSectors, 0);
    family.step.assign(kSectors, 1);
    family.bound.assign(static_cast<std::size_t>(kSectors) * family.stride(), kNone);
    family.block.assign(static_cast<std::size_t>(kSectors) * family.block_stride(), kNone);
    family.span.assign(static_cast<std::size_t>(kSectors) * family.spans(), kNone);
  }
  constexpr int kTasks = 64;
  parallel_for(kTasks, threads, [&](std::size_t task) {
    for (int s = static_cast<int>(task); s < kSectors; s += kTasks) build_sector(z, f, s, cover);
  });
  build_far(maxima, f, threads);
}

void SectorBounds::build_far(const terrain::Pyramid& maxima, const ViewFrame& f, unsigned threads) {
  const terrain::Window& w = f.window;
  band_metres_ = kFarTile * std::max(f.metres_per_col, f.metres_per_row);
  const double farthest = std::sqrt(f.farthest_distance2(w));
  bands_ = std::max(1, static_cast<int>(std::ceil((farthest - reach_) / band_metres_)) + 1);
  far_.assign(static_cast<std::size_t>(kSectors) * bands_, kNone);
  if (w.empty()) return;
  // The regions below cover the segments from the eye to the window's
  // targets only when the eye lies among them: else nothing is bounded.
  if (!(f.observer_col >= w.col0 - 0.5 && f.observer_col <= w.col1 - 0.5 && f.observer_row >= w.row0 - 0.5 &&
        f.observer_row <= w.row1 - 0.5)) {
    std::fill(far_.begin(), far_.end(), std::numeric_limits<float>::infinity());
    return;
  }
  const int across = (w.width() + kFarTile - 1) / kFarTile, down = (w.height() + kFarTile - 1) / kFarTile;
  std::mutex merge;
  // A fixed number of tasks, each with its own maxima merged at its end
  // (one per tile row would clear a table per row).
  constexpr int kTasks = 16;
  parallel_for(kTasks, threads, [&](std::size_t task) {
    std::vector<float> local(far_.size(), kNone);
    for (int tile = static_cast<int>(task); tile < across * down; tile += kTasks) {
      const int tx = tile % across, ty = tile / across;
      // The tile's region [x0, x1] x [y0, y1] (grid coordinates): its
      // cells' centres and half a cell around, so that the regions cover
      // every point between the eye and a target. A crossing there reads
      // cells within a cell of it, or of its position clamped to the DEM.
      const int c0 = w.col0 + tx * kFarTile, r0 = w.row0 + ty * kFarTile;
      const int c1 = std::min(c0 + kFarTile, w.col1 - 1), r1 = std::min(r0 + kFarTile, w.row1 - 1);
      const double x0 = c0 - 0.5, x1 = c1 + 0.5, y0 = r0 - 0.5, y1 = r1 + 0.5;
      const double ex = f.observer_col, ey = f.observer_row;
      const double nx = (std::clamp(ex, x0, x1) - ex) * f.metres_per_col,
                   ny = (std::clamp(ey, y0, y1) - ey) * f.metres_per_row;
      const double fx = std::max(std::abs(x0 - ex), std::abs(x1 - ex)) * f.metres_per_col;
      const double fy = std::max(std::abs(y0 - ey), std::abs(y1 - ey)) * f.metres_per_row;
      const double d_lo = std::sqrt(nx * nx + ny * ny) * (1 - 1e-12), d_hi = std::sqrt(fx * fx + fy * fy) * (1 + 1e-12);
      if (d_hi < reach_ * (1 - 1e-9)) continue;  // the near table's
      // Inside the window: a crossing between the eye and a target reads
      // no cell outside it with a weight other than zero.
      const terrain::Window around{std::max(w.col0, c0 - 2) - w.col0, std::max(w.row0, r0 - 2) - w.row0,
                                   std::min(w.col1, c1 + 3) - w.col0, std::min(w.row1, r1 + 3) - w.row0};
      const double top = maxima.max_in(around);
      if (!(top > -std::numeric_limits<double>::infinity())) continue;  // all void: its crossings never win
      const float s = slope_bound(f, top, d_lo, d_hi);
      // Its directions: every one when it holds the eye (or nearly),
      // else the arc of its corners, one sector more on each side.
      int first = 0, last = kSectors - 1;
      if (d_lo > 1e-6) {
        double lo = 4, hi = 0;
        for (const double x : {x0, x1})
          for (const double y : {y0, y1}) {
            const double a = pseudo_angle(x - ex, y - ey);
            lo = std::min(lo, a);
            hi = std::max(hi, a);
          }
        if (hi - lo > 2) {  // across angle 0: the arc from hi round to lo + 4
          const double wrap = lo + 4;
          lo = hi;
          hi = wrap;
        }
        first = static_cast<int>(std::floor(lo * kSectors / 4)) - 1;
        last = static_cast<int>(std::floor(hi * kSectors / 4)) + 1;
      }
      const int band = std::clamp(static_cast<int>((d_lo - reach_) / band_metres_), 0, bands_ - 1);
      for (int k = first; k <= last; ++k) {
        float& v = local[static_cast<std::size_t>(k & (kSectors - 1)) * bands_ + band];
        v = std::max(v, s);
      }
    }
    const std::lock_guard<std::mutex> lock(merge);
    for (std::size_t i = 0; i < far_.size(); ++i) far_[i] = std::max(far_[i], local[i]);
  });
  for (int k = 0; k < kSectors; ++k) {
    float* bands = far_.data() + static_cast<std::size_t>(k) * bands_;
    for (int b = 1; b < bands_; ++b) bands[b] = std::max(bands[b], bands[b - 1]);
  }
}

void SectorBounds::build_sector(const terrain::HeightView& z, const ViewFrame& f, int sector, double cover) {
  // The sector's edges, and the sides of the eye its lines run to.
  const double a_lo = 4.0 * sector / kSectors, a_hi = 4.0 * (sector + 1) / kSectors;
  double ex[2], ey[2], mx, my;
  direction_of(a_lo, ex[0], ey[0]);
  direction_of(a_hi, ex[1], ey[1]);
  direction_of((a_lo + a_hi) / 2, mx, my);
  for (int i = 0; i < 2; ++i) {
    const bool columns = i == 0;
    Family& family = families_[i];
    // Along the family (a) and along its lines (b).
    const double a0 = columns ? f.observer_col : f.observer_row, b0 = columns ? f.observer_row : f.observer_col;
    const double ma = columns ? f.metres_per_col : f.metres_per_row, mb = columns ? f.metres_per_row : f.metres_per_col;
    const int sa = (columns ? mx : my) > 0 ? 1 : -1, sb = (columns ? my : mx) > 0 ? 1 : -1;
    const int line_count = columns ? z.width() : z.height(), pos_count = columns ? z.height() : z.width();
    const std::ptrdiff_t line_stride = columns ? 1 : z.stride(), pos_stride = columns ? z.stride() : 1;
    // |b offset| per |a offset| of each edge (infinite for an edge along the lines).
    double q[2];
    for (int e = 0; e < 2; ++e) {
      const double da = std::abs(columns ? ex[e] : ey[e]), db = std::abs(columns ? ey[e] : ex[e]);
      q[e] = da == 0 ? std::numeric_limits<double>::infinity() : db / da;
    }
    const double q_lo = std::min(q[0], q[1]), q_hi = std::max(q[0], q[1]);
    // Metres from the eye per cell across the lines, at each edge.
    const double k_lo = std::sqrt(ma * ma + q_lo * mb * q_lo * mb), k_hi = std::sqrt(ma * ma + q_hi * mb * q_hi * mb);
    const int first = sa > 0 ? floor_to_int(a0) + 1 : ceil_to_int(a0) - 1;
    family.first[sector] = first;
    family.step[sector] = sa;
    float* bound = family.bound.data() + static_cast<std::size_t>(sector) * family.stride();
    const double pos_max = pos_count - 1.0;
    for (int j = 0; j < family.count; ++j) {
      const int line = first + sa * j;
      if (line < 0 || line >= line_count) continue;
      const double delta = std::abs(line - a0);  // cells across the lines from the eye
      const double across = delta * ma;
      if (across > cover) break;
      // Offsets along the line, cells from b0 on side sb: the sector's
      // crossings, and those within `cover` of the eye; their distances.
      const double off_lo = delta * q_lo;
      double off_hi = delta * q_hi, d_far = delta * k_hi;
      if (!(d_far <= cover)) {
        off_hi = std::min(off_hi, std::sqrt(cover * cover - across * across) / mb);
        d_far = std::sqrt(across * across + off_hi * mb * off_hi * mb);
      }
      if (!(off_lo <= off_hi)) continue;
      // Widened by a hair: R3's own arithmetic may put a crossing on a cell
      // centre just before it, and read the cell pair there.
      constexpr double kHair = 1e-7;  // cells
      double p_lo = b0 + sb * off_lo, p_hi = b0 + sb * off_hi;
      if (p_lo > p_hi) std::swap(p_lo, p_hi);
      p_lo = std::clamp(p_lo - kHair, 0.0, pos_max);
      p_hi = std::clamp(p_hi + kHair, 0.0, pos_max);
      const double top = highest(z.data() + line * line_stride, pos_stride, pos_count - 2, z.void_fill(), p_lo, p_hi);
      if (std::isnan(top)) continue;  // a crossing there reads a void: it never wins
      // Distances of the nearer and farther crossing, with slack for the
      // rounding of R3's own (t * total) and of these.
      bound[j] = slope_bound(f, top, delta * k_lo * (1 - 1e-12), d_far * (1 + 1e-12));
    }
    float* block = family.block.data() + static_cast<std::size_t>(sector) * family.block_stride();
    float* span = family.span.data() + static_cast<std::size_t>(sector) * family.spans();
    for (int j = 0; j < family.count; ++j) {
      block[j / kBlock] = std::max(block[j / kBlock], bound[j]);
      span[j / kSpan] = std::max(span[j / kSpan], bound[j]);
    }
  }
}

SectorBounds::Lines SectorBounds::lines(double angle, Axis axis) const {
  const int sector = sector_of(angle);
  const Family& family = families_[axis == Axis::kColumns ? 0 : 1];
  return {family.bound.data() + static_cast<std::size_t>(sector) * family.stride(),
          family.block.data() + static_cast<std::size_t>(sector) * family.block_stride(),
          family.span.data() + static_cast<std::size_t>(sector) * family.spans(),
          family.first[sector],
          family.step[sector],
          family.count};
}

}  // namespace horizon::visibility::detail
