#include "horizon/mesh/cull.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>

#include "common/simd_isa.hpp"
#include "mesh/cull_lanes.hpp"
#include "mesh/walls.hpp"

namespace horizon::mesh {
namespace {

constexpr double kTwoPi = 2 * std::numbers::pi;

// Angle in [0, 2π).
double wrap(double a) {
  a = std::fmod(a, kTwoPi);
  return a < 0 ? a + kTwoPi : a;
}

// OcclusionChain::contains on the flat arrays, with the same arithmetic.
bool hidden_in(const PreparedMesh& mesh, std::size_t g, int sector, const TinVertex& camera) {
  const std::size_t chain = g * static_cast<std::size_t>(mesh.sectors) + static_cast<std::size_t>(sector);
  const std::uint32_t begin = mesh.chain_begin[chain], end = mesh.chain_begin[chain + 1];
  const auto& r = mesh.centre_directions[static_cast<std::size_t>(sector)];
  const double t = r[0] * camera.x + r[1] * camera.y;
  if (begin == end || t < mesh.corner_t[begin]) return false;
  std::uint32_t j = begin;
  while (j + 1 < end && mesh.corner_t[j + 1] <= t) ++j;
  const double at = mesh.corner_t[j], az = mesh.corner_z[j];
  const double height = j + 1 == end ? az + mesh.chain_slope[chain] * (t - at)
                                     : az + (mesh.corner_z[j + 1] - az) * ((t - at) / (mesh.corner_t[j + 1] - at));
  return camera.z <= height;
}

// The group is tested in every sector that a direction from a point of
// its circle to the camera can fall in: those between the two tangents
// from the camera, rotated out of the centre's direction by asin(ρ / d)
// (computed from its sine, no trigonometric call), a hair wider so that
// a direction on a sector's edge takes both sectors.
bool hidden(const PreparedMesh& mesh, std::size_t g, const TinVertex& camera) {
  const int s = mesh.sectors;
  const Circle& circle = mesh.groups[g].circle;
  const double dx = camera.x - circle.x, dy = camera.y - circle.y;
  const double d2 = dx * dx + dy * dy;
  int first = 0, count = s;
  if (d2 > circle.radius * circle.radius) {
    const double d = std::sqrt(d2);
    const double sine = circle.radius / d * (1 + 1e-9) + 1e-12;
    if (sine < 1.0) {
      const double cosine = std::sqrt(1 - sine * sine);
      const double ux = dx / d, uy = dy / d;
      first = mesh.sector_of(ux * cosine + uy * sine, uy * cosine - ux * sine);
      const int last = mesh.sector_of(ux * cosine - uy * sine, uy * cosine + ux * sine);
      count = (last - first + s) % s + 1;
    }
  }
  for (int k = 0; k < count; ++k)
    if (!hidden_in(mesh, g, (first + k) % s, camera)) return false;
  return true;
}

// The conservative test: the camera's sector seen from the centre, the
// farthest of its walls nearer than the camera, and that wall's bound.
bool walled(const PreparedMesh& mesh, std::size_t g, const TinVertex& camera) {
  const Circle& circle = mesh.groups[g].circle;
  const double dx = camera.x - circle.x, dy = camera.y - circle.y;
  const double d2 = dx * dx + dy * dy;
  if (d2 <= circle.radius * circle.radius) return false;
  const std::size_t chain =
      g * static_cast<std::size_t>(mesh.sectors) + static_cast<std::size_t>(mesh.sector_of(dx, dy));
  return behind_wall(circle, mesh.group_top[g], mesh.wall_begin.data(), mesh.wall_radius.data(),
                     mesh.wall_slope.data(), chain, std::sqrt(d2), camera.z);
}

bool culled(const PreparedMesh& mesh, std::size_t g, const TinVertex& camera, CullMode mode) {
  return mode == CullMode::kConservative ? walled(mesh, g, camera) : hidden(mesh, g, camera);
}

#ifdef HORIZON_SIMD_AVX2
// The vector form's per-frame tables: each sector's t of the camera, as
// hidden_in computes it, and the view's bisector and half width for the
// frustum's lanes (cull_lanes.cpp).
void set_frame_tables(const PreparedMesh& mesh, CullFrame& frame, std::vector<double>& sector_t) {
  for (const auto& r : mesh.centre_directions) sector_t.push_back(r[0] * frame.camera.x + r[1] * frame.camera.y);
  frame.sector_t = sector_t.data();
  if (!frame.frustum) return;
  const double half = frame.view_width / 2;
  frame.bx = std::cos(frame.view_from + half);
  frame.by = std::sin(frame.view_from + half);
  frame.cos_half = std::cos(half);
  frame.sin_half = std::sin(half);
  frame.radius_limit = (half > std::numbers::pi / 2 ? frame.sin_half : 1.0) - 1e-8;
}

// The vector form: the hierarchy a level at a time (the top-level groups,
// then the children of those opened, ...), each level's verdicts from the
// lanes; the counts are sums, so they do not depend on the order, and the
// visible leaves are put back in the scalar twin's depth-first order by
// their ranks (GroupColumns).
CullAnswer cull_by_levels(const PreparedMesh& mesh, const CullFrame& frame, simd_isa::Isa isa) {
  constexpr std::size_t kWidth = 16;  // both kernels take whole sixteens
  CullAnswer answer;
  const GroupColumns& columns = mesh.columns;
  std::vector<std::uint32_t> level(mesh.top_level), next;
  std::vector<std::uint8_t> verdict;
  std::vector<std::uint64_t> visible((columns.leaf_order.size() + 63) / 64, 0);
  while (!level.empty()) {
    const std::size_t n = level.size();
    const std::uint32_t last = level.back();
    level.resize((n + kWidth - 1) / kWidth * kWidth, last);  // padding lanes repeat a group
    verdict.resize(level.size());
    if (isa == simd_isa::Isa::kAvx512)
      cull_lanes_avx512(frame, level.data(), level.size(), verdict.data());
    else
      cull_lanes_avx2(frame, level.data(), level.size(), verdict.data());
    next.clear();
    answer.groups_tested += static_cast<std::uint32_t>(n);
    for (std::size_t i = 0; i < n; ++i) {
      const std::uint32_t g = level[i];
      const MeshGroup& group = mesh.groups[g];
      if (verdict[i] != kOpen) {
        ++answer.groups_culled;
        answer.frustum_culled += verdict[i] == kFrustumCulled;
        answer.triangles_culled += group.triangle_count;
      } else if (group.leaf()) {
        const std::uint32_t rank = columns.leaf_rank[g];
        visible[rank / 64] |= std::uint64_t{1} << (rank % 64);
        answer.triangles_visible += group.triangle_count;
      } else {
        next.push_back(static_cast<std::uint32_t>(group.children[0]));
        next.push_back(static_cast<std::uint32_t>(group.children[1]));
      }
    }
    level.swap(next);
  }
  for (std::size_t w = 0; w < visible.size(); ++w)
    for (std::uint64_t bits = visible[w]; bits != 0; bits &= bits - 1)
      answer.visible_groups.push_back(columns.leaf_order[w * 64 + static_cast<std::size_t>(__builtin_ctzll(bits))]);
  answer.triangles_visible += mesh.always_visible_count;
  return answer;
}
#endif

}  // namespace

// The scalar frustum test (cull_lanes.hpp).
bool outside_view(const Circle& circle, const TinVertex& camera, double from, double width) {
  const double dx = circle.x - camera.x, dy = circle.y - camera.y;
  const double d = std::hypot(dx, dy);
  if (d <= circle.radius) return false;
  const double half = std::asin(circle.radius / d);
  const double lo = wrap(std::atan2(dy, dx) - half - from);  // the circle's near edge, from the view's start
  // The circle spans [lo, lo + 2 half] past `from`; it misses the view when
  // that interval falls in the gap (width, 2π).
  return lo > width && lo + 2 * half < kTwoPi;
}

bool group_hidden(const PreparedMesh& mesh, std::size_t g, const TinVertex& camera, CullMode mode) {
  return culled(mesh, g, camera, mode);
}

Result<CullAnswer> cull(const PreparedMesh& mesh, const CullQuery& query) {
  const TinVertex& camera = query.camera;
  if (!std::isfinite(camera.x) || !std::isfinite(camera.y) || !std::isfinite(camera.z))
    return make_error(ErrorCode::kInvalidArgument, "the camera's position must be finite", "camera");
  if (query.azimuth_from.has_value() != query.azimuth_to.has_value())
    return make_error(ErrorCode::kInvalidArgument, "a view needs both azimuth_from and azimuth_to, or neither",
                      "azimuth");
  bool frustum = false;
  double view_from = 0.0, view_width = kTwoPi;
  if (query.azimuth_from) {
    const double from = *query.azimuth_from, to = *query.azimuth_to;
    if (!std::isfinite(from) || !std::isfinite(to))
      return make_error(ErrorCode::kInvalidArgument, "azimuths must be finite degrees", "azimuth");
    double clockwise = std::fmod(to - from, 360.0);
    if (clockwise < 0) clockwise += 360.0;
    if (clockwise == 0.0 && to != from) clockwise = 360.0;
    if (clockwise > 0.0 && clockwise < 360.0) {
      frustum = true;
      // Clockwise from north from..to is counter-clockwise from east
      // (90° − to)..(90° − from).
      view_from = wrap((90.0 - to) * std::numbers::pi / 180.0);
      view_width = clockwise * std::numbers::pi / 180.0;
    }
  }

#ifdef HORIZON_SIMD_AVX2
  const simd_isa::Isa isa = simd_isa::kernel_isa();
  const GroupColumns& columns = mesh.columns;
  if (isa != simd_isa::Isa::kScalar && columns.usable && columns.x.size() == mesh.groups.size() &&
      columns.leaf_rank.size() == mesh.groups.size()) {
    std::vector<double> sector_t;
    CullFrame frame{&mesh, camera, query.mode, nullptr, frustum, view_from, view_width};
    set_frame_tables(mesh, frame, sector_t);
    return cull_by_levels(mesh, frame, isa);
  }
#endif

  // The scalar twin: depth first, one group at a time.
  CullAnswer answer;
  std::vector<std::uint32_t> stack;
  for (auto it = mesh.top_level.rbegin(); it != mesh.top_level.rend(); ++it) stack.push_back(*it);
  while (!stack.empty()) {
    const std::uint32_t g = stack.back();
    stack.pop_back();
    const MeshGroup& group = mesh.groups[g];
    ++answer.groups_tested;
    if (frustum && outside_view(group.circle, camera, view_from, view_width)) {
      ++answer.groups_culled, ++answer.frustum_culled;
      answer.triangles_culled += group.triangle_count;
      continue;
    }
    if (culled(mesh, g, camera, query.mode)) {
      ++answer.groups_culled;
      answer.triangles_culled += group.triangle_count;
      continue;
    }
    if (group.leaf()) {
      answer.visible_groups.push_back(g);
      answer.triangles_visible += group.triangle_count;
      continue;
    }
    stack.push_back(static_cast<std::uint32_t>(group.children[1]));
    stack.push_back(static_cast<std::uint32_t>(group.children[0]));
  }
  answer.triangles_visible += mesh.always_visible_count;
  return answer;
}

std::vector<std::uint8_t> triangle_states(const PreparedMesh& mesh, const CullAnswer& answer) {
  std::vector<std::uint8_t> state(mesh.tin.triangles.size(), kCulled);
  for (std::uint32_t g : answer.visible_groups)
    std::fill_n(state.begin() + mesh.groups[g].first_triangle, mesh.groups[g].triangle_count, kDrawn);
  std::fill_n(state.begin() + mesh.always_visible_first, mesh.always_visible_count, kAlwaysVisible);
  return state;
}

}  // namespace horizon::mesh
