// Private: upper bounds of R3's crossing slopes by direction sector: near
// the eye per grid line, beyond it per band of distance (for the exact
// sweep, exact.cpp).
//
// Around the eye the directions are cut into kSectors narrow sectors, and
// for each sector and each grid line near the eye the table holds an upper
// bound of the slope (terrain - curvature d^2 - eye) / d of any crossing of
// that line, within reach of the eye, by any sight line whose direction lies
// in the sector. In a sector that does not straddle a grid axis a sight
// line's crossing with a given line moves monotonically with its direction,
// and so does its distance: every line of the sector crosses between the
// crossings of the sector's two edges, at a distance between theirs. The
// bound takes the highest terrain between those two points (linear between
// cell centres, so at one of them or at a cell centre between them) over
// the nearer distance. A sector spans at most 8 / kSectors radians, so
// the two points lie within a cell of each other out to 128 cells from the
// eye and within six at 768: the bound is close to the crossings' own
// slopes near the eye, where every sight line passes, and looser further
// out, where fewer do.
//
// The exact sweep looks at a target's near crossings only on the lines
// whose bound in the target's sector reaches the slope to beat: usually a
// few lines around the ridge that hides it, where walking the sight line
// would screen every crossing out to the ridge.
//
// Beyond the reach a coarser bound per sector and band of distance,
// beyond(), lets a sight line skip its far part in one look-up: the tiles
// of 64 cells that meet the sector, each bounded by its highest terrain
// over its nearest distance. From a valley the slope to beat is steep and
// the far terrain stays far below it; where it does not, the sweep falls
// back to its max-pyramid.
//
// Directions are pseudo-angles: a monotone map of the angle onto [0, 4)
// (the "diamond angle"), cheaper than atan2, in grid coordinates. The
// sectors are equal steps of it, with the grid axes (0, 1, 2, 3) among
// their edges.
#pragma once

#include <algorithm>
#include <bit>
#include <cstdint>
#include <limits>
#include <vector>

#ifdef __SSE2__
#include <emmintrin.h>
#endif

#include "crossings.hpp"
#include "horizon/terrain/height_view.hpp"
#include "horizon/terrain/pyramid.hpp"
#include "horizon/visibility/view_frame.hpp"

namespace horizon::visibility::detail {

class SectorBounds {
 public:
  // Bounds for the crossings within `reach` metres of the eye (a little
  // more, so that a sight line that takes its crossings up to `reach` by
  // its own arithmetic stays inside), and beyond it over frame.window, of
  // which `maxima` is a kMax pyramid of `elevation`; threads as
  // parallel_for.
  SectorBounds(const terrain::HeightView& elevation, const terrain::Pyramid& maxima, const ViewFrame& frame,
               double reach, unsigned threads);

  static constexpr int kSectors = 1024;
  static constexpr int kBlock = 16;    // entries per block maximum
  static constexpr int kSpan = 256;    // entries per span maximum (16 blocks)
  static constexpr int kFarTile = 64;  // cells: beyond()'s tiles and bands

  // One sector's bounds for one family of grid lines: bound[j] for line
  // first + step * j, j in [0, count), the lines in order of distance from
  // the eye; -inf where no crossing of the line lies within reach (or all
  // read voids), and in the last block's entries past count. block[b] is
  // the highest of bound[b * kBlock ...] (kBlock entries, fewer in the last
  // block), span[k] the highest of bound[k * kSpan ...]; block has whole
  // spans, -inf past the last block.
  struct Lines {
    const float* bound = nullptr;
    const float* block = nullptr;
    const float* span = nullptr;
    int first = 0, step = 1, count = 0;
  };
  Lines lines(double angle, Axis axis) const;

  double reach() const { return reach_; }  // metres

  // The highest slope any crossing at least reach() and at most `distance`
  // metres from the eye can have on a sight line in the sector of `angle`
  // and in the frame's window: the highest of the slope bounds of the
  // window's tiles of kFarTile cells that meet the sector (their highest
  // terrain with two cells around, over their nearest distance), by bands
  // of kFarTile cells of distance. Coarse, but far from the eye a sight
  // line to a hidden target usually passes high above all of it.
  float beyond(double angle, double distance) const {
    const int band = std::clamp(static_cast<int>((distance - reach_) / band_metres_), 0, bands_ - 1);
    return far_[static_cast<std::size_t>(sector_of(angle)) * bands_ + band];
  }

  // Bit i set when values[i] >= floor, for i in [0, 16).
  static std::uint32_t at_least(const float* values, float floor) {
#ifdef __SSE2__
    const __m128 t = _mm_set1_ps(floor);
    std::uint32_t mask = 0;
    for (int i = 0; i < 4; ++i)
      mask |= std::uint32_t(_mm_movemask_ps(_mm_cmpge_ps(_mm_loadu_ps(values + 4 * i), t))) << (4 * i);
    return mask;
#else
    std::uint32_t mask = 0;
    for (int i = 0; i < 16; ++i) mask |= std::uint32_t(values[i] >= floor) << i;
    return mask;
#endif
  }

  // The pseudo-angle of grid offset (dx, dy) != (0, 0), in [0, 4).
  static double pseudo_angle(double dx, double dy);

  // The smallest float at least s (s a double, not NaN): the table's
  // entries are bounds rounded so, and an entry is below a slope exactly
  // when it is below the slope rounded so.
  static float round_up(double s) {
    const float f = static_cast<float>(s);
    if (!(f < s)) return f;  // also NaN
    if (f == -std::numeric_limits<float>::infinity()) return std::numeric_limits<float>::lowest();
    if (f == 0) return std::numeric_limits<float>::denorm_min();
    const auto bits = std::bit_cast<std::uint32_t>(f);  // the next float up, without libm
    return std::bit_cast<float>(f > 0 ? bits + 1 : bits - 1);
  }

 private:
  struct Family {
    int count = 0;                          // lines per sector
    std::vector<int> first, step;           // per sector
    std::vector<float> bound, block, span;  // per sector, count (blocks, spans) entries each
    int blocks() const { return (count + kBlock - 1) / kBlock; }
    int stride() const { return blocks() * kBlock; }                 // entries per sector: whole blocks
    int block_stride() const { return spans() * (kSpan / kBlock); }  // blocks per sector: whole spans
    int spans() const { return (count + kSpan - 1) / kSpan; }
  };
  void build_sector(const terrain::HeightView& z, const ViewFrame& f, int sector, double cover);
  void build_far(const terrain::Pyramid& maxima, const ViewFrame& f, unsigned threads);
  static int sector_of(double angle) {
    return static_cast<int>(angle * (kSectors / 4)) & (kSectors - 1);  // angle >= 0: truncation is floor
  }

  double reach_ = 0;
  Family families_[2];  // column lines, row lines
  // Beyond the reach: per sector, per band of kFarTile cells of distance
  // from the reach outwards, the highest bound of the tiles whose nearest
  // point lies in that band or a nearer one.
  double band_metres_ = 1;
  int bands_ = 1;
  std::vector<float> far_;
};

}  // namespace horizon::visibility::detail
