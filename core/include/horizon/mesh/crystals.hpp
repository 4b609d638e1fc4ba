// horizon/mesh/crystals.hpp — visibility-aware groups of triangles.
//
// Edmondson (2004, §5.2.3, §6.3.1), the "crystal method". Seeds fall on
// random faces; each crystal grows breadth-first across shared edges, one
// face a turn, crystals taking turns, and stops where a face is not seen
// from its reference vertex: the crystal's lowest vertex so far, so
// crystals grow away from ridges rather than across them. "Not seen" is
// the occlusion-region test (occlusion_region.hpp) with the face's vertex
// as the camera: a face is not claimed if any of its vertices lies in the
// reference vertex's region for the sector it is in. A face another
// crystal holds is not claimed either; the meeting is counted as a
// collision between the two.
//
// Faces no crystal reached are orphans; the next pass scatters seeds on
// them, as many as `seeds` times the orphans' share of the faces (one at
// least). Passes stop after `max_orphan_passes`, when `max_groups` is
// reached, or when a pass grows no crystal of `min_group_size` faces.
// Then each crystal smaller than `min_group_size` is merged with the small
// crystal it collided with most (if any); what is still small, and every
// orphan left, joins the always-visible set (ridges and peaks, mostly).
//
// Determinism: seeds come from std::mt19937_64 seeded with `random_seed`,
// faces are drawn by index, and every tie is broken by the smaller id, so
// the same mesh, horizons and options give the same groups.
#pragma once

#include <cstdint>
#include <vector>

#include "horizon/mesh/horizons.hpp"
#include "horizon/mesh/tin.hpp"

namespace horizon::mesh {

struct CrystalOptions {
  int seeds = 500;             // pass 0 (the thesis: 100 on 10^4 vertices, 500 on 10^5)
  int min_group_size = 30;     // faces
  int max_orphan_passes = 10;
  int max_groups = 1000;
  std::uint64_t random_seed = 1;
};

struct Crystals {
  std::vector<std::vector<std::uint32_t>> groups;  // faces of each group, ascending
  std::vector<std::uint32_t> always_visible;       // faces in no group, ascending
  // collisions[g] = (other group, count), ascending by other group
  std::vector<std::vector<std::pair<std::uint32_t, std::uint32_t>>> collisions;
  int orphan_passes = 0;       // passes after the first
};

// Whether `camera` lies in the occlusion region of vertex `vertex` for the
// sector of `horizons` that holds it: the thesis's "cannot be seen from".
bool occluded_from_vertex(std::span<const TinVertex> vertices, const VertexHorizons& horizons, std::uint32_t vertex,
                          const TinVertex& camera);

// Groups the faces of `tin` (checked) given its vertices' horizons.
Crystals grow_crystals(const Tin& tin, const VertexHorizons& horizons, const CrystalOptions& options);

}  // namespace horizon::mesh
