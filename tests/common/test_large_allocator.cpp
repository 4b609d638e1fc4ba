// LargeAllocator (horizon/common/large_allocator.hpp): large rasters come
// from their own mapping, small ones from operator new, and both hold what
// is written to them.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <numeric>
#include <string_view>
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

TEST(LargeAllocator, HugePagesAreAskedForOnlyOnRequestModeWithFreeBlocksToSpare) {
  // This VM's /proc/buddyinfo: orders 0..10; order 9 is one 2 MiB page,
  // order 10 two. Free here: DMA 1 + 3 * 2, DMA32 1 + 753 * 2, Normal 126 +
  // 2942 * 2: 7524 huge pages.
  const std::string_view roomy =
      "Node 0, zone      DMA      0      0      0      0      0      0      0      0      1      1      3 \n"
      "Node 0, zone    DMA32      1      2      2      2      1      2      0      3      3      1    753 \n"
      "Node 0, zone   Normal  16941   9822   7091   6380   2608   1195    538    181     44    126   2942 \n";
  const std::string_view madvise = "always [madvise] never\n";
  constexpr std::size_t kMiB = std::size_t{1} << 20;
  EXPECT_TRUE(detail::want_huge_pages(madvise, roomy, 48 * kMiB));
  // Twice the block's huge pages and 32 more must be free: 7524 = 2 * 3746 + 32.
  EXPECT_TRUE(detail::want_huge_pages(madvise, roomy, 3746 * 2 * kMiB));
  EXPECT_FALSE(detail::want_huge_pages(madvise, roomy, 3746 * 2 * kMiB + 1));
  // Fragmented: free memory in small blocks only (3 + 1 huge pages free).
  const std::string_view fragmented =
      "Node 0, zone   Normal  916941   99822   7091   6380   2608   1195    538    181     44      3      0 \n"
      "Node 1, zone   Normal  16941   9822   7091   6380   2608   1195    538    181     44      1      0\n";
  EXPECT_FALSE(detail::want_huge_pages(madvise, fragmented, 2 * kMiB));
  // Two nodes are summed: 20 + 2 * 10 = 40 >= 2 * 4 + 32; a fifth page is one too many.
  const std::string_view two_nodes =
      "Node 0, zone   Normal 1 1 1 1 1 1 1 1 1 20 0\nNode 1, zone   Normal 1 1 1 1 1 1 1 1 1 0 10";
  EXPECT_TRUE(detail::want_huge_pages(madvise, two_nodes, 8 * kMiB));
  EXPECT_FALSE(detail::want_huge_pages(madvise, two_nodes, 10 * kMiB - 1));
  // Other modes: "always" backs blocks unasked, "never" refuses; an
  // unreadable file (empty text) asks for nothing.
  EXPECT_FALSE(detail::want_huge_pages("[always] madvise never\n", roomy, 48 * kMiB));
  EXPECT_FALSE(detail::want_huge_pages("always madvise [never]\n", roomy, 48 * kMiB));
  EXPECT_FALSE(detail::want_huge_pages("", roomy, 48 * kMiB));
  EXPECT_FALSE(detail::want_huge_pages(madvise, "", 48 * kMiB));
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
