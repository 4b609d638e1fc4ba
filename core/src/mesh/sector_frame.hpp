// mesh/sector_frame.hpp (private) — a TIN's sectors and its vertices'
// occlusion regions in them, shared by crystal growth, the hierarchy and
// the tests' references.
#pragma once

#include <cmath>
#include <numbers>
#include <optional>
#include <span>
#include <vector>

#include "horizon/mesh/horizons.hpp"
#include "horizon/mesh/occlusion_region.hpp"

namespace horizon::mesh {

class SectorFrame {
 public:
  SectorFrame(std::span<const TinVertex> vertices, const VertexHorizons& horizons)
      : vertices_(vertices), horizons_(horizons) {
    for (int i = 0; i < horizons.sectors; ++i) wedges_.push_back(Wedge::sector(i, horizons.sectors));
  }

  int sectors() const { return horizons_.sectors; }
  const Wedge& wedge(int sector) const { return wedges_[static_cast<std::size_t>(sector)]; }

  // Vertex v's occlusion region in `sector` (empty without a horizon).
  OcclusionChain region(std::uint32_t v, int sector) const {
    const std::uint32_t h = horizons_.at(v, sector);
    if (h == kNoHorizon) return {};
    const Wedge& w = wedge(sector);
    const TinVertex& p = vertices_[v];
    const TinVertex& q = vertices_[h];
    return OcclusionChain::from_horizon({w.t(p), p.z}, {w.t(q), q.z});
  }

  // The same as a ray (occlusion_region.hpp), or nullopt without a horizon.
  std::optional<OcclusionChain::Ray> ray(std::uint32_t v, int sector) const {
    const std::uint32_t h = horizons_.at(v, sector);
    if (h == kNoHorizon) return std::nullopt;
    const Wedge& w = wedge(sector);
    const TinVertex& p = vertices_[v];
    const TinVertex& q = vertices_[h];
    const double tp = w.t(p), tq = w.t(q);
    return OcclusionChain::Ray{{tq, q.z}, (q.z - p.z) / (tq - tp)};
  }

  // Whether `camera` is in the region of v for every sector whose closed
  // wedge around v holds it (one, or two on a shared edge).
  bool occluded(std::uint32_t v, const TinVertex& camera) const {
    const TinVertex& p = vertices_[v];
    if (camera.x == p.x && camera.y == p.y) return false;
    const int s = sectors();
    double angle = std::atan2(camera.y - p.y, camera.x - p.x);
    if (angle < 0) angle += 2 * std::numbers::pi;
    const int guess = static_cast<int>(angle / (2 * std::numbers::pi) * s);
    bool any = false;
    for (int d = -1; d <= 1; ++d) {
      const int i = ((guess + d) % s + s) % s;
      if (!wedge(i).contains(p, camera)) continue;
      any = true;
      const std::uint32_t h = horizons_.at(v, i);
      if (h == kNoHorizon) return false;
      const Wedge& w = wedge(i);
      const TinVertex& q = vertices_[h];
      const double tp = w.t(p), tq = w.t(q), tc = w.t(camera);
      if (tc < tq) return false;
      if (camera.z > p.z + (q.z - p.z) / (tq - tp) * (tc - tp)) return false;
    }
    return any;
  }

 private:
  std::span<const TinVertex> vertices_;
  const VertexHorizons& horizons_;
  std::vector<Wedge> wedges_;
};

}  // namespace horizon::mesh
