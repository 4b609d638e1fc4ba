// horizon/mesh/occlusion_region.hpp — where a camera cannot see a vertex,
// an element or a group of them, sector by sector.
//
// After Edmondson (2004, §4.6, §5.1.1). Take vertex p, sector i and p's
// horizon h there (horizons.hpp), both projected onto the sector's centre
// plane: (T, z) with T = r_i·(x, y). A camera c lying in p's wedge i whose
// projection (T_c, z_c) is past the horizon (T_c >= T_h) and below the ray
// from p through h (z_c <= z_p + m (T_c − T_p), m the ray's slope) is
// taken to be unable to see p: the terrain at h is in the way. That set of
// (T, z) is p's occlusion region in sector i. By the symmetry of sight
// lines the same test says that p cannot see c.
//
// A set of vertices (a triangle, a group) is hidden from c when each of
// them is: its region is the intersection of theirs. Each vertex region
// is a half-plane under a line, cut at T >= T_h; their intersection is
// the region under a concave chain, { T >= T_0, z <= min_j line_j(T) },
// kept as its corners (T_0, z_0) … (T_m, z_m) plus the slope of the final
// ray. A vertex with no horizon in a sector (a wedge reaching off the
// mesh) has an empty region there, and so has every set holding it.
//
// Approximation. The thesis's test is not exact: the projection onto the
// centre plane replaces true distance, a sector keeps one horizon for all
// its directions, and only vertices are judged. tin_visibility.hpp gives
// the exact answer the tests and `horizon bench` measure it against.
//
// Chains are short in practice; `simplify` bounds one to a number of
// corners by replacing runs of corners with chords. A chord of a concave
// chain lies below it, so a simplified region is inside the true one: a
// camera it holds is held by the unsimplified region too.
#pragma once

#include <optional>
#include <span>
#include <vector>

namespace horizon::mesh {

struct ChainPoint {
  double t = 0.0, z = 0.0;
  friend bool operator==(const ChainPoint&, const ChainPoint&) = default;
};

class OcclusionChain {
 public:
  // The empty region (nothing is hidden).
  OcclusionChain() = default;

  // A vertex's region: p = (T_p, z_p), h = (T_h, z_h) in the sector's
  // plane, T_h > T_p.
  static OcclusionChain from_horizon(ChainPoint p, ChainPoint h);

  // A chain from its parts as corners() and final_slope() gave them
  // (a file read back): corners ascending in t. nullopt otherwise.
  static std::optional<OcclusionChain> from_parts(std::vector<ChainPoint> corners, double final_slope);

  bool empty() const { return corners_.empty(); }
  const std::vector<ChainPoint>& corners() const { return corners_; }
  double final_slope() const { return final_slope_; }

  // Whether (t, z) lies in the region, its boundary included.
  bool contains(double t, double z) const;

  // The region's upper bound at t >= corners().front().t.
  double height_at(double t) const;

  // The intersection of two regions (empty if either is).
  static OcclusionChain intersect(const OcclusionChain& a, const OcclusionChain& b);

  // The intersection of many vertex regions at once, each given as its
  // horizon h and the slope of its ray (from_horizon's), in O(m log m):
  // past the farthest horizon, the lower envelope of the rays' lines.
  // Empty for no rays. The same region as folding intersect over them.
  struct Ray {
    ChainPoint h;
    double slope;
  };
  static OcclusionChain lower_envelope(std::span<const Ray> rays);

  // The same region shrunk to at most `max_corners` (>= 2) corners by
  // chords; the first corner and the final ray are kept.
  OcclusionChain simplified(std::size_t max_corners) const;

  friend bool operator==(const OcclusionChain&, const OcclusionChain&) = default;

 private:
  std::vector<ChainPoint> corners_;  // increasing t
  double final_slope_ = 0.0;
};

}  // namespace horizon::mesh
