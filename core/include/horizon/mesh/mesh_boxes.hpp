// horizon/mesh/mesh_boxes.hpp — object boxes registered with a prepared
// mesh and culled from its structures, with no per-frame work on the
// terrain.
//
// A box (a building, a vehicle's bounds) is treated as the conservative
// mode treats a group (cull.hpp, src/mesh/walls.cpp): at registration,
// the walls of high ground around its circle are found once from the
// mesh's floors; a frame then asks, per box, whether the camera is behind
// one of them, one sector's few bands. The answer is sound: a box reported
// hidden has no point the camera can see over the TIN. Boxes close to the
// terrain's crests are rarely reported hidden (the walls must be higher
// than the box's top all across the sector).
#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include "horizon/common/error.hpp"
#include "horizon/mesh/prepared_mesh.hpp"

namespace horizon::mesh {

struct MeshBox {
  double x_min = 0, y_min = 0, x_max = 0, y_max = 0;  // the mesh's frame (metres)
  double z_min = 0, z_max = 0;                        // absolute metres
};

class RegisteredBoxes {
 public:
  // kInvalidArgument naming the box for a non-finite or reversed one.
  static Result<RegisteredBoxes> make(const PreparedMesh& mesh, std::span<const MeshBox> boxes,
                                      unsigned threads = 0);

  std::size_t size() const { return circles_.size(); }
  // The bytes it holds.
  std::uint64_t memory_bytes() const;

  // Whether no point of box k can be seen from `camera`.
  bool hidden(const PreparedMesh& mesh, std::size_t k, const TinVertex& camera) const;

 private:
  std::vector<Circle> circles_;
  std::vector<double> top_;
  std::vector<std::uint32_t> begin_;
  std::vector<double> radius_, slope_;
};

}  // namespace horizon::mesh
