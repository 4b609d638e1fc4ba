// The trace's kernels (core/src/trace/silhouette.hpp): the packed tree
// against brute-force maxima, the descent against a linear scan, and every
// SIMD form against the scalar loop, bit for bit.
#include <gtest/gtest.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>
#include <random>
#include <vector>

#include "test_support.hpp"
#include "trace/frustum.hpp"
#include "trace/silhouette.hpp"
#include "trace_test_util.hpp"

namespace horizon::trace {
namespace {

using detail::Isa;
using detail::kBlock;
using detail::kNoCrossing;
using visibility::sweep::simd::cpu_isa;

// A map of `lines` x kBlock slopes, some lines without a crossing.
std::vector<float> random_map(int lines, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> slope(-0.5f, 0.5f);
  std::uniform_int_distribution<int> coin(0, 9);
  std::vector<float> map(static_cast<std::size_t>(lines) * kBlock);
  for (float& v : map) v = coin(rng) == 0 ? kNoCrossing : slope(rng);
  return map;
}

float max_over(const std::vector<float>& map, int from, int to, int lane, int lines) {
  float m = kNoCrossing;
  for (int k = from; k < std::min(to, lines); ++k) m = std::max(m, map[static_cast<std::size_t>(k) * kBlock + lane]);
  return m;
}

TEST(SilhouetteTree, EveryChannelIsTheMaximumOfItsLines) {
  for (int lines : {1, 2, 3, 4, 5, 7, 16, 17, 63, 64, 65, 100, 1000, 1025}) {
    const std::vector<float> map = random_map(lines, static_cast<unsigned>(lines));
    const detail::TreeShape shape = detail::tree_shape(lines);
    std::vector<float> pairs(shape.floats);
    detail::build_tree(map.data(), shape, pairs.data());
    ASSERT_EQ(shape.nodes.back(), 1) << lines;
    EXPECT_EQ(shape.levels, static_cast<int>(std::ceil(std::log2(std::max(lines, 2)) / 2.0))) << lines;
    int span = 1;  // lines under one quarter of a level-p node
    for (int p = 1; p <= shape.levels; ++p, span *= 4) {
      for (int j = 0; j < shape.nodes[static_cast<std::size_t>(p)]; ++j) {
        const float* texel =
            pairs.data() + shape.offset[static_cast<std::size_t>(p)] + static_cast<std::size_t>(j) * 4 * kBlock;
        const int q0 = 4 * j * span;
        for (int lane = 0; lane < kBlock; ++lane) {
          ASSERT_EQ(texel[lane], max_over(map, q0, q0 + span, lane, lines)) << lines << " R p" << p << " j" << j;
          ASSERT_EQ(texel[kBlock + lane], max_over(map, q0 + 2 * span, q0 + 3 * span, lane, lines)) << "G";
          ASSERT_EQ(texel[2 * kBlock + lane], max_over(map, q0, q0 + 2 * span, lane, lines)) << "B";
          ASSERT_EQ(texel[3 * kBlock + lane], max_over(map, q0, q0 + 4 * span, lane, lines)) << "A";
        }
      }
    }
  }
}

TEST(SilhouetteTree, NoLinesMeansNoLevelsAndEverythingIsSky) {
  const detail::TreeShape shape = detail::tree_shape(0);
  EXPECT_EQ(shape.levels, 0);
  float slope[kBlock];
  std::int32_t leaf[kBlock];
  std::fill(slope, slope + kBlock, -1.0f);
  detail::descend(Isa::kScalar, nullptr, shape, slope, leaf);
  for (int lane = 0; lane < kBlock; ++lane) EXPECT_EQ(leaf[lane], -1);
}

// Every form the CPU runs, scalar first.
std::vector<Isa> forms() {
  std::vector<Isa> isas{Isa::kScalar};
  if (cpu_isa() >= Isa::kAvx2) isas.push_back(Isa::kAvx2);
  if (cpu_isa() >= Isa::kAvx512) isas.push_back(Isa::kAvx512);
  return isas;
}

TEST(SilhouetteTree, TheDescentFindsTheFirstLineReachingTheRayInEveryForm) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> slope(-0.6f, 0.6f);
  for (int lines : {1, 3, 4, 9, 64, 77, 513}) {
    const std::vector<float> map = random_map(lines, 100u + static_cast<unsigned>(lines));
    const detail::TreeShape shape = detail::tree_shape(lines);
    std::vector<float> pairs(shape.floats);
    detail::build_tree(map.data(), shape, pairs.data());
    for (int trial = 0; trial < 200; ++trial) {
      alignas(64) float s[kBlock];
      for (int lane = 0; lane < kBlock; ++lane) {
        // Some slopes exactly on a line's value: ties must go to that line.
        const int k = std::uniform_int_distribution<int>(0, lines - 1)(rng);
        s[lane] = trial % 3 == 0 ? map[static_cast<std::size_t>(k) * kBlock + lane] : slope(rng);
      }
      std::int32_t expected[kBlock];
      for (int lane = 0; lane < kBlock; ++lane) {
        expected[lane] = -1;
        for (int k = 0; k < lines; ++k)
          if (s[lane] <= map[static_cast<std::size_t>(k) * kBlock + lane]) {
            expected[lane] = k;
            break;
          }
      }
      for (Isa isa : forms()) {
        alignas(64) std::int32_t leaf[kBlock];
        detail::descend(isa, pairs.data(), shape, s, leaf);
        for (int lane = 0; lane < kBlock; ++lane)
          ASSERT_EQ(leaf[lane], expected[lane])
              << "isa " << static_cast<int>(isa) << " lines " << lines << " lane " << lane << " slope " << s[lane];
      }
    }
  }
}

TEST(SilhouetteMap, EverySimdFormGivesTheScalarBits) {
  // Voids, the view's edges, near and far limits and curvature all in play.
  terrain::Dem dem = horizon::testing::make_random_terrain(157, 131, 11, 300.0, 30.0);
  for (int r = 40; r < 48; ++r)
    for (int c = 60; c < 75; ++c) dem.elevation.at(c, r) = std::numeric_limits<float>::quiet_NaN();
  const terrain::HeightView view(dem.elevation);
  TraceOptions options;
  options.near = 40.0;
  options.max_distance = 2500.0;
  for (double yaw : {0.0, 33.0, 95.0, 180.0, 231.0, 300.0}) {
    const Camera camera = testing::camera_at(dem, 70.3, 66.8, 25.0, testing::spec_of(yaw, 5.0, 120.0, 100, 10));
    const detail::FrameGeometry g = detail::make_frame_geometry(camera, view, options);
    for (const detail::Run& run : g.runs) {
      for (int x0 = run.x0; x0 < run.x1; x0 += kBlock) {
        detail::BlockLines b;
        b.lanes = std::min(kBlock, run.x1 - x0);
        for (int side = 0; side < 3; ++side) {
          // side 2: the primary family; 0 and 1: each secondary family on every lane.
          const detail::LineFamily& f = side == 2 ? run.primary : run.secondary[side];
          b.eye_along = f.eye_along;
          b.pos_count = f.pos_count;
          b.line_stride = f.line_stride;
          b.pos_stride = f.pos_stride;
          for (int i = 0; i < b.lanes; ++i) {
            const auto x = static_cast<std::size_t>(x0 + i);
            b.first[i] = f.first;
            b.step[i] = f.step;
            b.count[i] = f.count;
            b.t0[i] = f.t0;
            b.pos_per_t[i] = side == 2 ? g.pos_per_t[x] : g.pos_per_t2[x];
            b.dist_per_t[i] = side == 2 ? g.dist_per_t[x] : 30.0f + static_cast<float>(i);
            b.near[i] = g.near[x];
          }
          const int lines = f.count;
          std::vector<float> reference(static_cast<std::size_t>(lines) * kBlock);
          detail::build_map(Isa::kScalar, view.data(), b, g, lines, reference.data());
          const auto crossings =
              std::count_if(reference.begin(), reference.end(), [](float v) { return v > kNoCrossing; });
          if (side == 2) {
            EXPECT_GT(crossings, 0);
          }
          for (Isa isa : forms()) {
            std::vector<float> map(reference.size());
            detail::build_map(isa, view.data(), b, g, lines, map.data());
            ASSERT_EQ(0, std::memcmp(map.data(), reference.data(), map.size() * sizeof(float)))
                << "isa " << static_cast<int>(isa) << " yaw " << yaw << " side " << side;
          }
        }
      }
    }
  }
}

}  // namespace
}  // namespace horizon::trace
