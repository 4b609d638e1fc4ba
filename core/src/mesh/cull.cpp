#include "horizon/mesh/cull.hpp"

#include <cmath>
#include <numbers>

namespace horizon::mesh {
namespace {

constexpr double kTwoPi = 2 * std::numbers::pi;

// Angle in [0, 2π).
double wrap(double a) {
  a = std::fmod(a, kTwoPi);
  return a < 0 ? a + kTwoPi : a;
}

// The directions from points of `circle` to `camera`: [lo, lo + width],
// or nullopt when the camera is inside the circle.
std::optional<std::pair<double, double>> directions_to(const Circle& circle, const TinVertex& camera) {
  const double dx = camera.x - circle.x, dy = camera.y - circle.y;
  const double d = std::hypot(dx, dy);
  if (d <= circle.radius) return std::nullopt;
  // A hair wider than exact, so a direction on a sector's edge takes both.
  const double half = std::asin(circle.radius / d) + 1e-9;
  return std::pair{std::atan2(dy, dx) - half, 2 * half};
}

bool hidden_in(const PreparedMesh& mesh, std::size_t g, int sector, const TinVertex& camera) {
  const auto& r = mesh.centre_directions[static_cast<std::size_t>(sector)];
  return mesh.region(g, sector).contains(r[0] * camera.x + r[1] * camera.y, camera.z);
}

bool hidden(const PreparedMesh& mesh, std::size_t g, const TinVertex& camera) {
  const int s = mesh.sectors;
  const auto range = directions_to(mesh.groups[g].circle, camera);
  if (!range) {
    for (int i = 0; i < s; ++i)
      if (!hidden_in(mesh, g, i, camera)) return false;
    return true;
  }
  const double width = kTwoPi / s;
  const double lo = wrap(range->first);
  const int first = static_cast<int>(lo / width);
  const int last = static_cast<int>((lo + range->second) / width);
  if (last - first + 1 >= s) {
    for (int i = 0; i < s; ++i)
      if (!hidden_in(mesh, g, i, camera)) return false;
    return true;
  }
  for (int k = first; k <= last; ++k) {
    const int i = k % s;
    if (!hidden_in(mesh, g, i, camera)) return false;
  }
  return true;
}

// Whether the circle lies wholly outside the view [from, from + width]
// (math angles), seen from the camera.
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

}  // namespace

bool group_hidden(const PreparedMesh& mesh, std::size_t g, const TinVertex& camera) {
  return hidden(mesh, g, camera);
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
    if (hidden(mesh, g, camera)) {
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

}  // namespace horizon::mesh
