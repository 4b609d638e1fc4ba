// Every kernel reads a terrain::HeightView: a window of a larger grid (row
// stride wider than the window) must give the bits a copy of that window
// gives, and voids read through a fill height must give the bits of a grid
// whose voids were filled in memory, for fast, conservative, exact and R3,
// under every vector form of the sweep's kernels.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <limits>
#include <string>

#include "horizon/terrain/height_view.hpp"
#include "horizon/visibility/exact.hpp"
#include "horizon/visibility/r3.hpp"
#include "horizon/visibility/radial_sweep.hpp"
#include "horizon/visibility/view_frame.hpp"
#include "horizon/visibility/viewshed.hpp"
#include "simd.hpp"
#include "visibility_test_util.hpp"

namespace horizon::visibility {
namespace {

using testing::eye_at;
using testing::grid_dem;

constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();
constexpr float kFill = 95.0f;  // above most of the terrain: a filled void hides what lies behind it

// Ridges and valleys, with void patches (one right beside the eye) where a
// filled void decides what is seen.
terrain::Dem voided_hills(int width, int height) {
  terrain::Dem dem =
      grid_dem(width, height, [](int c, int r) { return 40.0 * std::sin(c * 0.21) * std::cos(r * 0.17) + 0.4 * c; });
  for (int r = 0; r < height; ++r)
    for (int c = 0; c < width; ++c)
      if ((c / 7 + r / 5) % 6 == 0 || (c % 13 == 4 && r % 11 == 3)) dem.elevation.at(c, r) = kNaN;
  return dem;
}

enum class Kernel { kFast, kConservative, kExact, kR3 };

const char* name(Kernel k) {
  switch (k) {
    case Kernel::kFast:
      return "fast";
    case Kernel::kConservative:
      return "conservative";
    case Kernel::kExact:
      return "exact";
    default:
      return "r3";
  }
}

terrain::Grid<float> run(Kernel kernel, const terrain::HeightView& z, const ViewFrame& f) {
  terrain::Grid<float> ohf;
  WorkStats stats;
  Status s = Status::Ok();
  switch (kernel) {
    case Kernel::kFast:
      s = radial_ohf(z, f, {}, 2, nullptr, ohf, stats);
      break;
    case Kernel::kConservative:
      s = radial_ohf(z, f, {}, 2, nullptr, ohf, stats, RadialBound::kLowerBound);
      break;
    case Kernel::kExact:
      s = exact_ohf(z, f, {}, 2, nullptr, ohf, stats);
      break;
    case Kernel::kR3:
      s = r3_ohf(z, f, 2, nullptr, ohf, stats);
      break;
  }
  EXPECT_TRUE(s.ok()) << name(kernel);
  return ohf;
}

void expect_same_bits(const terrain::Grid<float>& a, const terrain::Grid<float>& b, const std::string& what) {
  ASSERT_EQ(a.width(), b.width()) << what;
  ASSERT_EQ(a.height(), b.height()) << what;
  EXPECT_EQ(std::memcmp(a.data(), b.data(), a.size() * sizeof(float)), 0) << what;
  std::size_t answered = 0;
  for (const float v : a.values()) answered += std::isnan(v) ? 0 : 1;
  EXPECT_GT(answered, a.size() / 2) << what;  // a real answer, not an empty window
}

template <class Check>
void for_each_isa(Check check) {
  struct Restore {
    ~Restore() { sweep::simd::isa_limit() = sweep::simd::Isa::kAvx512; }
  } restore;
  for (const auto isa : {sweep::simd::Isa::kScalar, sweep::simd::Isa::kAvx2, sweep::simd::Isa::kAvx512}) {
    if (sweep::simd::cpu_isa() < isa) continue;
    sweep::simd::isa_limit() = isa;
    SCOPED_TRACE("kernels capped at ISA " + std::to_string(static_cast<int>(isa)));
    check();
  }
}

TEST(HeightViews, AFilledViewGivesTheBitsOfAGridFilledInMemory) {
  const terrain::Dem dem = voided_hills(83, 71);
  terrain::Dem filled = dem;
  for (float& v : filled.elevation.values()) v = std::isnan(v) ? kFill : v;
  const auto eye = eye_at(filled, 40, 33, 2.0);  // void patches all around, one 2 cells away
  ViewshedOptions options;
  options.max_distance = 600.0;  // 60 cells: a window inside the grid on two sides
  auto frame = make_view_frame(filled, eye, options);
  ASSERT_TRUE(frame.ok());
  const terrain::HeightView view = terrain::HeightView(dem.elevation).with_void_fill(kFill);
  for_each_isa([&] {
    for (const Kernel k : {Kernel::kFast, Kernel::kConservative, Kernel::kExact, Kernel::kR3}) {
      const terrain::Grid<float> from_view = run(k, view, *frame);
      const terrain::Grid<float> from_copy = run(k, filled.elevation, *frame);
      expect_same_bits(from_view, from_copy, name(k));
      // And the fill matters here: transparent voids give another answer.
      const terrain::Grid<float> transparent = run(k, dem.elevation, *frame);
      EXPECT_NE(std::memcmp(transparent.data(), from_copy.data(), from_copy.size() * sizeof(float)), 0) << name(k);
    }
  });
  EXPECT_TRUE(std::isnan(dem.elevation.at(35, 35)));  // the grid read is never written
}

TEST(HeightViews, AWindowOfALargerGridGivesTheBitsOfItsCopy) {
  const terrain::Dem big = voided_hills(97, 88);
  const terrain::Window w{9, 13, 9 + 70, 13 + 64};
  terrain::Dem crop = grid_dem(w.width(), w.height(), [](int, int) { return 0.0; });
  for (int r = 0; r < w.height(); ++r)
    for (int c = 0; c < w.width(); ++c) crop.elevation.at(c, r) = big.elevation.at(w.col0 + c, w.row0 + r);
  const auto eye = eye_at(crop, 31.0, 27.0, 3.0);
  auto frame = make_view_frame(crop, eye, {});
  ASSERT_TRUE(frame.ok());
  const terrain::HeightView window = terrain::HeightView(big.elevation).sub(w);
  ASSERT_EQ(window.stride(), 97);
  for_each_isa([&] {
    for (const Kernel k : {Kernel::kFast, Kernel::kConservative, Kernel::kExact, Kernel::kR3}) {
      expect_same_bits(run(k, window, *frame), run(k, crop.elevation, *frame), name(k));
      expect_same_bits(run(k, window.with_void_fill(kFill), *frame),
                       run(k, terrain::copy_cells(window.with_void_fill(kFill)), *frame),
                       std::string(name(k)) + ", filled");
    }
  });
}

TEST(HeightViews, ComputeViewshedFillsAsItReadsAndKeepsTheFilledTerrain) {
  const terrain::Dem dem = voided_hills(83, 71);
  terrain::Dem filled = dem;
  for (float& v : filled.elevation.values()) v = std::isnan(v) ? kFill : v;
  const auto eye = eye_at(filled, 40, 33, 2.0);
  for (const Algorithm a : {Algorithm::kRadial, Algorithm::kConservative, Algorithm::kExact}) {
    ViewshedOptions fill;
    fill.algorithm = a;
    fill.max_distance = 450.0;
    fill.nodata = NodataPolicy::kFill;
    fill.nodata_fill_height = kFill;
    ViewshedOptions transparent = fill;
    transparent.nodata = NodataPolicy::kTransparent;
    auto by_view = compute_viewshed(dem, eye, fill);
    auto by_copy = compute_viewshed(filled, eye, transparent);
    ASSERT_TRUE(by_view.ok() && by_copy.ok());
    expect_same_bits(by_view->ohf, by_copy->ohf, std::string(algorithm_name(a)));
    expect_same_bits(by_view->terrain, by_copy->terrain, std::string(algorithm_name(a)) + " terrain");
  }
}

}  // namespace
}  // namespace horizon::visibility
