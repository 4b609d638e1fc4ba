// horizon/mesh/tin.hpp — a triangulated irregular network (TIN) over a height field.
//
// A TIN is what renderers and simulators draw terrain with: vertices at
// irregular places and triangles between them. Here it must be a height
// field, a function z(x, y): seen from above, its triangles tile their
// union without overlapping, so no two vertices share an (x, y) and no
// vertical line meets the surface twice. Edges join two triangles (inside)
// or one (on the border); the surface may have holes and several pieces.
//
// Frames and units. x and y are in the CRS units of the mesh's source (the
// DEM's CRS for a TIN built from one, the file's own for a mesh read from
// disk); z is metres. Everything is double precision: UTM eastings need
// its 53 bits to keep millimetres.
//
// check_height_field() is the gate every TIN passes before the engine uses
// it; its errors name the element at fault ("triangle 12 (vertices 3, 9,
// 40) overlaps triangle 57 seen from above") so a user can find it in the
// file. Its predicates are CGAL's exact ones, so a nearly flat triangle or
// two triangles that only touch are judged exactly, not within a rounding.
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "horizon/common/error.hpp"

namespace horizon::mesh {

struct TinVertex {
  double x = 0.0, y = 0.0;  // CRS units
  double z = 0.0;           // metres
  friend bool operator==(const TinVertex&, const TinVertex&) = default;
};

using TinTriangle = std::array<std::uint32_t, 3>;  // vertex indices

struct Tin {
  std::vector<TinVertex> vertices;
  std::vector<TinTriangle> triangles;  // counter-clockwise seen from above once checked
};

// Checks that `tin` is a height field and turns every triangle counter-
// clockwise seen from above (x east, y north). Refused (kInvalidArgument,
// the message starting with `label`, naming the element):
//   - no triangle;
//   - a coordinate that is NaN or infinite;
//   - a triangle naming a vertex that does not exist, or one vertex twice;
//   - a vertex no triangle uses;
//   - two vertices at the same (x, y) (any z);
//   - a triangle with no area seen from above (its corners on one line);
//   - an edge shared by more than two triangles (non-manifold);
//   - two triangles that overlap seen from above, whether they share an
//     edge (a fold), a corner, or nothing.
// Cost: O(n log n) in the triangles, the overlap search bucketed on a grid
// of about one triangle per bucket. A mesh whose triangles crowd so that
// the search would test more than 64 million pairs is refused
// (kResourceExhausted) before they are made.
Status check_height_field(Tin& tin, const std::string& label);

// The area of triangle t seen from above, CRS units squared (> 0 for a
// counter-clockwise one).
double signed_area(const Tin& tin, const TinTriangle& t);

}  // namespace horizon::mesh
