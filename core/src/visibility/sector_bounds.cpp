// Sector-and-line bounds of R3's crossing slopes near the eye (see
// sector_bounds.hpp).
#include "sector_bounds.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "horizon/common/parallel.hpp"

namespace horizon::visibility::detail {
namespace {

constexpr float kNone = -std::numeric_limits<float>::infinity();

// The double rounded up to a float.
float round_up(double s) {
  const float f = static_cast<float>(s);
  return f < s ? std::nextafter(f, std::numeric_limits<float>::infinity()) : f;
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

SectorBounds::SectorBounds(const terrain::HeightView& z, const ViewFrame& f, double reach, unsigned threads)
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
      // crossings, and those within `cover` of the eye.
      const double within = std::sqrt(cover * cover - across * across) / mb;
      const double off_lo = delta * q_lo, off_hi = std::min(delta * q_hi, within);
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
      // rounding of R3's own (t * total) and of these; and the terrain with
      // slack for R3's own interpolation.
      const double d_lo = std::sqrt(across * across + off_lo * mb * off_lo * mb) * (1 - 1e-12);
      const double d_hi = std::sqrt(across * across + off_hi * mb * off_hi * mb) * (1 + 1e-12);
      const double above = top + 1e-6 * (1.0 + std::abs(top)) - f.eye;
      float s = std::numeric_limits<float>::infinity();
      if (above < 0 || d_lo > 0)
        s = round_up(above / (above >= 0 ? d_lo : d_hi) - f.curvature * (f.curvature >= 0 ? d_lo : d_hi));
      bound[j] = s;
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
  const int sector = static_cast<int>(angle * (kSectors / 4)) & (kSectors - 1);  // angle >= 0: truncation is floor
  const Family& family = families_[axis == Axis::kColumns ? 0 : 1];
  return {family.bound.data() + static_cast<std::size_t>(sector) * family.stride(),
          family.block.data() + static_cast<std::size_t>(sector) * family.block_stride(),
          family.span.data() + static_cast<std::size_t>(sector) * family.spans(),
          family.first[sector],
          family.step[sector],
          family.count};
}

}  // namespace horizon::visibility::detail
