// horizon/mesh/horizons.hpp — every vertex's horizon, sector by sector.
//
// After Edmondson, "Hierarchical Occlusion Culling for Arbitrarily-Meshed
// Height Fields" (MSc thesis, Texas A&M, 2004, §4.5), which adapts Stewart's
// all-points horizon ("Fast horizon computation at all points of a terrain
// with visibility and shading applications", TVCG 1998). Only the vertices
// count: an edge crossing a wedge with neither end inside is not seen (the
// thesis's "undersampling"; it errs towards visible).
//
// Sectors. Around a point p the plane is cut into `sectors` closed wedges,
// sector i holding the directions at angles [2πi/s, 2π(i+1)/s] counter-
// clockwise from east (+x). Its centre direction r_i lies at 2π(i + ½)/s.
// A point q lies in p's wedge when A(q) >= A(p) and B(q) <= B(p), with A, B
// the dot products with the normals of the wedge's edges (Wedge below);
// both compare the same doubles wherever they are used, so every form
// agrees on membership, edges included.
//
// The horizon of p in a wedge is the point q of the wedge whose projection
// onto the wedge's vertical centre plane, (T, z) with T = r·(x, y), rises
// most steeply from p's: the largest (z_q - z_p) / (T_q - T_p) (T_q > T_p
// throughout a wedge narrower than π). Ties go to the smaller T, then the
// smaller vertex index. The slopes are compared exactly (CGAL's orientation
// of the three projected points), so the tree sweep and the brute force
// below give the same vertex, not merely a close one.
//
// Subsectors. With `subsectors` = k > 1 each sector is cut into k equal
// wedges, each traced on its own; the sector keeps the subsector horizon
// that is lowest, by its slope in its own subsector's plane (the thesis:
// "for occlusion we really want the minimum"). A sector any of whose
// subsectors has no horizon has none.
//
// Cost. compute_horizons sweeps each of the s·k wedges once over a static
// binary tree of upper convex hulls (Stewart): points in order of
// decreasing A, each querying the hulls of the tree nodes left of its leaf
// (leaves ordered by B) for the steepest tangent, then inserted into the
// hulls on its path. It runs node by node instead of point by point: a
// node's left child's points are inserted and its right child's points
// query, in processing order, so each node's hull is built and read in one
// go and the tree's levels are the passes of a bottom-up merge sort of the
// leaves by processing rank (the lowest levels block by block, in cache;
// runs of 4 leaves at the bottom pair by pair). Every pair still meets at
// its one node under the same exact, total order, so the answer does not
// depend on that schedule.
//
// O(n log n · log h) a wedge, h the hulls' sizes, plus the moves of
// insertions into a hull kept as an array. Terrain's hulls are short
// (about 5 points at a query, Rainier at 100 000 vertices, 16/4), so the
// cost is per operation: about log2 n of them per point and wedge, each an
// insertion or a query. The hull is stored by decreasing t, the order the
// points mostly arrive in, so most insertions are a step of Andrew's
// monotone chain at its end; a query tests every edge of a short hull at
// once, or binary-searches a long one, without branching on the filtered
// determinant, and is repeated with exact branching when a sign was
// unproven. Sectors run in parallel (threads), a sector and its opposite
// together when s is even: their edges are the same lines, so k + 1 radix
// sorts of the vertices along them serve 2k wedges. Memory: about 270
// bytes a vertex a thread at k = 4 (the sorts, two 48-byte leaf arrays, a
// hull buffer), plus the answer's 4·s bytes a vertex. docs/benchmarks.md
// ("TIN horizons") has the timings. brute_force_horizons is the
// O(s·k·n²) reference with the same predicate and tie rule, for tests.
#pragma once

#include <cstdint>
#include <limits>
#include <span>
#include <vector>

#include "horizon/common/control.hpp"
#include "horizon/common/error.hpp"
#include "horizon/mesh/tin.hpp"

namespace horizon::mesh {

// A closed wedge of directions [lo, hi] (radians counter-clockwise from +x,
// hi - lo < π), and the three directions its tests use.
struct Wedge {
  double ax = 0, ay = 0;  // normal of the edge at lo: (-sin lo, cos lo)
  double bx = 0, by = 0;  // normal of the edge at hi: (-sin hi, cos hi)
  double rx = 0, ry = 0;  // the centre direction: (cos mid, sin mid)

  // Sector `index` of `count` (count >= 3), or subsector `sub` of `subs` of
  // it. Its edges are edges m and m + 1 of the count·subs edges around; the
  // last closes on edge 0's normal, and with an even number of edges edge
  // m + half is exactly edge m's negation, so neighbours and opposites
  // compare the very same doubles.
  static Wedge sector(int index, int count, int sub = 0, int subs = 1);

  double a(const TinVertex& v) const { return ax * v.x + ay * v.y; }
  double b(const TinVertex& v) const { return bx * v.x + by * v.y; }
  double t(const TinVertex& v) const { return rx * v.x + ry * v.y; }
  // Whether q lies in p's wedge (q = p does not).
  bool contains(const TinVertex& p, const TinVertex& q) const {
    return a(q) >= a(p) && b(q) <= b(p) && (q.x != p.x || q.y != p.y);
  }
};

struct HorizonOptions {
  int sectors = 16;    // s, 3..256
  int subsectors = 4;  // k, 1..64; s·k <= 1024
  unsigned threads = 0;  // 0: every core
};

inline constexpr std::uint32_t kNoHorizon = std::numeric_limits<std::uint32_t>::max();

// Each vertex's horizon vertex in each sector: vertex v's in sector i at
// [v * sectors + i], kNoHorizon where its wedge holds no vertex.
struct VertexHorizons {
  int sectors = 0;
  std::vector<std::uint32_t> horizon;

  std::uint32_t at(std::size_t vertex, int sector) const {
    return horizon[vertex * static_cast<std::size_t>(sectors) + static_cast<std::size_t>(sector)];
  }
};

// The horizons of `points` (vertices of a height field: distinct (x, y),
// finite; x, y in metres of a local frame, z metres). kInvalidArgument for
// options out of range; kCancelled / kDeadlineExceeded from `control`.
Result<VertexHorizons> compute_horizons(std::span<const TinVertex> points, const HorizonOptions& options,
                                        const RunControl* control = nullptr);

// The same answer by testing every pair: O(s·k·n²), for tests.
Result<VertexHorizons> brute_force_horizons(std::span<const TinVertex> points, const HorizonOptions& options);

}  // namespace horizon::mesh
