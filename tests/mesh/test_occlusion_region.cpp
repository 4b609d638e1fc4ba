// Tests for mesh/occlusion_region.cpp: a vertex's region by hand, the
// intersection of many against the brute-force minimum of their lines,
// and simplification that only shrinks.
#include <gtest/gtest.h>

#include <algorithm>
#include <random>

#include "horizon/mesh/occlusion_region.hpp"

namespace horizon::mesh {
namespace {

TEST(OcclusionChain, AVertexRegionIsUnderTheRayPastItsHorizon) {
  // p at T = 0, z = 100; horizon at T = 50, z = 150: slope 1.
  const auto chain = OcclusionChain::from_horizon({0, 100}, {50, 150});
  EXPECT_FALSE(chain.empty());
  EXPECT_DOUBLE_EQ(chain.final_slope(), 1.0);
  EXPECT_TRUE(chain.contains(50, 150));    // on the ray at the horizon
  EXPECT_TRUE(chain.contains(100, 199));   // under the ray
  EXPECT_TRUE(chain.contains(100, 200));   // on it
  EXPECT_FALSE(chain.contains(100, 201));  // above it
  EXPECT_FALSE(chain.contains(49, 0));     // before the horizon: nothing in the way
  EXPECT_FALSE(OcclusionChain().contains(100, -1e9));
}

TEST(OcclusionChain, IntersectionIsTheLowerEnvelopeOfItsLines) {
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  for (int trial = 0; trial < 200; ++trial) {
    struct Line {
      double t0, z0, slope;
    };
    std::vector<Line> lines;
    OcclusionChain all;
    const int count = 1 + trial % 12;
    for (int k = 0; k < count; ++k) {
      const ChainPoint p{u(rng) * 100, u(rng) * 500};
      const ChainPoint h{p.t + 1 + u(rng) * 400, p.z + (u(rng) - 0.3) * 300};
      lines.push_back({h.t, h.z, (h.z - p.z) / (h.t - p.t)});
      const auto one = OcclusionChain::from_horizon(p, h);
      all = k == 0 ? one : OcclusionChain::intersect(all, one);
    }
    double t0 = 0;
    for (const Line& l : lines) t0 = std::max(t0, l.t0);
    ASSERT_FALSE(all.empty());
    EXPECT_DOUBLE_EQ(all.corners().front().t, t0);
    for (int i = 0; i < 200; ++i) {
      const double t = t0 + u(rng) * 3000;
      double lowest = INFINITY;
      for (const Line& l : lines) lowest = std::min(lowest, l.z0 + l.slope * (t - l.t0));
      EXPECT_NEAR(all.height_at(t), lowest, 1e-7 * std::max(1.0, std::abs(lowest))) << "trial " << trial << " t " << t;
    }
    // Concave: slopes never rise along the chain.
    const auto& c = all.corners();
    for (std::size_t j = 1; j + 1 < c.size(); ++j) {
      const double before = (c[j].z - c[j - 1].z) / (c[j].t - c[j - 1].t);
      const double after = (c[j + 1].z - c[j].z) / (c[j + 1].t - c[j].t);
      EXPECT_LE(after, before + 1e-9);
    }
    EXPECT_TRUE(OcclusionChain::intersect(all, OcclusionChain()).empty());
  }
}

TEST(OcclusionChain, TheLowerEnvelopeOfManyRaysIsTheirFoldedIntersection) {
  std::mt19937_64 rng(13);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  for (int trial = 0; trial < 300; ++trial) {
    std::vector<OcclusionChain::Ray> rays;
    OcclusionChain folded;
    const int count = 1 + trial % 40;
    for (int k = 0; k < count; ++k) {
      // Whole-metre values now and then, so equal slopes and common points occur.
      const bool coarse = trial % 3 == 0;
      const ChainPoint p{coarse ? std::floor(u(rng) * 5) : u(rng) * 100, coarse ? std::floor(u(rng) * 5) : u(rng) * 500};
      const ChainPoint h{p.t + 1 + (coarse ? std::floor(u(rng) * 4) : u(rng) * 400),
                         p.z + (coarse ? std::floor(u(rng) * 5) - 2 : (u(rng) - 0.3) * 300)};
      const auto one = OcclusionChain::from_horizon(p, h);
      rays.push_back({h, one.final_slope()});
      folded = k == 0 ? one : OcclusionChain::intersect(folded, one);
    }
    const OcclusionChain envelope = OcclusionChain::lower_envelope(rays);
    ASSERT_FALSE(envelope.empty());
    EXPECT_DOUBLE_EQ(envelope.corners().front().t, folded.corners().front().t);
    EXPECT_DOUBLE_EQ(envelope.final_slope(), folded.final_slope());
    for (int i = 0; i < 100; ++i) {
      const double t = folded.corners().front().t + u(rng) * 2000;
      EXPECT_NEAR(envelope.height_at(t), folded.height_at(t), 1e-7 * std::max(1.0, std::abs(folded.height_at(t))))
          << "trial " << trial;
    }
  }
  EXPECT_TRUE(OcclusionChain::lower_envelope({}).empty());
}

TEST(OcclusionChain, SimplifyingOnlyShrinksTheRegion) {
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  // A chain of many corners: the lines tangent to the concave parabola
  // g(t) = 500 + 2t - 0.005 t² at t = 10, 20, ..., 400, all from T = 10.
  auto g = [](double t) { return 500 + 2 * t - 0.005 * t * t; };
  auto dg = [](double t) { return 2 - 0.01 * t; };
  OcclusionChain many;
  for (int k = 1; k <= 40; ++k) {
    const double tk = 10.0 * k;
    const ChainPoint h{10, g(tk) + dg(tk) * (10 - tk)};
    const ChainPoint p{9, h.z - dg(tk)};
    const auto line = OcclusionChain::from_horizon(p, h);
    many = k == 1 ? line : OcclusionChain::intersect(many, line);
  }
  ASSERT_GT(many.corners().size(), 8u);
  for (std::size_t keep : {2u, 3u, 5u, 8u}) {
    const OcclusionChain few = many.simplified(keep);
    EXPECT_LE(few.corners().size(), keep);
    EXPECT_EQ(few.corners().front(), many.corners().front());
    EXPECT_DOUBLE_EQ(few.final_slope(), many.final_slope());
    for (int i = 0; i < 500; ++i) {
      const double t = many.corners().front().t + u(rng) * 1000;
      EXPECT_LE(few.height_at(t), many.height_at(t) + 1e-9) << keep << " corners at t " << t;
    }
  }
  EXPECT_EQ(many.simplified(1000), many);
}

}  // namespace
}  // namespace horizon::mesh
