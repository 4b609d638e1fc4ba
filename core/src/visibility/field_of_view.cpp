// The field of view's validation and its mask over an OHF (field_of_view.hpp).
#include "horizon/visibility/field_of_view.hpp"

#include <cmath>
#include <limits>
#include <numbers>
#include <string>

#include "horizon/common/parallel.hpp"
#include "horizon/visibility/view_frame.hpp"

namespace horizon::visibility {
namespace {

constexpr double kDegrees = 180.0 / std::numbers::pi;

Error bad(const char* field, const std::string& what) {
  return make_error(ErrorCode::kInvalidArgument, std::string(field) + ": " + what, field);
}

// Degrees clockwise from `from` to `to`, in [0, 360).
double clockwise(double from, double to) {
  const double d = std::fmod(to - from, 360.0);
  return d < 0 ? d + 360.0 : d;
}

}  // namespace

bool FieldOfView::limits_azimuth() const {
  return clockwise(azimuth_start, azimuth_end) != 0.0;
}

bool FieldOfView::limits_pitch() const {
  return pitch_min > -90.0 || pitch_max < 90.0;
}

bool FieldOfView::limits() const {
  return limits_azimuth() || limits_pitch() || min_distance > 0.0;
}

Status validate_field_of_view(const FieldOfView& v) {
  for (const auto& [field, value] : {std::pair{"azimuth_start", v.azimuth_start}, {"azimuth_end", v.azimuth_end}})
    if (!std::isfinite(value) || value < 0.0 || value > 360.0)
      return bad(field, "must be degrees in [0, 360] (clockwise from north), got " + number_text(value));
  if (!std::isfinite(v.min_distance) || v.min_distance < 0.0)
    return bad("min_distance", "must be a finite number >= 0 metres, got " + number_text(v.min_distance));
  for (const auto& [field, value] : {std::pair{"pitch_min", v.pitch_min}, {"pitch_max", v.pitch_max}})
    if (!std::isfinite(value) || value < -90.0 || value > 90.0)
      return bad(field, "must be degrees in [-90, 90] (0 level, 90 straight up), got " + number_text(value));
  if (v.pitch_min > v.pitch_max)
    return bad("pitch_min", "must not exceed pitch_max (" + number_text(v.pitch_max) + " degrees), got " +
                                number_text(v.pitch_min));
  return Status::Ok();
}

void mask_field_of_view(const FieldOfView& view, const ViewFrame& f, const terrain::Grid<float>& terrain,
                        terrain::Grid<float>& ohf, unsigned threads) {
  if (!view.limits()) return;
  const bool by_azimuth = view.limits_azimuth(), by_pitch = view.limits_pitch();
  const double span = clockwise(view.azimuth_start, view.azimuth_end);
  const double min2 = view.min_distance * view.min_distance;
  // The pitch band as slopes (tan of the limits); +-90 never binds.
  constexpr double kInf = std::numeric_limits<double>::infinity();
  const double low = view.pitch_min > -90.0 ? std::tan(view.pitch_min / kDegrees) : -kInf;
  const double high = view.pitch_max < 90.0 ? std::tan(view.pitch_max / kDegrees) : kInf;
  const auto in_pitch = [&](double dz, double d) {
    if (d > 0.0) return dz >= low * d && dz <= high * d;
    const double pitch = dz < 0.0 ? -90.0 : dz > 0.0 ? 90.0 : 0.0;  // straight below or above the eye
    return pitch >= view.pitch_min && pitch <= view.pitch_max;
  };
  const terrain::Window& w = f.window;
  parallel_for(static_cast<std::size_t>(ohf.height()), threads, [&](std::size_t r) {
    const int row = static_cast<int>(r);
    float* out = ohf.row(row);
    const float* ground = terrain.row(row);
    const double north = -(row + w.row0 - f.observer_row) * f.metres_per_row;  // rows grow south
    for (int c = 0; c < ohf.width(); ++c) {
      if (std::isnan(out[c])) continue;
      const double east = (c + w.col0 - f.observer_col) * f.metres_per_col;
      const double d2 = east * east + north * north;
      bool inside = d2 >= min2;
      if (inside && by_azimuth && d2 > 0.0) {
        double azimuth = std::atan2(east, north) * kDegrees;
        if (azimuth < 0.0) azimuth += 360.0;
        inside = clockwise(view.azimuth_start, azimuth) <= span;
      }
      if (inside && by_pitch && !std::isnan(ground[c])) {
        const double d = std::sqrt(d2);
        inside = in_pitch(ground[c] - f.curvature * d2 - f.eye, d);
      }
      if (!inside) out[c] = std::numeric_limits<float>::quiet_NaN();
    }
  });
}

}  // namespace horizon::visibility
