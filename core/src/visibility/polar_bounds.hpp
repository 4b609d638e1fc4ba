// Private: upper bounds of R3's crossing slopes near the eye, by distance ring
// and direction (for the exact sweep, exact.cpp).
//
// R3's crossings (crossings.hpp) lie on the grid segments joining
// neighbouring cell centres. Around the eye those segments are cut into
// pieces, and each piece gets an upper bound of the slope
// (terrain - curvature d^2 - eye) / d of any crossing on it: its terrain is
// at most the higher of its two ends (linear interpolation), and its
// distance lies between the nearest and the farthest of its points. A sight
// line in direction a meets a piece only when a lies within the piece's
// angular span, so the highest bound over the pieces of distance ring k
// whose span covers a bounds every crossing of every sight line in
// direction a at a distance in ring k.
//
// Rings widen 1.5x outwards ([0, 8 L), [8 L, 12 L), [12 L, 18 L), ... with
// L the larger cell side); each has enough directions for about one cell of
// arc at its outer edge. Near the eye, where the max-pyramid's square tiles
// span wide angles and so bound little, this bound follows the sight line:
// the exact sweep skips a whole ring of a sight line when the ring's bound
// in its direction is below the slope to beat.
//
// Directions are pseudo-angles: a monotone map of the angle onto [0, 4)
// (the "diamond angle"), cheaper than atan2 and the same for the pieces and
// the sight lines, in grid coordinates.
#pragma once

#include <vector>

#include "horizon/terrain/grid.hpp"
#include "horizon/terrain/height_view.hpp"
#include "horizon/visibility/view_frame.hpp"

namespace horizon::visibility::detail {

class PolarBounds {
 public:
  // Bounds for the crossings within `reach` metres of the eye (rounded up to
  // a whole ring); threads as parallel_for.
  PolarBounds(const terrain::HeightView& elevation, const ViewFrame& frame, double reach, unsigned threads);

  int rings() const { return static_cast<int>(outer_.size()); }
  double inner(int ring) const { return ring == 0 ? 0.0 : outer_[ring - 1]; }  // metres
  double outer(int ring) const { return outer_[ring]; }                         // metres
  // The highest slope any crossing at a distance in [inner, outer] of
  // `ring` can have on a sight line in direction `angle` (pseudo_angle());
  // -inf when there is none (voids, or outside the DEM).
  float bound(int ring, double angle) const;
  // The highest bound(k, angle) of `ring` and every ring outside it.
  float beyond(int ring, double angle) const;

  // The pseudo-angle of grid offset (dx, dy) != (0, 0), in [0, 4).
  static double pseudo_angle(double dx, double dy);

 private:
  void gather_beyond();                                 // beyond_ from bound_
  std::size_t direction(int ring, double angle) const;  // the ring's direction bin holding `angle`

  std::vector<double> outer_;               // per ring, metres
  std::vector<int> bins_;                   // per ring: directions, a power of two
  std::vector<std::vector<float>> bound_;   // per ring, per direction
  std::vector<std::vector<float>> beyond_;  // per ring, per direction: the max of bound_ over it and outer rings
};

}  // namespace horizon::visibility::detail
