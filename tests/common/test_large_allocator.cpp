// LargeAllocator (horizon/common/large_allocator.hpp): large rasters come
// from their own mapping, small ones from operator new, and both hold what
// is written to them.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <numeric>
#include <vector>

#include "horizon/common/large_allocator.hpp"
#include "horizon/terrain/grid.hpp"

namespace horizon {
namespace {

TEST(LargeAllocator, OnlyBlocksOfTwoMebibytesAndMoreAreMapped) {
#if defined(__linux__) && !defined(__SANITIZE_ADDRESS__) && !defined(__SANITIZE_THREAD__)
  EXPECT_TRUE(detail::is_large_block(std::size_t{2} << 20));
  EXPECT_TRUE(detail::is_large_block(std::size_t{48} << 20));
#else
  EXPECT_FALSE(detail::is_large_block(std::size_t{48} << 20));
#endif
  EXPECT_FALSE(detail::is_large_block((std::size_t{2} << 20) - 1));
  EXPECT_FALSE(detail::is_large_block(0));
}

TEST(LargeAllocator, LargeAndSmallVectorsHoldTheirValues) {
  for (const std::size_t n : {std::size_t{1}, std::size_t{1000}, std::size_t{1} << 20, (std::size_t{3} << 20) + 7}) {
    std::vector<float, LargeAllocator<float>> v(n, -1.0f);
    if (detail::is_large_block(n * sizeof(float))) {
      EXPECT_EQ(reinterpret_cast<std::uintptr_t>(v.data()) % 4096, 0u) << n;  // its own, page-aligned mapping
    }
    std::iota(v.begin(), v.end(), 0.0f);
    EXPECT_EQ(v.front(), 0.0f);
    EXPECT_EQ(v.back(), static_cast<float>(n - 1));
    // Copies and moves keep the values (and free their blocks correctly).
    auto copy = v;
    auto moved = std::move(v);
    EXPECT_EQ(copy, moved);
    copy.resize(n / 2 + 1);
    EXPECT_EQ(copy.back(), static_cast<float>(n / 2));
  }
}

TEST(LargeAllocator, AGridOfTwelveMillionCellsIsFilledEverywhere) {
  terrain::Grid<float> g(3309, 3708, 7.5f);
  EXPECT_EQ(g.at(0, 0), 7.5f);
  EXPECT_EQ(g.at(3308, 3707), 7.5f);
  g.at(1654, 1854) = 2951.0f;
  const terrain::Grid<float> copy = g;
  EXPECT_EQ(copy.at(1654, 1854), 2951.0f);
  EXPECT_EQ(copy.at(3308, 0), 7.5f);
}

TEST(LargeAllocator, AnUninitializedGridHasItsSizeAndTakesWhatIsWritten) {
  terrain::Grid<float> g(3309, 3708, terrain::kUninitialized);
  ASSERT_EQ(g.size(), std::size_t{3309} * 3708);
  std::fill(g.values().begin(), g.values().end(), 4.25f);
  EXPECT_EQ(g.at(0, 0), 4.25f);
  EXPECT_EQ(g.at(3308, 3707), 4.25f);
  terrain::Grid<std::uint8_t> small(5, 4, terrain::kUninitialized);
  EXPECT_EQ(small.size(), 20u);
  // A value-less construct leaves a float as it is; a construct with a value sets it.
  LargeAllocator<float> alloc;
  float cell = 9.5f;
  alloc.construct(&cell, 1.5f);
  EXPECT_EQ(cell, 1.5f);
}

}  // namespace
}  // namespace horizon
