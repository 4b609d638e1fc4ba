// The field of view (visibility/field_of_view.hpp): each limit checked as an
// exact property against the same run without it (a mask on the answer,
// nothing else), on every algorithm, and on hand-computed cells.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "horizon/geodesy/crs.hpp"
#include "horizon/visibility/field_of_view.hpp"
#include "horizon/visibility/view_frame.hpp"
#include "visibility_test_util.hpp"

namespace horizon {
namespace {

using testing::eye_at;
using testing::grid_dem;
using visibility::Algorithm;
using visibility::FieldOfView;
using visibility::ViewshedOptions;
using visibility::ViewshedResult;

constexpr double kDegrees = 180.0 / std::numbers::pi;

terrain::Dem hills() {
  return grid_dem(81, 67, [](int c, int r) { return 40.0 * std::sin(c * 0.21) * std::cos(r * 0.17) + 0.8 * r; });
}

// Azimuth of window cell (c, r) from the eye, degrees clockwise from north.
double azimuth(const visibility::ViewFrame& f, int c, int r) {
  const double east = (c + f.window.col0 - f.observer_col) * f.metres_per_col;
  const double north = -(r + f.window.row0 - f.observer_row) * f.metres_per_row;
  const double a = std::atan2(east, north) * kDegrees;
  return a < 0 ? a + 360 : a;
}

double distance(const visibility::ViewFrame& f, int c, int r) {
  return f.distance(c + f.window.col0, r + f.window.row0);
}

double pitch(const ViewshedResult& v, int c, int r) {
  const visibility::ViewFrame& f = v.frame;
  const double d = distance(f, c, r);
  return std::atan2(v.terrain.at(c, r) - f.curvature * d * d - f.eye, d) * kDegrees;
}

// Runs the DEM with and without `view`; calls check(c, r, full, limited) on every cell.
template <class Check>
void compare(const FieldOfView& view, Algorithm algorithm, Check&& check, double max_distance = 600) {
  const terrain::Dem dem = hills();
  const auto eye = eye_at(dem, 40.3, 30.6, 5.0);
  ViewshedOptions full;
  full.algorithm = algorithm;
  full.max_distance = max_distance;
  ViewshedOptions limited = full;
  limited.field_of_view = view;
  auto a = visibility::compute_viewshed(dem, eye, full);
  auto b = visibility::compute_viewshed(dem, eye, limited);
  ASSERT_TRUE(a.ok() && b.ok());
  ASSERT_EQ(a->frame.window, b->frame.window);
  // Each result says which view masked it (its picture says so).
  EXPECT_FALSE(a->field_of_view.limits());
  EXPECT_EQ(b->field_of_view.azimuth_start, view.azimuth_start);
  EXPECT_EQ(b->field_of_view.azimuth_end, view.azimuth_end);
  EXPECT_EQ(b->field_of_view.min_distance, view.min_distance);
  EXPECT_EQ(b->field_of_view.pitch_min, view.pitch_min);
  EXPECT_EQ(b->field_of_view.pitch_max, view.pitch_max);
  for (int r = 0; r < a->ohf.height(); ++r)
    for (int c = 0; c < a->ohf.width(); ++c) check(c, r, *a, *b);
}

const Algorithm kAlgorithms[] = {Algorithm::kRadial, Algorithm::kConservative, Algorithm::kExact, Algorithm::kR3};

TEST(FieldOfView, AWedgeThroughNorthKeepsExactlyItsAzimuths) {
  FieldOfView view;
  view.azimuth_start = 300;
  view.azimuth_end = 60;
  for (Algorithm alg : kAlgorithms) {
    int kept = 0, masked = 0;
    compare(view, alg, [&](int c, int r, const ViewshedResult& full, const ViewshedResult& limited) {
      const float a = full.ohf.at(c, r), b = limited.ohf.at(c, r);
      if (std::isnan(a)) {
        EXPECT_TRUE(std::isnan(b));
        return;
      }
      const double az = azimuth(full.frame, c, r);
      if (az >= 300 || az <= 60) {
        EXPECT_EQ(a, b) << c << "," << r;  // inside: the answer is untouched, bit for bit
        ++kept;
      } else {
        EXPECT_TRUE(std::isnan(b)) << "azimuth " << az << " at " << c << "," << r;
        ++masked;
      }
    });
    EXPECT_GT(kept, 1000) << visibility::algorithm_name(alg);
    EXPECT_GT(masked, 2 * kept) << visibility::algorithm_name(alg);  // 240 of 360 degrees
  }
}

TEST(FieldOfView, EqualOrFullTurnAzimuthsLimitNothing) {
  for (auto [start, end] : {std::pair{0.0, 0.0}, {0.0, 360.0}, {135.0, 135.0}, {360.0, 0.0}}) {
    FieldOfView view;
    view.azimuth_start = start;
    view.azimuth_end = end;
    EXPECT_FALSE(view.limits()) << start << "," << end;
    compare(view, Algorithm::kRadial, [](int c, int r, const ViewshedResult& a, const ViewshedResult& b) {
      const float x = a.ohf.at(c, r), y = b.ohf.at(c, r);
      EXPECT_TRUE(x == y || (std::isnan(x) && std::isnan(y)));
    });
  }
}

TEST(FieldOfView, CellsNearerThanTheMinimumAreOutOfRangeAndStillHide) {
  FieldOfView view;
  view.min_distance = 150;
  for (Algorithm alg : kAlgorithms) {
    int near = 0;
    compare(view, alg, [&](int c, int r, const ViewshedResult& full, const ViewshedResult& limited) {
      const float a = full.ohf.at(c, r), b = limited.ohf.at(c, r);
      if (distance(full.frame, c, r) < 150) {
        EXPECT_TRUE(std::isnan(b));
        near += !std::isnan(a);
      } else {
        // Beyond it, the answer is the full run's: the near terrain still blocks.
        EXPECT_TRUE(a == b || (std::isnan(a) && std::isnan(b))) << c << "," << r;
      }
    });
    EXPECT_GT(near, 600) << visibility::algorithm_name(alg);
  }
}

TEST(FieldOfView, CellsWhosePitchIsOutsideTheBandAreOutOfRange) {
  FieldOfView view;
  view.pitch_min = -8;
  view.pitch_max = 2;
  int below = 0, above = 0, inside = 0;
  compare(view, Algorithm::kExact, [&](int c, int r, const ViewshedResult& full, const ViewshedResult& limited) {
    const float a = full.ohf.at(c, r), b = limited.ohf.at(c, r);
    if (std::isnan(a)) return;
    const double p = pitch(full, c, r);
    if (distance(full.frame, c, r) == 0) return;
    if (p < -8 - 1e-9 || p > 2 + 1e-9) {
      EXPECT_TRUE(std::isnan(b)) << "pitch " << p;
      (p < 0 ? below : above) += 1;
    } else if (p > -8 + 1e-9 && p < 2 - 1e-9) {
      EXPECT_EQ(a, b);
      ++inside;
    }
  });
  EXPECT_GT(below, 100);
  EXPECT_GT(above, 100);
  EXPECT_GT(inside, 100);
}

TEST(FieldOfView, PitchIsTakenAfterCurvature) {
  // A flat plain 100 m below the eye, a band down to -0.5 degrees. On a flat
  // earth the ground enters it at d tan(0.5 deg) = 100 m, d = 11 459 m; with
  // the curvature the ground at d sinks d^2 / 2R more (coefficient 1), so it
  // enters only where 100 + d^2 / 2R <= d tan(0.5 deg): 12 969 to 98 356 m.
  const terrain::Dem plain = grid_dem(801, 3, [](int, int) { return 0.0; }, 100.0);
  const auto eye = eye_at(plain, 0, 1, 100.0);
  ViewshedOptions o;
  o.algorithm = Algorithm::kR3;
  o.curvature_coefficient = 1.0;
  o.field_of_view.pitch_min = -0.5;
  auto v = visibility::compute_viewshed(plain, eye, o);
  ASSERT_TRUE(v.ok());
  const double tan_half = std::tan(0.5 / kDegrees);
  for (int c = 1; c < 801; ++c) {
    const double d = c * 100.0;
    EXPECT_EQ(!std::isnan(v->ohf.at(c, 1)), 100.0 + d * d / (2 * geodesy::kEarthRadiusMetres) <= d * tan_half)
        << "d " << d;
  }
  EXPECT_TRUE(std::isnan(v->ohf.at(120, 1)));  // 12 km: in the band on a flat earth, below it here
  EXPECT_FALSE(std::isnan(v->ohf.at(130, 1)));
  o.curvature_coefficient = 0.0;
  auto flat = visibility::compute_viewshed(plain, eye, o);
  ASSERT_TRUE(flat.ok());
  EXPECT_TRUE(std::isnan(flat->ohf.at(114, 1)));
  EXPECT_FALSE(std::isnan(flat->ohf.at(115, 1)));
  EXPECT_FALSE(std::isnan(flat->ohf.at(120, 1)));
}

TEST(FieldOfView, ValidationNamesTheField) {
  const auto field = [](FieldOfView v) {
    ViewshedOptions o;
    o.max_distance = 1000;
    o.field_of_view = v;
    return visibility::validate_options(o).error().field;
  };
  FieldOfView v;
  v.azimuth_start = -1;
  EXPECT_EQ(field(v), "azimuth_start");
  v = {};
  v.azimuth_end = 361;
  EXPECT_EQ(field(v), "azimuth_end");
  v = {};
  v.min_distance = -5;
  EXPECT_EQ(field(v), "min_distance");
  v = {};
  v.min_distance = 1000;  // not below max_distance
  EXPECT_EQ(field(v), "min_distance");
  v = {};
  v.pitch_max = 91;
  EXPECT_EQ(field(v), "pitch_max");
  v = {};
  v.pitch_min = 10;
  v.pitch_max = 5;
  EXPECT_EQ(field(v), "pitch_min");
  v = {};
  v.pitch_min = std::nan("");
  EXPECT_EQ(field(v), "pitch_min");
}

}  // namespace
}  // namespace horizon
