// mesh/cull_lanes.hpp (private) — the cull's vector form (cull.hpp):
// one level of the hierarchy's groups at a time, each lane one group, in
// vectors of four (AVX2) or eight (AVX-512) doubles, two such batches
// side by side (eight or sixteen groups a step).
//
// A lane runs the scalar twin's arithmetic (cull.cpp) operation for
// operation, in the same order and with the same comparisons (NaN
// included), so it reaches the same verdict bit for bit:
//   - the region test (approximate mode): the distance to the circle's
//     centre, the tangent directions and their sectors (pseudo_angle
//     counted against every sector start, which is what upper_bound finds),
//     then a walk over the sectors in which each lane's chain walk is a
//     masked gather loop;
//   - the wall test (conservative mode): the camera's sector from the
//     centre, the arcs walked the same way, the bound;
//   - the frustum: the scalar test needs atan2 and asin, which have no
//     vector twin that rounds alike, so the lanes decide it without them
//     where the answer is certain and hand the rest to the scalar test
//     (cull_lanes.cpp, frustum_*, gives the argument and its margins).
#pragma once

#include <cstddef>
#include <cstdint>

#include "horizon/mesh/cull.hpp"

namespace horizon::mesh {

// What a frame's lanes share: the mesh, the camera, and the tables the
// driver computes once a frame.
struct CullFrame {
  const PreparedMesh* mesh = nullptr;
  TinVertex camera;
  CullMode mode = CullMode::kApproximate;
  const double* sector_t = nullptr;  // r_i · (camera x, y), sector by sector, as hidden_in computes it
  bool frustum = false;
  double view_from = 0.0, view_width = 0.0;  // as outside_view takes them
  // The view's bisector (bx, by), the cosine and sine of its half width,
  // and the largest radius / distance for which a circle can lie wholly
  // outside the view with room to spare.
  double bx = 0.0, by = 0.0, cos_half = 1.0, sin_half = 0.0, radius_limit = 0.0;
};

// Verdicts, one a group.
enum LaneVerdict : std::uint8_t { kOpen = 0, kRegionCulled = 1, kFrustumCulled = 2 };

// Groups ids[0, n) (n a multiple of 16) into verdict[0, n); the caller
// checks that they can run (kernel_isa(), mesh.columns.usable). Defined
// where HORIZON_SIMD_AVX2 is (common/simd_isa.hpp).
void cull_lanes_avx2(const CullFrame& frame, const std::uint32_t* ids, std::size_t n, std::uint8_t* verdict);
void cull_lanes_avx512(const CullFrame& frame, const std::uint32_t* ids, std::size_t n, std::uint8_t* verdict);

// The scalar frustum test (cull.cpp): whether the circle lies wholly
// outside the view [from, from + width] (math angles), seen from the camera.
bool outside_view(const Circle& circle, const TinVertex& camera, double from, double width);

}  // namespace horizon::mesh
