// The radial sweep's cell kernels (core/src/visibility/resample_cells.hpp):
// the AVX2 and AVX-512 kernels must give the scalar kernel's bits, cell for
// cell, on every kind of candidate (the line before, u lines, v lines, none),
// with voids, along rows and along columns, for neighbouring cells with the
// same candidates or not, and for ranges of every length (partial groups of
// sixteen and eight included).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <random>
#include <vector>

#include "horizon/visibility/viewshed.hpp"  // min_target_height_at, the codes
#include "resample_cells.hpp"
#include "vector_forms.hpp"

namespace horizon::visibility::sweep {
namespace {

constexpr int kWidth = 97, kHeight = 83;

std::vector<float> rough_terrain(std::mt19937& rng) {
  std::uniform_real_distribution<float> height(-30.0f, 3000.0f);
  std::uniform_real_distribution<float> unit(0.0f, 1.0f);
  std::vector<float> z(static_cast<std::size_t>(kWidth) * kHeight);
  for (float& v : z) v = unit(rng) < 0.03f ? std::numeric_limits<float>::quiet_NaN() : height(rng);
  return z;
}

// Runs both kernels on lines of one sector (u along rows or columns) with
// random candidate codes, and compares outputs and counts bit for bit.
void compare_kernels(bool rows, std::mt19937& rng) {
  const std::vector<float> z = rough_terrain(rng);
  Sector s;
  s.z = z.data();
  s.z_line = rows ? kWidth : 1;
  s.z_v = rows ? 1 : kWidth;
  s.v_count = rows ? kWidth : kHeight;
  s.line_count = rows ? kHeight : kWidth;
  s.line0 = 3;
  s.dir = 1;
  s.k0 = 0.6;
  s.eye_v = 40.3;
  s.lines = s.line_count - s.line0;

  std::vector<float> inv_step(s.lines), inv_dv(s.v_count);
  for (int n = 0; n < s.lines; ++n) inv_step[n] = static_cast<float>(1.0 / (s.k0 + n));
  for (int c = 0; c < s.v_count; ++c) inv_dv[c] = static_cast<float>(1.0 / (c - s.eye_v));
  const double eye = 2950.37, curvature = 6.7e-8, metres_u = 30.0, metres_v = 27.5;
  const float eye_hi = static_cast<float>(eye), eye_lo = static_cast<float>(eye - eye_hi);
  const int ray_half = 61;

  for (const int n : {0, 1, 2, 7, 30, 31, 45, s.lines - 1}) {
    const double k = s.k0 + n;
    const CellLine cl{&s,
                      inv_step.data(),
                      inv_dv.data(),
                      eye_hi,
                      eye_lo,
                      static_cast<float>(s.eye_v),
                      0.0f,
                      static_cast<float>(s.v_count - 1),
                      static_cast<float>(s.k0),
                      static_cast<float>(k),
                      static_cast<float>(curvature),
                      static_cast<float>(metres_u * metres_u),
                      static_cast<float>(metres_v * metres_v),
                      s.v_count - 2,
                      static_cast<int>(s.z_v),
                      s.line0,
                      s.dir,
                      s.line_count,
                      s.z_line};
    // Codes: the line before, earlier u lines, v lines (the cell's own among
    // them), and none. On odd lines most rays repeat their neighbour's code,
    // as a real sweep's do, so that groups of cells often share their
    // candidates (and the vector kernels skip a kind of sample no lane needs).
    std::vector<int> code(2 * ray_half + 2);
    std::uniform_int_distribution<int> kind(0, 3), v_line(0, s.v_count - 1), u_line(0, std::max(0, n - 1));
    std::uniform_real_distribution<float> unit(0.0f, 1.0f);
    for (int& c : code) {
      if (n % 2 == 1 && &c != code.data() && unit(rng) < 0.9f) {
        c = (&c)[-1];
        continue;
      }
      switch (kind(rng)) {
        case 0:
          c = n - 1;
          break;
        case 1:
          c = n > 0 ? u_line(rng) : -1;
          break;
        case 2:
          c = -2 - v_line(rng);
          break;
        default:
          c = -1;
      }
    }
    const int line = s.line0 + s.dir * n;
    std::vector<float> out_scalar(z.size(), -7.0f), out_vector(z.size(), -7.0f);
    auto line_of = [&](std::vector<float>& out) {
      return ResampleLine{&cl,
                          code.data(),
                          n,
                          -ray_half,
                          0,
                          ray_half,
                          s.eye_v,
                          1.0 / k,
                          k,
                          eye,
                          curvature,
                          (k * metres_u) * (k * metres_u),
                          metres_v,
                          s.z + line * s.z_line,
                          out.data() + line * s.z_line,
                          s.z_v};
    };
    std::uniform_int_distribution<int> start(0, s.v_count - 1);
    for (int trial = 0; trial < 40; ++trial) {
      int j0 = start(rng), j1 = start(rng);
      if (j0 > j1) std::swap(j0, j1);
      const std::uint64_t written_scalar = resample_cells_scalar(line_of(out_scalar), j0, j1);
      const std::uint64_t written = resample_cells(line_of(out_vector), j0, j1);
      ASSERT_EQ(written, written_scalar) << "line " << n << ", cells " << j0 << ".." << j1;
    }
    // The whole line at once as well.
    ASSERT_EQ(resample_cells(line_of(out_vector), 0, s.v_count - 1),
              resample_cells_scalar(line_of(out_scalar), 0, s.v_count - 1));
    for (std::size_t i = 0; i < z.size(); ++i) {
      ASSERT_EQ(std::memcmp(&out_scalar[i], &out_vector[i], sizeof(float)), 0)
          << (rows ? "rows" : "columns") << ", line " << n << ", cell " << i << ": scalar " << out_scalar[i]
          << ", vector " << out_vector[i];
    }
    // The kernels answered every non-void cell of the line with a real
    // height, and wrote NaN (no answer) on every void one.
    int answered = 0;
    for (int j = 0; j < s.v_count; ++j) {
      const float target = s.z[line * s.z_line + j * s.z_v];
      const float value = out_scalar[line * s.z_line + j * s.z_v];
      if (std::isnan(target)) {
        EXPECT_TRUE(std::isnan(value)) << value;
      } else {
        EXPECT_FALSE(std::isnan(value));
        EXPECT_NE(value, -7.0f);
        ++answered;
      }
    }
    EXPECT_GT(answered, 0);

    // Coding the cells instead (radial_mask): every kernel gives the code
    // that visibility_mask()'s rule gives the scalar kernel's height, and
    // counts the visible ones, for every range tried above.
    for (const float target : {0.0f, 40.0f}) {
      std::vector<std::uint8_t> mask_scalar(z.size(), 77), mask_vector(z.size(), 77);
      std::uint64_t visible_scalar = 0, visible_vector = 0;
      auto coding = [&](std::vector<std::uint8_t>& mask, std::uint64_t& visible) {
        ResampleLine l = line_of(out_vector);
        l.out = nullptr;
        l.mask = mask.data() + line * s.z_line;
        l.target_height = target;
        l.visible = &visible;
        return l;
      };
      for (int trial = 0; trial < 40; ++trial) {
        int j0 = start(rng), j1 = start(rng);
        if (j0 > j1) std::swap(j0, j1);
        visible_scalar = visible_vector = 0;
        ASSERT_EQ(resample_cells(coding(mask_vector, visible_vector), j0, j1),
                  resample_cells_scalar(coding(mask_scalar, visible_scalar), j0, j1));
        ASSERT_EQ(visible_vector, visible_scalar) << "cells " << j0 << ".." << j1;
      }
      visible_scalar = visible_vector = 0;
      resample_cells(coding(mask_vector, visible_vector), 0, s.v_count - 1);
      resample_cells_scalar(coding(mask_scalar, visible_scalar), 0, s.v_count - 1);
      std::uint64_t visible = 0;
      for (int j = 0; j < s.v_count; ++j) {
        const std::size_t at = static_cast<std::size_t>(line * s.z_line + j * s.z_v);
        const float ground = s.z[at], height = out_scalar[at];
        const std::uint8_t want = std::isnan(ground)                               ? kNoAnswer
                                  : target >= min_target_height_at(height, ground) ? kVisible
                                                                                   : kHidden;
        ASSERT_EQ(int(mask_scalar[at]), int(want)) << "cell " << j;
        ASSERT_EQ(int(mask_vector[at]), int(want)) << "cell " << j;
        visible += want == kVisible;
      }
      EXPECT_EQ(visible_scalar, visible);
      EXPECT_EQ(visible_vector, visible);
      // The two masks agree everywhere, and no cell off the line was touched.
      ASSERT_EQ(mask_vector, mask_scalar);
      std::vector<bool> on_line(z.size(), false);
      for (int j = 0; j < s.v_count; ++j) on_line[static_cast<std::size_t>(line * s.z_line + j * s.z_v)] = true;
      for (std::size_t i = 0; i < z.size(); ++i)
        ASSERT_TRUE(on_line[i] || mask_scalar[i] == 77) << "cell " << i << " is not on line " << line;
    }
  }
}

TEST(ResampleCells, TheVectorKernelsGiveTheScalarKernelsBits) {
  const int forms = for_each_vector_form([] {
    std::mt19937 rng(20261201);
    for (int round = 0; round < 4; ++round) {
      compare_kernels(true, rng);
      compare_kernels(false, rng);
    }
  });
  if (forms == 0) GTEST_SKIP() << "this CPU has no AVX2: only the scalar kernel runs";
}

}  // namespace
}  // namespace horizon::visibility::sweep
