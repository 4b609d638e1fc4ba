// horizon/mesh/cull.hpp — which groups of a prepared mesh a camera cannot
// see, per frame.
//
// Edmondson (2004, §5.1.1, §5.3), top-down through the hierarchy. A group
// is tested against the sectors the camera can lie in as seen from any
// point of the group: from its circle (centre m, radius ρ), the
// directions to the camera within asin(ρ / |c − m|) of the centre's (all
// sectors when the camera is inside the circle). The group is culled when,
// in every one of those sectors, the camera's projection onto the sector's
// plane, (r·(x, y), z), lies in the group's occlusion region. A culled
// group's triangles are all skipped; an unculled leaf is drawn; an
// unculled parent is opened. The always-visible triangles are always
// drawn.
//
// Frustum (optional): an azimuth range, degrees clockwise from north (the
// y axis), from `azimuth_from` turning clockwise to `azimuth_to`; a group
// whose circle lies wholly outside it, seen from the camera, is culled
// before its regions are looked at. Omitted, or 360° wide: all around.
//
// Modes.
//   kApproximate: the thesis's test above. occlusion_region.hpp says how
//     it can err: it may cull a triangle that can in fact be seen; the
//     tests and bench_mesh measure how often against the exact sight
//     lines of tin_visibility.hpp.
//   kConservative: never culls a triangle any point of which the camera
//     can see. A group is culled when the camera, in the sector of its
//     azimuth from the group's centre and farther than one of the
//     group's walls there, is below that wall's bound (prepared_mesh.hpp;
//     the proof is at the top of src/mesh/walls.cpp). One sector and a
//     few arcs a group.
//
// Forms. The cull runs in one of two forms that give the same answer bit
// for bit (visible_groups in the same order, every count):
//   - the scalar twin: the hierarchy depth first, a group at a time;
//   - the vector form, where the CPU has AVX2 or AVX-512F: the hierarchy a
//     level at a time (the top-level groups, then the children of the
//     groups left open, ...), each level's groups eight (AVX2) or sixteen
//     (AVX-512) at a time in vectors of doubles, every lane doing the scalar
//     twin's arithmetic in the same order (src/mesh/cull_lanes.hpp): the
//     distance to the circle's centre, the sectors the camera can lie in,
//     the region or wall test as a masked walk of gathers. The frustum's
//     atan2 and asin have no vector twin that rounds alike, so the lanes
//     decide it by a test with no trigonometry where the answer is
//     certain (by 10⁻⁸ rad, far beyond either form's rounding), and run
//     the scalar test on the rest (a circle grazing the view's edge).
//     The visible leaves are put back in depth-first order from their
//     ranks (PreparedMesh::columns).
// The form is chosen at run time: the engine's kernel_isa(), the CPU's
// best capped by isa_limit() for tests and benchmarks
// (src/common/simd_isa.hpp); a mesh whose columns are not usable
// (GroupColumns) is culled scalar.
//
// Cost: O(groups tested · sectors a group spans · corners a chain),
// independent of the mesh's triangles; it allocates the answer's vector
// and a stack (scalar) or two levels of groups (vector) to open. At
// 100 000 vertices, 16/4, about 1 000 groups tested a frame:
// docs/benchmarks.md, "TIN horizons".
#pragma once

#include <cstdint>
#include <optional>
#include <vector>

#include "horizon/mesh/prepared_mesh.hpp"

namespace horizon::mesh {

enum class CullMode { kApproximate, kConservative };

struct CullQuery {
  TinVertex camera;                 // x, y in the mesh's frame, z metres
  std::optional<double> azimuth_from, azimuth_to;  // degrees; both or neither
  CullMode mode = CullMode::kApproximate;
};

struct CullAnswer {
  std::vector<std::uint32_t> visible_groups;  // leaves to draw, in triangle order
  std::uint32_t groups_tested = 0;            // region or frustum tests made
  std::uint32_t groups_culled = 0;            // of those, culled (a culled parent counts once)
  std::uint32_t frustum_culled = 0;           // of those, by the frustum alone
  std::uint64_t triangles_culled = 0;
  std::uint64_t triangles_visible = 0;        // in visible groups and the always-visible set
};

// Whether group g is culled for `camera` in `mode` (no frustum).
bool group_hidden(const PreparedMesh& mesh, std::size_t g, const TinVertex& camera,
                  CullMode mode = CullMode::kApproximate);

// kInvalidArgument for a non-finite camera, or one azimuth without the other.
Result<CullAnswer> cull(const PreparedMesh& mesh, const CullQuery& query);

// What an answer draws, triangle by triangle of mesh.tin: kCulled,
// kDrawn (in a visible group) or kAlwaysVisible.
enum TriangleState : std::uint8_t { kCulled = 0, kDrawn = 1, kAlwaysVisible = 2 };
std::vector<std::uint8_t> triangle_states(const PreparedMesh& mesh, const CullAnswer& answer);

}  // namespace horizon::mesh
