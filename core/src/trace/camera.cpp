// The camera's per-column rays (horizon/trace/camera.hpp).
#include "horizon/trace/camera.hpp"

#include <cmath>
#include <numbers>
#include <string>

#include "horizon/visibility/view_frame.hpp"

namespace horizon::trace {
namespace {

constexpr double kDegree = std::numbers::pi / 180.0;

Status bad(const char* field, const std::string& what) {
  return make_error(ErrorCode::kInvalidArgument, std::string("camera ") + field + ": " + what, field);
}

}  // namespace

const char* projection_name(Projection projection) {
  return projection == Projection::kCylindrical ? "cylindrical" : "perspective";
}

Status validate_camera(const CameraSpec& spec) {
  if (!std::isfinite(spec.yaw)) return bad("yaw", "must be a finite number of degrees, got " + number_text(spec.yaw));
  if (!std::isfinite(spec.pitch) || spec.pitch < -80.0 || spec.pitch > 80.0)
    return bad("pitch", "must lie in [-80, 80] degrees, got " + number_text(spec.pitch));
  const double max_fov = spec.projection == Projection::kCylindrical ? 360.0 : 170.0;
  if (!std::isfinite(spec.hfov) || !(spec.hfov > 0.0) || spec.hfov > max_fov)
    return bad("hfov", std::string("must lie in (0, ") + number_text(max_fov) + "] degrees for a " +
                           projection_name(spec.projection) + " camera, got " + number_text(spec.hfov));
  if (spec.width < 1 || spec.width > kMaxSide)
    return bad("width", "must lie in [1, " + std::to_string(kMaxSide) + "] pixels, got " + std::to_string(spec.width));
  if (spec.height < 1 || spec.height > kMaxSide)
    return bad("height",
               "must lie in [1, " + std::to_string(kMaxSide) + "] pixels, got " + std::to_string(spec.height));
  return Status::Ok();
}

double Camera::near_distance(int x, double near) const {
  if (spec.projection == Projection::kCylindrical) return near;
  return near * focal_col[static_cast<std::size_t>(x)] / focal;
}

double Camera::slope(int x, int j) const {
  const double y_up = spec.height - j - 0.5;
  return (y_up - cy) / focal_col[static_cast<std::size_t>(x)];
}

Result<Camera> make_camera(const CameraSpec& spec, const geodesy::GridPoint& eye, double metres_per_col,
                           double metres_per_row) {
  HORIZON_RETURN_IF_ERROR(validate_camera(spec));
  Camera c;
  c.spec = spec;
  c.eye = eye;
  c.metres_per_col = metres_per_col;
  c.metres_per_row = metres_per_row;
  const double half_fov = spec.hfov * kDegree / 2.0;
  c.cx = spec.width / 2.0;
  c.focal = spec.projection == Projection::kCylindrical ? spec.width / (2.0 * half_fov)
                                                        : (spec.width / 2.0) / std::tan(half_fov);
  // The centre pixel (y_up = height / 2) looks `pitch` up: a shifted principal point.
  c.cy = spec.height / 2.0 - c.focal * std::tan(spec.pitch * kDegree);
  c.azimuth.resize(static_cast<std::size_t>(spec.width));
  c.focal_col.resize(static_cast<std::size_t>(spec.width));
  const double yaw = spec.yaw * kDegree;
  for (int x = 0; x < spec.width; ++x) {
    const double dx = x + 0.5 - c.cx;
    if (spec.projection == Projection::kCylindrical) {
      c.azimuth[static_cast<std::size_t>(x)] = yaw + dx / c.focal;
      c.focal_col[static_cast<std::size_t>(x)] = c.focal;
    } else {
      c.azimuth[static_cast<std::size_t>(x)] = yaw + std::atan2(dx, c.focal);
      c.focal_col[static_cast<std::size_t>(x)] = std::hypot(c.focal, dx);
    }
  }
  return c;
}

Result<Camera> resolve_camera(const terrain::Dem& dem, const CameraSpec& spec) {
  HORIZON_RETURN_IF_ERROR(validate_camera(spec));
  auto eye = geodesy::resolve_point(dem, spec.position, "camera");
  if (!eye.ok()) return eye.error();
  auto cell = visibility::metric_cell_size(dem.georef, eye->x, eye->y, dem.source);
  if (!cell.ok()) return cell.error();
  return make_camera(spec, *eye, cell->per_col, cell->per_row);
}

}  // namespace horizon::trace
