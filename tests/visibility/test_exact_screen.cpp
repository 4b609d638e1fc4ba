// The exact sweep's crossing screen (core/src/visibility/exact_screen.hpp):
// it must never drop a crossing whose R3 slope (crossings.hpp, the samples
// R3 itself takes) beats the slope asked, must drop the crossings far below
// it, and its AVX2 and AVX-512 kernels must give the scalar kernel's mask
// bit for bit, for runs of every length (partial groups of four and eight
// included), along columns and rows, with voids transparent and filled.
#include <gtest/gtest.h>

#include <bit>
#include <cmath>
#include <cstdint>
#include <limits>
#include <random>
#include <vector>

#include "crossings.hpp"
#include "exact_screen.hpp"
#include "horizon/terrain/height_view.hpp"
#include "vector_forms.hpp"

namespace horizon::visibility::detail {
namespace {

constexpr int kWidth = 131, kHeight = 117;
constexpr double kEye = 1520.25, kCurvature = 6.7e-8, kMetresPerCol = 30.0, kMetresPerRow = 27.5;

std::vector<float> rough_terrain(std::mt19937& rng) {
  std::uniform_real_distribution<float> height(-30.0f, 3000.0f), unit(0.0f, 1.0f);
  std::vector<float> z(static_cast<std::size_t>(kWidth) * kHeight);
  for (float& v : z) v = unit(rng) < 0.04f ? std::numeric_limits<float>::quiet_NaN() : height(rng);
  return z;
}

// A sight line from a fractional eye to a cell centre, and its screen for
// one family of lines (screen_family, as exact.cpp sets it up).
struct Segment {
  double c0, r0, c1, r1, total;
  int first, last;  // the family's lines strictly between the ends, inside the grid
  CrossingScreen screen;
};

Segment segment(const terrain::HeightView& z, Axis axis, double c0, double r0, int c1, int r1) {
  Segment s{c0, r0, double(c1), double(r1), 0, 0, 0, {}};
  s.total = std::hypot((c1 - c0) * kMetresPerCol, (r1 - r0) * kMetresPerRow);
  const ScreenedFamily family = screen_family(z, axis, c0, r0, c1, r1, s.total, kEye, kCurvature);
  s.first = family.first;
  s.last = family.last;
  s.screen = family.screen;
  return s;
}

// R3's slope of the crossing with each line first..last (NaN: a void).
std::vector<double> r3_slopes(const terrain::HeightView& z, Axis axis, const Segment& s) {
  std::vector<double> slopes;
  for (int line = s.first; line <= s.last; ++line)
    for_each_crossing_on(axis, z, s.c0, s.r0, s.c1, s.r1, line, line, [&](double t, double, double, double terrain) {
      const double d = t * s.total;
      slopes.push_back((terrain - kCurvature * d * d - kEye) / d);
    });
  return slopes;
}

// Screens lines first..last in runs of up to 64, as exact.cpp does.
std::vector<bool> screened(const Segment& s, double slope, bool scalar) {
  std::vector<bool> bits;
  for (int line = s.first; line <= s.last; line += 64) {
    const int count = std::min(64, s.last - line + 1);
    const std::uint64_t mask =
        scalar ? screen_crossings_scalar(s.screen, line, count, slope) : screen_crossings(s.screen, line, count, slope);
    for (int i = 0; i < count; ++i) bits.push_back(((mask >> i) & 1) != 0);
  }
  return bits;
}

// Random sight lines over the grid, each with its R3 slopes.
template <class Check>
void for_random_segments(std::mt19937& rng, const terrain::HeightView& z, Check check) {
  std::uniform_real_distribution<double> eye_col(-0.5, kWidth - 0.5), eye_row(-0.5, kHeight - 0.5);
  std::uniform_int_distribution<int> col(0, kWidth - 1), row(0, kHeight - 1);
  for (int i = 0; i < 300; ++i) {
    const double c0 = eye_col(rng), r0 = eye_row(rng);
    const int c1 = col(rng), r1 = row(rng);
    for (const Axis axis : {Axis::kColumns, Axis::kRows}) {
      const Segment s = segment(z, axis, c0, r0, c1, r1);
      if (s.first > s.last) continue;
      const std::vector<double> slopes = r3_slopes(z, axis, s);
      ASSERT_EQ(slopes.size(), static_cast<std::size_t>(s.last - s.first + 1));
      check(s, slopes);
    }
  }
}

// crossings.hpp's integer floor and ceiling, which every crossing's
// position goes through, against std::floor / std::ceil.
TEST(Crossings, IntegerFloorAndCeilingAreTheLibrarys) {
  std::vector<double> xs = {0.0,      -0.0,      0.5, -0.5, 1.0,          -1.0,
                            2.999999, -2.999999, 1e9, -1e9, 2147483646.5, -2147483647.5};
  for (int k = -5000; k <= 5000; ++k)
    for (const double x : {k / 8.0, k * 0.37})
      xs.insert(xs.end(), {x, std::nextafter(x, -1e300), std::nextafter(x, 1e300)});
  for (const double x : xs) {
    EXPECT_EQ(floor_to_int(x), static_cast<int>(std::floor(x))) << x;
    EXPECT_EQ(ceil_to_int(x), static_cast<int>(std::ceil(x))) << x;
  }
}

TEST(ExactScreen, NeverDropsACrossingThatBeatsTheSlopeAndDropsThoseFarBelow) {
  std::mt19937 rng(2026);
  const std::vector<float> cells = rough_terrain(rng);
  for (const float fill : {std::numeric_limits<float>::quiet_NaN(), 250.0f}) {
    const terrain::HeightView z = terrain::HeightView(cells.data(), kWidth, kHeight, kWidth).with_void_fill(fill);
    std::size_t beaten = 0, dropped = 0;
    for_random_segments(rng, z, [&](const Segment& s, const std::vector<double>& slopes) {
      // Slopes just below each crossing's own (it beats them), and random ones.
      std::vector<double> asked = {-1e3, 1e3};
      for (const double v : slopes)
        if (std::isfinite(v)) asked.insert(asked.end(), {v - 1e-12 * (1 + std::abs(v)), std::nextafter(v, -1e9)});
      for (const double slope : asked) {
        const std::vector<bool> bits = screened(s, slope, false);
        for (std::size_t i = 0; i < slopes.size(); ++i) {
          if (std::isnan(slopes[i]) || slopes[i] > slope) {
            ++beaten;
            EXPECT_TRUE(bits[i]) << "line " << s.first + int(i) << " slope " << slopes[i] << " beats " << slope;
          }
          // Far below: at least a metre under the needed height at 10 km.
          if (slopes[i] < slope - 1e-4) dropped += !bits[i];
        }
        if (slope == 1e3) {  // only voids and crossings right by the eye reach it
          for (std::size_t i = 0; i < slopes.size(); ++i)
            if (slopes[i] < 900) {
              EXPECT_FALSE(bits[i]) << "line " << s.first + int(i) << " slope " << slopes[i];
            }
        }
      }
    });
    EXPECT_GT(beaten, 1000u);
    EXPECT_GT(dropped, 10000u);
  }
}

TEST(ExactScreen, EveryFormGivesTheScalarMask) {
  if (sweep::simd::cpu_isa() == sweep::simd::Isa::kScalar) GTEST_SKIP() << "this CPU runs the scalar kernels only";
  std::mt19937 rng(7);
  const std::vector<float> cells = rough_terrain(rng);
  for (const float fill : {std::numeric_limits<float>::quiet_NaN(), -12.5f}) {
    const terrain::HeightView z = terrain::HeightView(cells.data(), kWidth, kHeight, kWidth).with_void_fill(fill);
    const int forms = sweep::for_each_vector_form([&] {
      std::mt19937 local(11);
      std::uniform_real_distribution<double> jitter(-0.02, 0.02);
      for_random_segments(local, z, [&](const Segment& s, const std::vector<double>& slopes) {
        for (const double v : slopes) {
          const double slope = std::isfinite(v) ? v + jitter(local) : 0.1;
          // Every start within the run and every length, so that partial
          // vectors and their masks are exercised.
          for (int first = s.first; first <= s.last; first += 3) {
            const int count = std::min(64, s.last - first + 1);
            ASSERT_EQ(screen_crossings(s.screen, first, count, slope),
                      screen_crossings_scalar(s.screen, first, count, slope))
                << "lines " << first << " + " << count << ", slope " << slope;
          }
        }
      });
    });
    EXPECT_GE(forms, 1);
  }
}

}  // namespace
}  // namespace horizon::visibility::detail
