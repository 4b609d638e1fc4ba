// horizon/mesh/tin_visibility.hpp — exact lines of sight over a TIN.
//
// The reference the culling modes are measured against: whether the
// straight segment from an eye to a target point stays on or above the
// TIN's surface. Over one triangle the surface is a plane and the sight
// line a line, so the gap between them is linear there: it is enough to
// compare them where the segment's ground track crosses an edge. A
// crossing where the surface is higher than the sight line by more than
// `tolerance` metres hides the target; crossings within a millionth of the
// segment's length of either end are not counted (the target's own
// triangle touches it there). Off the mesh (a hole, past its border)
// nothing is in the way.
//
// Cost: edges are bucketed on a grid of about two edges a cell; a query
// walks the cells under its ground track, O(cells crossed · edges a cell).
#pragma once

#include <cstdint>
#include <optional>
#include <vector>

#include "horizon/mesh/tin.hpp"

namespace horizon::mesh {

class TinVisibility {
 public:
  // `tin` must outlive this and must have passed check_height_field.
  explicit TinVisibility(const Tin& tin);

  // The surface's height at (x, y); nullopt off the mesh.
  std::optional<double> height_at(double x, double y) const;

  // Whether `target` can be seen from `eye`.
  bool visible(const TinVertex& eye, const TinVertex& target, double tolerance = 1e-6) const;

  // The bytes of its index (not of the TIN it refers to).
  std::uint64_t memory_bytes() const;

 private:
  template <class Visit>
  void walk_cells(double x0, double y0, double x1, double y1, Visit&& visit) const;
  std::size_t cell_of(int cx, int cy) const {
    return static_cast<std::size_t>(cy) * static_cast<std::size_t>(nx_) + static_cast<std::size_t>(cx);
  }

  const Tin& tin_;
  std::vector<std::array<std::uint32_t, 2>> edges_;
  double x0_ = 0, y0_ = 0, cell_ = 1;
  int nx_ = 1, ny_ = 1;
  std::vector<std::uint32_t> edge_start_, edge_items_;          // per cell: edges meeting its box
  std::vector<std::uint32_t> triangle_start_, triangle_items_;  // per cell: triangles meeting its box
};

}  // namespace horizon::mesh
