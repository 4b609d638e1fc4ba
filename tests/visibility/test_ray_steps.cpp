// The radial sweep's ray loops (core/src/visibility/ray_steps.hpp): the AVX2
// and AVX-512 kernels, and the fused step_rays, must give the scalar loops'
// bits, ray for ray, for every kind of ray (level, rising, falling, the
// diagonals), crossings and none, voids, the first line closer than one
// step, along rows and along columns, voids transparent or read as a fill
// height (which must equal the voids filled in memory), for counts that
// leave partial groups of sixteen and eight, and with each group's reads
// gathered or, along rows, taken as one run of each line.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <limits>
#include <random>
#include <vector>

#include "ray_steps.hpp"
#include "simd.hpp"
#include "vector_forms.hpp"

namespace horizon::visibility::sweep {
namespace {

constexpr int kV = 131;  // positions along v
constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();

template <class T>
void expect_same_bits(const std::vector<T>& a, const std::vector<T>& b, const char* what, double k) {
  ASSERT_EQ(a.size(), b.size());
  for (std::size_t i = 0; i < a.size(); ++i)
    ASSERT_EQ(std::memcmp(&a[i], &b[i], sizeof(T)), 0) << what << " of ray " << i << " at step " << k;
}

void compare_ray_steps() {
  std::mt19937 rng(1201);
  std::uniform_real_distribution<float> height(-430.0f, 8848.0f), unit(0.0f, 1.0f);
  for (const int zv : {1, 7}) {  // v contiguous (north/south) or strided (east/west)
    std::vector<float> prev(static_cast<std::size_t>(kV) * zv), cur(prev.size());
    for (std::size_t i = 0; i < prev.size(); ++i) {
      prev[i] = unit(rng) < 0.05f ? std::numeric_limits<float>::quiet_NaN() : height(rng);
      cur[i] = unit(rng) < 0.05f ? std::numeric_limits<float>::quiet_NaN() : height(rng);
    }
    // The same lines with their voids filled in memory: what a void read
    // through a fill height must equal.
    constexpr float kFill = 1234.5f;
    std::vector<float> prev_filled = prev, cur_filled = cur;
    for (float& v : prev_filled) v = std::isnan(v) ? kFill : v;
    for (float& v : cur_filled) v = std::isnan(v) ? kFill : v;
    for (const float fill : {std::numeric_limits<float>::quiet_NaN(), kFill})
      for (const double k : {0.35, 1.0, 1.5, 17.25, 64.0}) {
        const float eye_v = 65.4f;
        const double eye = 2952.9995700767936;
        const float eye_hi = static_cast<float>(eye), eye_lo = static_cast<float>(eye - eye_hi);
        const float kf = static_cast<float>(k), kp = static_cast<float>(k - 1.0);
        // Along a contiguous v, also with the vector kernels allowed to read
        // a group's samples as one run of each line (LineStep::run_last), up
        // to the lines' last element: groups near the end, and groups whose
        // rays spread wider than a run, must fall back to gathers.
        const std::vector<int> run_lasts = zv == 1 ? std::vector<int>{-1, kV - 1} : std::vector<int>{-1};
        for (const int run_last : run_lasts)
          for (const int count : {0, 1, 7, 8, 9, 15, 16, 17, 24, 25, 61, 193})
            for (const bool falling : {false, true}) {
              const LineStep ls{eye_hi, eye_lo, eye_v, 0.0f,    float(kV - 1), kf, kp, std::max(kp, 0.0f),
                                kV - 2, zv,     fill,  run_last};
              // Slopes evenly spaced in [-1, 1] as the plan makes them (0 and the
              // diagonals included), with their inverses and curvature terms;
              // also in falling order, where a group's first lane reads the
              // highest cells, not the lowest (the run loads must then gather).
              std::vector<float> slope(count), inv_slope(count), curv_k(count);
              for (int i = 0; i < count; ++i) {
                const int at = falling ? count - 1 - i : i;
                const double m = count == 1 ? 0.25 : -1.0 + 2.0 * at / (count - 1);
                slope[i] = static_cast<float>(m);
                inv_slope[i] = m == 0 ? 0.0f : static_cast<float>(1.0 / m);
                curv_k[i] = static_cast<float>(6.7e-8 * (900.0 + m * m * 756.0));
              }
              // Running maxima from a random state: some rays without a horizon yet.
              std::vector<float> h_scalar(count);
              std::vector<int> arg_scalar(count);
              for (int i = 0; i < count; ++i) {
                const bool none = unit(rng) < 0.2f;
                h_scalar[i] = none ? kNoHorizon : (unit(rng) - 0.5f) * 40.0f;
                arg_scalar[i] = none ? -1 : static_cast<int>(unit(rng) * 9.0f);
              }
              std::vector<float> cs_scalar(count, 1.0f), cs_vector(count, 2.0f);
              std::vector<int> cv_scalar(count, 5), cv_vector(count, 6), code_scalar(count, 7), code_vector(count, 8);
              step_cross_scalar(ls, count, slope.data(), inv_slope.data(), curv_k.data(), prev.data(), cur.data(),
                                h_scalar.data(), arg_scalar.data(), cs_scalar.data(), cv_scalar.data(),
                                code_scalar.data());
              step_cross(ls, count, slope.data(), inv_slope.data(), curv_k.data(), prev.data(), cur.data(),
                         h_scalar.data(), arg_scalar.data(), cs_vector.data(), cv_vector.data(), code_vector.data());
              expect_same_bits(cs_scalar, cs_vector, "cross slope", k);
              expect_same_bits(cv_scalar, cv_vector, "crossed v line", k);
              expect_same_bits(code_scalar, code_vector, "code", k);
              for (int i = 0; i < count; ++i) {
                const bool crossing_wins = cs_scalar[i] > h_scalar[i];
                EXPECT_EQ(code_scalar[i], crossing_wins ? -2 - cv_scalar[i] : arg_scalar[i]);
              }

              const std::vector<float> h_before = h_scalar;
              const std::vector<int> arg_before = arg_scalar;
              std::vector<float> h_vector = h_scalar;
              std::vector<int> arg_vector = arg_scalar;
              step_line_scalar(ls, count, slope.data(), curv_k.data(), cur.data(), cs_scalar.data(), cv_scalar.data(),
                               h_scalar.data(), arg_scalar.data(), 11);
              step_line(ls, count, slope.data(), curv_k.data(), cur.data(), cs_scalar.data(), cv_scalar.data(),
                        h_vector.data(), arg_vector.data(), 11);
              expect_same_bits(h_scalar, h_vector, "running maximum", k);
              expect_same_bits(arg_scalar, arg_vector, "where the maximum lies", k);
              // step_rays, both loops in one pass, from the same state: the same bits.
              for (const bool scalar : {true, false}) {
                std::vector<float> h_fused = h_before;
                std::vector<int> arg_fused = arg_before, code_fused(count, 9);
                (scalar ? step_rays_scalar : step_rays)(ls, count, slope.data(), inv_slope.data(), curv_k.data(),
                                                        prev.data(), cur.data(), h_fused.data(), arg_fused.data(),
                                                        code_fused.data(), 11);
                expect_same_bits(h_scalar, h_fused, scalar ? "fused scalar maximum" : "fused maximum", k);
                expect_same_bits(arg_scalar, arg_fused, scalar ? "fused scalar place" : "fused place", k);
                expect_same_bits(code_scalar, code_fused, scalar ? "fused scalar code" : "fused code", k);
              }
              if (!std::isnan(fill)) {
                // Filled as read == filled in memory and read as they are.
                LineStep transparent = ls;
                transparent.fill = std::numeric_limits<float>::quiet_NaN();
                std::vector<float> h_copy = h_before;
                std::vector<int> arg_copy = arg_before, code_copy(count, 9);
                step_rays_scalar(transparent, count, slope.data(), inv_slope.data(), curv_k.data(), prev_filled.data(),
                                 cur_filled.data(), h_copy.data(), arg_copy.data(), code_copy.data(), 11);
                expect_same_bits(h_scalar, h_copy, "maximum over the filled copy", k);
                expect_same_bits(arg_scalar, arg_copy, "place over the filled copy", k);
                expect_same_bits(code_scalar, code_copy, "code over the filled copy", k);
              }
              // The same crossings again: every candidate now ties with the maximum
              // it set, and a tie must keep the old place (line 11, not 12).
              step_line_scalar(ls, count, slope.data(), curv_k.data(), cur.data(), cs_scalar.data(), cv_scalar.data(),
                               h_scalar.data(), arg_scalar.data(), 12);
              step_line(ls, count, slope.data(), curv_k.data(), cur.data(), cs_scalar.data(), cv_scalar.data(),
                        h_vector.data(), arg_vector.data(), 12);
              expect_same_bits(arg_scalar, arg_vector, "where the maximum lies after ties", k);
              for (const int where : arg_scalar) EXPECT_NE(where, 12);
            }
      }
  }
}

TEST(RaySteps, TheVectorKernelsGiveTheScalarLoopsBits) {
  if (for_each_vector_form(compare_ray_steps) == 0) GTEST_SKIP() << "this CPU has no AVX2: only the scalar loops run";
}

// The loops' answer on a case worked by hand: one ray along v = eye_v + k / 2
// over a plane rising 1 m per v index, eye at 0 m, no curvature.
TEST(RaySteps, ARayOnAPlaneTakesTheHandComputedSlopes) {
  std::vector<float> prev(kV), cur(kV);
  for (int j = 0; j < kV; ++j) prev[j] = cur[j] = static_cast<float>(j);
  const float eye_v = 10.25f, k = 3.0f;
  const LineStep ls{0.0f, 0.0f, eye_v, 0.0f, float(kV - 1), k, k - 1.0f, k - 1.0f, kV - 2, 1, kNaN};
  // Nine identical rays so that the AVX2 kernel, where it runs, takes eight.
  std::vector<float> slope(9, 0.5f), inv_slope(9, 2.0f), curv_k(9, 0.0f), cs(9), h(9, kNoHorizon);
  std::vector<int> cv(9), arg(9, -1), code(9);
  step_cross(ls, 9, slope.data(), inv_slope.data(), curv_k.data(), prev.data(), cur.data(), h.data(), arg.data(),
             cs.data(), cv.data(), code.data());
  step_line(ls, 9, slope.data(), curv_k.data(), cur.data(), cs.data(), cv.data(), h.data(), arg.data(), 2);
  for (int i = 0; i < 9; ++i) {
    // From step 2 (v = 11.25) to step 3 (v = 11.75) the ray crosses no v line.
    EXPECT_EQ(cv[i], -1);
    EXPECT_EQ(code[i], -1);  // no horizon before this step
    // On line 3 it is at v = 11.75: terrain 11.75 m, slope per step 11.75 / 3.
    EXPECT_FLOAT_EQ(h[i], 11.75f / 3.0f);
    EXPECT_EQ(arg[i], 2);
  }
}

}  // namespace
}  // namespace horizon::visibility::sweep
