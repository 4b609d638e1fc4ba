#include "horizon/mesh/mesh_boxes.hpp"

#include <cmath>

#include "mesh/walls.hpp"

namespace horizon::mesh {

Result<RegisteredBoxes> RegisteredBoxes::make(const PreparedMesh& mesh, std::span<const MeshBox> boxes,
                                              unsigned threads) {
  RegisteredBoxes out;
  for (std::size_t k = 0; k < boxes.size(); ++k) {
    const MeshBox& b = boxes[k];
    const double v[6] = {b.x_min, b.y_min, b.x_max, b.y_max, b.z_min, b.z_max};
    for (double x : v)
      if (!std::isfinite(x))
        return make_error(ErrorCode::kInvalidArgument, "box " + std::to_string(k) + " has a coordinate that is not finite",
                          "boxes");
    if (b.x_max < b.x_min || b.y_max < b.y_min || b.z_max < b.z_min)
      return make_error(ErrorCode::kInvalidArgument,
                        "box " + std::to_string(k) + " has a maximum below its minimum", "boxes");
    // The footprint's circumscribed circle, a hair wide.
    const double hx = (b.x_max - b.x_min) / 2, hy = (b.y_max - b.y_min) / 2;
    out.circles_.push_back({b.x_min + hx, b.y_min + hy, std::hypot(hx, hy) * (1 + 1e-9) + 1e-6});
    out.top_.push_back(b.z_max);
  }
  Walls walls = build_walls(mesh.tin, mesh.sectors, out.circles_, out.top_, threads);
  out.begin_ = std::move(walls.begin);
  out.radius_ = std::move(walls.radius);
  out.slope_ = std::move(walls.slope);
  return out;
}

bool RegisteredBoxes::hidden(const PreparedMesh& mesh, std::size_t k, const TinVertex& camera) const {
  const Circle& circle = circles_[k];
  const double dx = camera.x - circle.x, dy = camera.y - circle.y;
  const double d2 = dx * dx + dy * dy;
  if (d2 <= circle.radius * circle.radius) return false;
  const std::size_t chain = k * static_cast<std::size_t>(mesh.sectors) + static_cast<std::size_t>(mesh.sector_of(dx, dy));
  return behind_wall(circle, top_[k], begin_.data(), radius_.data(), slope_.data(), chain, std::sqrt(d2), camera.z);
}

std::uint64_t RegisteredBoxes::memory_bytes() const {
  return circles_.capacity() * sizeof(Circle) + begin_.capacity() * sizeof(std::uint32_t) +
         (top_.capacity() + radius_.capacity() + slope_.capacity()) * sizeof(double);
}

}  // namespace horizon::mesh
