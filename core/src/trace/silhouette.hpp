// Private to core/trace: the CPU kernels of the silhouette-partitioning
// trace (trace.hpp) for one block of kBlock adjacent screen columns of one
// sub-frustum — the silhouette map, the packed tree over it, and the
// descent. trace.cpp runs the blocks in parallel; the tests hold the tree
// to brute-force maxima and every SIMD form to the scalar one.
//
// Layouts (floats, lanes = screen columns, kBlock of them, contiguous so
// that a vector of columns is one load):
//   map:   [line][lane]                      slope of crossing `line`
//   pairs: level p = 1..levels at offset(p): [node][channel R,G,B,A][lane]
// Pair level 1's nodes cover four lines each; level p's cover four nodes
// of level p - 1; the top level has one node, the root. Quarters past the
// last line read as kNoCrossing.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include "../visibility/simd.hpp"
#include "frustum.hpp"

namespace horizon::trace::detail {

using visibility::sweep::simd::Isa;

inline constexpr int kBlock = 32;

// The lanes of one block, for one family of lines: per lane, where its
// crossings are (each lane's family may differ: the secondary family's side).
struct BlockLines {
  int lanes = 0;  // columns in use, <= kBlock; the rest read kNoCrossing
  alignas(64) int first[kBlock] = {};
  alignas(64) int step[kBlock] = {};
  alignas(64) int count[kBlock] = {};  // 0 for unused lanes
  alignas(64) float t0[kBlock] = {};
  alignas(64) float pos_per_t[kBlock] = {};
  alignas(64) float dist_per_t[kBlock] = {};
  alignas(64) float near[kBlock] = {};
  // Shared by the lanes: the family's shape.
  float eye_along = 0.0f;
  int pos_count = 0;
  std::ptrdiff_t line_stride = 0, pos_stride = 1;
};

// The shape of the packed tree over `lines` leaves.
struct TreeShape {
  int lines = 0;
  int levels = 0;                   // pair levels; 0 when there are no lines
  std::vector<int> nodes;           // nodes[p], p = 1..levels (nodes[0] = lines)
  std::vector<std::size_t> offset;  // offset[p] in floats into `pairs`
  std::size_t floats = 0;           // the pairs' size
};
TreeShape tree_shape(int lines);

// map[k][lane] = crossing_slope(...) for k < lines (kNoCrossing past a
// lane's count, and on unused lanes).
void build_map(Isa isa, const float* data, const BlockLines& b, const FrameGeometry& g, int lines, float* map);

// The pair levels from the map: R = max(q0), G = max(q2), B = max(q0, q1),
// A = max(q0..q3), the q's the four children of a node.
void build_tree(const float* map, const TreeShape& shape, float* pairs);

// For each lane, the first line whose slope reaches slope[lane] (-1: sky,
// the ray above the root's A), found by the descent through the pair
// levels: `levels` texel reads a lane.
void descend(Isa isa, const float* pairs, const TreeShape& shape, const float* slope, std::int32_t* leaf);

// One family's hits (the paper's rows-only trace): for each lane < lanes
// with leaf >= 0, the ground distance where its ray (slope) meets the chord
// between crossing leaf - 1 and crossing leaf (chord_hit), and the grid line
// of the hit; +inf and -1 for sky (leaf -1).
void resolve_rows(Isa isa, const float* map, const BlockLines& b, const float* slope, const std::int32_t* leaf,
                  int lanes, float* distance, std::int32_t* line);

}  // namespace horizon::trace::detail
