// mesh/walls.hpp (private) — the conservative mode's occluders: for each
// group and sector, arcs of terrain around the group that are higher than
// the whole group (see build_walls in walls.cpp for the argument that a
// camera under the bound cannot see any point of the group).
#pragma once

#include <cmath>
#include <memory>
#include <span>
#include <vector>

#include "horizon/mesh/prepared_mesh.hpp"

namespace horizon::mesh {

// Walls of items (groups, boxes) as flat arrays: item k, sector i has
// bands [begin[c], begin[c + 1]), c = k * sectors + i, of ascending
// radius and slope; top[k] is the item's highest point.
struct Walls {
  std::vector<double> top;
  std::vector<std::uint32_t> begin;
  std::vector<double> radius, slope;
};

// The walls of items inside `circles`, none higher than `tops`, over `tin`.
// The lower bounds of a TIN's surface the walls are built from (the floor
// pyramid of walls.cpp). It depends only on the vertices and on the set of
// triangles, not their order, so it can be built while the groups are
// still growing.
class FloorPyramid;
std::shared_ptr<const FloorPyramid> build_floors(const Tin& tin);

Walls build_walls(const FloorPyramid& floors, int sectors, std::span<const Circle> circles, std::span<const double> tops,
                  unsigned threads);
Walls build_walls(const Tin& tin, int sectors, std::span<const Circle> circles, std::span<const double> tops,
                  unsigned threads);

// Whether the camera is behind one of item k's walls: `sector` is the
// camera's azimuth from the circle's centre (sector_of), `d` its distance.
inline bool behind_wall(const Circle& circle, double top, const std::uint32_t* begin, const double* radius,
                        const double* slope, std::size_t chain, double d, double camera_z) {
  if (d <= circle.radius) return false;
  std::uint32_t best = begin[chain];
  const std::uint32_t end = begin[chain + 1];
  if (best == end || radius[best] >= d) return false;
  while (best + 1 < end && radius[best + 1] < d) ++best;
  return camera_z < top + slope[best] * (d - circle.radius);
}

// Fills mesh.group_top, mesh.wall_begin, mesh.wall_radius and
// mesh.wall_slope for every group, after the triangles are in group order.
void build_walls(PreparedMesh& mesh, unsigned threads);
void build_walls(PreparedMesh& mesh, const FloorPyramid& floors, unsigned threads);

}  // namespace horizon::mesh
