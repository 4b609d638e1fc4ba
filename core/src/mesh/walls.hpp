// mesh/walls.hpp (private) — the conservative mode's occluders: for each
// group and sector, arcs of terrain around the group that are higher than
// the whole group (see build_walls in walls.cpp for the argument that a
// camera under the bound cannot see any point of the group).
#pragma once

#include "horizon/mesh/prepared_mesh.hpp"

namespace horizon::mesh {

// Fills mesh.group_top, mesh.wall_begin, mesh.wall_radius and
// mesh.wall_slope for every group, after the triangles are in group order.
void build_walls(PreparedMesh& mesh, unsigned threads);

}  // namespace horizon::mesh
