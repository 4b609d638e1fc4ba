// The lower bound's cell kernels (core/src/visibility/resample_r3.hpp): the
// AVX2 and AVX-512 kernels must give the scalar kernel's bits, cell for
// cell, for candidates on u and v lines, lines the sight line does not
// cross, lines off the grid and none, with voids transparent and filled,
// along rows and columns, for batches of every length; and every value must
// be at most R3's OHF of the cell (its samples are some of R3's).
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <limits>
#include <random>
#include <vector>

#include "crossings.hpp"
#include "resample_r3.hpp"
#include "vector_forms.hpp"

namespace horizon::visibility::sweep {
namespace {

constexpr int kWidth = 97, kHeight = 83;

std::vector<float> rough_terrain(std::mt19937& rng) {
  std::uniform_real_distribution<float> height(-30.0f, 3000.0f), unit(0.0f, 1.0f);
  std::vector<float> z(static_cast<std::size_t>(kWidth) * kHeight);
  for (float& v : z) v = unit(rng) < 0.04f ? std::numeric_limits<float>::quiet_NaN() : height(rng);
  return z;
}

ViewFrame frame_at(double col, double row) {
  ViewFrame f;
  f.observer_col = col;
  f.observer_row = row;
  f.eye = 1501.75;
  f.metres_per_col = 30.0;
  f.metres_per_row = 27.5;
  f.curvature = 6.7e-8;
  f.dem_width = kWidth;
  f.dem_height = kHeight;
  return f;
}

// Random lines of cells with random candidates, run through `kernel`.
struct Case {
  R3CellLine line;
  std::vector<int> v;
  std::vector<double> total;
  std::vector<R3Line> first, second;
};

Case random_case(std::mt19937& rng, const terrain::HeightView& z, const ViewFrame& f, bool rows) {
  const int line_count = rows ? kHeight : kWidth, v_count = rows ? kWidth : kHeight;
  std::uniform_int_distribution<int> line(0, line_count - 1), v(0, v_count - 1), count(1, 64), any(-3, 100);
  Case c;
  c.line = {&z, &f, rows, line(rng), std::uniform_int_distribution<int>(-1, line_count - 1)(rng)};
  const int n = count(rng);
  for (int i = 0; i < n; ++i) {
    int j = v(rng);
    const double col = rows ? j : c.line.line, row = rows ? c.line.line : j;
    if (col == f.observer_col && row == f.observer_row) j = (j + 1) % v_count;  // never the eye's own cell
    c.v.push_back(j);
    c.total.push_back(f.distance(rows ? j : c.line.line, rows ? c.line.line : j));
    // Candidates: mostly lines near the cell, some anywhere (off the grid
    // too, or not crossed), some none.
    for (auto* list : {&c.first, &c.second}) {
      const bool u = rng() % 2 == 0;
      const int near = u ? c.line.line - static_cast<int>(rng() % 5) : j + static_cast<int>(rng() % 7) - 3;
      const int pick = rng() % 4;
      list->push_back(pick == 0 ? R3Line{} : pick == 1 ? R3Line{any(rng), u} : R3Line{near, u});
    }
  }
  return c;
}

std::vector<float> run(const Case& c, bool scalar) {
  std::vector<float> out(c.v.size(), std::nanf(""));
  const int n = static_cast<int>(c.v.size());
  if (scalar)
    resample_r3_cells_scalar(c.line, n, c.v.data(), c.total.data(), c.first.data(), c.second.data(), out.data());
  else
    resample_r3_cells(c.line, n, c.v.data(), c.total.data(), c.first.data(), c.second.data(), out.data());
  return out;
}

TEST(ResampleR3, EveryFormGivesTheScalarBits) {
  if (simd::cpu_isa() == simd::Isa::kScalar) GTEST_SKIP() << "this CPU runs the scalar kernels only";
  std::mt19937 rng(31);
  const std::vector<float> cells = rough_terrain(rng);
  std::size_t finite = 0;
  for (const float fill : {std::numeric_limits<float>::quiet_NaN(), 123.5f}) {
    const terrain::HeightView z = terrain::HeightView(cells.data(), kWidth, kHeight, kWidth).with_void_fill(fill);
    // Eyes on a cell centre, on grid lines, off them, near a corner, on the
    // last row and column (crossings at the grid's far edge, clamped there)
    // and in the outer half-cell margin (positions below 0, clamped).
    for (const auto& [col, row] : {std::pair{40.0, 30.0},
                                   {40.5, 30.25},
                                   {12.000001, 70.99999},
                                   {0.2, 0.3},
                                   {40.0, kHeight - 1.0},
                                   {kWidth - 1.0, 20.0},
                                   {40.0, -0.3},
                                   {-0.4, 50.0}}) {
      const ViewFrame f = frame_at(col, row);
      for (const bool rows : {true, false}) {
        for (int trial = 0; trial < 200; ++trial) {
          const Case c = random_case(rng, z, f, rows);
          const std::vector<float> scalar = run(c, true);
          for (const float v : scalar) finite += std::isfinite(v);
          const int forms = for_each_vector_form([&] {
            const std::vector<float> vector = run(c, false);
            for (std::size_t i = 0; i < scalar.size(); ++i)
              ASSERT_EQ(std::memcmp(&scalar[i], &vector[i], sizeof(float)), 0)
                  << "cell " << i << " of " << scalar.size() << ": " << scalar[i] << " vs " << vector[i];
          });
          ASSERT_GE(forms, 1);
        }
      }
    }
  }
  EXPECT_GT(finite, 10000u);  // most cells found a sample
}

TEST(ResampleR3, NeverAboveRThreesOhf) {
  std::mt19937 rng(8);
  const std::vector<float> cells = rough_terrain(rng);
  const terrain::HeightView z(cells.data(), kWidth, kHeight, kWidth);
  const ViewFrame f = frame_at(47.3, 38.6);
  std::size_t compared = 0;
  for (const bool rows : {true, false}) {
    for (int trial = 0; trial < 300; ++trial) {
      const Case c = random_case(rng, z, f, rows);
      const std::vector<float> out = run(c, false);
      for (std::size_t i = 0; i < out.size(); ++i) {
        const double tc = rows ? c.v[i] : c.line.line, tr = rows ? c.line.line : c.v[i];
        double best = -std::numeric_limits<double>::infinity();
        detail::for_each_crossing(z, f.observer_col, f.observer_row, tc, tr, [&](double t, double, double, double h) {
          const double s = detail::r3_slope(f, c.total[i], t, h);
          if (s > best) best = s;
        });
        if (best == -std::numeric_limits<double>::infinity()) {
          EXPECT_EQ(out[i], -std::numeric_limits<float>::infinity());
          continue;
        }
        EXPECT_LE(out[i], static_cast<float>(detail::r3_ohf_value(f, c.total[i], best))) << "cell " << i;
        ++compared;
      }
    }
  }
  EXPECT_GT(compared, 5000u);
}

}  // namespace
}  // namespace horizon::visibility::sweep
