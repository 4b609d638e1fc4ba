// horizon/mesh/prepared_mesh.hpp — a TIN made ready for per-frame culling.
//
// Preparation (Edmondson 2004, §5.2) runs once a mesh:
//   1. every vertex's horizon in s sectors of k subsectors (horizons.hpp);
//   2. crystal groups of triangles and an always-visible rest
//      (crystals.hpp);
//   3. the merge hierarchy: level by level each group is paired with the
//      group it collided with most (ties: the smaller id), unless that one
//      is already paired this level (it is then carried up unchanged); a
//      parent's collisions are its children's less their mutual ones. A
//      group with no collision left is top-level, and so is a parent whose
//      circle covers more than `merge_cutoff` of the mesh's area (seen from
//      above): big groups span many sectors and are rarely hidden;
//   4. every group's walls for the conservative mode (cull.hpp), and its
//      occlusion region in every sector: a leaf's is the
//      intersection of its vertices' (occlusion_region.hpp), a parent's the
//      intersection of its children's, each simplified to at most
//      `max_chain_corners` corners (which only shrinks it). So a parent's
//      region lies inside its children's, and its circle holds theirs: a
//      camera that culls a parent culls each child.
//
// Circles: a leaf's is the smallest circle holding its vertices (CGAL's
// Min_circle_2), widened by a millionth; a parent's the smallest holding
// its children's circles.
//
// The triangles are reordered so that every group, leaf or parent, is one
// run [first_triangle, first_triangle + triangle_count) of tin.triangles:
// the top-level groups' trees depth first, the always-visible triangles
// last. source_triangle maps each back to the input's numbering, so a
// renderer can draw a visible group as one index range.
#pragma once

#include <array>
#include <cmath>
#include <cstdint>
#include <vector>

#include "horizon/common/control.hpp"
#include "horizon/common/error.hpp"
#include "horizon/mesh/crystals.hpp"
#include "horizon/mesh/horizons.hpp"
#include "horizon/mesh/occlusion_region.hpp"
#include "horizon/mesh/tin.hpp"

namespace horizon::mesh {

struct PrepareOptions {
  HorizonOptions horizons;        // s = 16, k = 4 (the thesis's recommendation)
  CrystalOptions crystals;
  double merge_cutoff = 0.25;     // a parent's circle over the mesh's area
  int max_chain_corners = 8;      // per group and sector, >= 2
};

struct Circle {
  double x = 0.0, y = 0.0, radius = 0.0;
};

struct MeshGroup {
  std::uint32_t first_triangle = 0, triangle_count = 0;
  std::int32_t children[2] = {-1, -1};  // both -1 for a leaf
  Circle circle;
  bool leaf() const { return children[0] < 0; }
};

// The groups again, as the cull's vector form reads them (cull.hpp):
// derived from `groups` and `top_level` by prepare_mesh and by a cache
// load, never stored.
struct GroupColumns {
  std::vector<double> x, y, radius;        // groups[g].circle, column by column
  std::vector<std::uint32_t> leaf_order;   // the leaves reached from top_level, depth first (triangle order)
  std::vector<std::uint32_t> leaf_rank;    // leaf g's place in leaf_order (~0u: unreached)
  // False when the vector form cannot run on this mesh: a group reached
  // twice through the hierarchy, or tables past 2^31 entries (its
  // gathers take 32-bit indices). The cull is then scalar.
  bool usable = false;
};

// Wall-clock seconds of each phase. The walls' floor pyramid is built
// on a second thread while the crystals grow, so grouping_seconds covers
// both and wall_seconds the walls' bands alone.
struct PrepareStats {
  double horizon_seconds = 0.0, grouping_seconds = 0.0, hierarchy_seconds = 0.0, wall_seconds = 0.0;
  int orphan_passes = 0;
  std::uint32_t leaf_groups = 0, levels = 0;
};

struct PreparedMesh {
  Tin tin;                                     // triangles in group order
  std::vector<std::uint32_t> source_triangle;  // the input's index of each triangle
  int sectors = 0;
  VertexHorizons horizons;
  std::vector<MeshGroup> groups;               // leaves first, then parents in creation order
  std::vector<std::uint32_t> top_level;        // roots, ascending
  std::uint32_t always_visible_first = 0, always_visible_count = 0;
  std::vector<OcclusionChain> regions;         // group g, sector i at [g * sectors + i]
  // The same regions flattened for culling, chain c = g * sectors + i:
  // corners [chain_begin[c], chain_begin[c + 1]) of corner_t / corner_z,
  // then a ray of slope chain_slope[c]; a group's chains are adjacent.
  std::vector<std::uint32_t> chain_begin;
  std::vector<double> corner_t, corner_z, chain_slope;
  // The conservative mode's walls (src/mesh/walls.cpp): each group's
  // highest vertex, and for group g and sector i (the camera's azimuth
  // from the group's centre) arcs [wall_begin[c], wall_begin[c + 1]),
  // c = g * sectors + i, of ascending radius and slope: a camera at
  // distance D > radius from the centre, lower than
  // group_top + slope · (D − circle radius), sees no point of the group.
  std::vector<double> group_top;
  std::vector<std::uint32_t> wall_begin;
  std::vector<double> wall_radius, wall_slope;
  std::vector<std::array<double, 2>> centre_directions;  // r_i of each sector
  std::vector<double> sector_starts;           // pseudo_angle of each sector's first edge, ascending
  double area = 0.0;                           // the mesh seen from above
  GroupColumns columns;
  PrepareStats stats;

  // The sector holding direction (dx, dy), by pseudo_angle (below).
  int sector_of(double dx, double dy) const;

  const OcclusionChain& region(std::size_t group, int sector) const {
    return regions[group * static_cast<std::size_t>(sectors) + static_cast<std::size_t>(sector)];
  }
};

// A monotone stand-in for the angle of direction (x, y) counter-clockwise
// from +x: 0 at +x, 1 at +y, 2 at -x, 3 at -y, below 4 just under +x. One
// division, no trigonometry; culling finds sectors with it.
inline double pseudo_angle(double x, double y) {
  const double p = x / (std::abs(x) + std::abs(y));
  return y >= 0 ? 1 - p : 3 + p;
}

// Prepares `tin` (it must have passed check_height_field; x, y metres of a
// local frame). kInvalidArgument for options out of range (naming the
// option); kCancelled / kDeadlineExceeded from `control`, checked during
// the horizons and between phases. `control`'s progress rises to 0.8
// through the horizons, then by a step a phase to 1.
Result<PreparedMesh> prepare_mesh(Tin tin, const PrepareOptions& options, const RunControl* control = nullptr);

}  // namespace horizon::mesh
