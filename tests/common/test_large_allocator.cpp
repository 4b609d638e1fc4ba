// LargeAllocator (horizon/common/large_allocator.hpp): large rasters come
// from their own mapping, small ones from operator new, and both hold what
// is written to them.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <fstream>
#include <numeric>
#include <sstream>
#include <string>
#include <string_view>
#include <vector>

#include "horizon/common/huge_pages.hpp"
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
  // A VM's /proc/buddyinfo: orders 0..10; order 9 is one 2 MiB page, order
  // 10 two. Free here: DMA 1 + 3 * 2, DMA32 1 + 753 * 2, Normal 126 + 2942 *
  // 2: 7524 huge pages.
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

// The kB of the mapping holding `address` that huge pages back
// (/proc/self/smaps' AnonHugePages), or -1 when it is not found.
long huge_kb_at(const void* address) {
  std::ifstream smaps("/proc/self/smaps");
  const auto at = reinterpret_cast<std::uintptr_t>(address);
  std::string line;
  bool inside = false;
  while (std::getline(smaps, line)) {
    std::uintptr_t begin = 0, end = 0;
    char dash = 0;
    std::istringstream head(line);
    if (head >> std::hex >> begin >> dash >> end && dash == '-') {
      inside = begin <= at && at < end;
      continue;
    }
    if (inside && line.rfind("AnonHugePages:", 0) == 0) return std::stol(line.substr(14));
  }
  return -1;
}

// The text of a kernel file, empty when it cannot be read.
std::string kernel_text(const char* path) {
  std::ifstream in(path);
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

// Where the kernel would hand out huge pages now, a mapped block starts on
// a 2 MiB boundary and huge pages back all of it; the values stay.
TEST(LargeAllocator, AMappedBlockIsOnHugePagesWhereTheKernelHasThemToSpare) {
  constexpr std::size_t kMiB = std::size_t{1} << 20;
  const std::size_t bytes = 16 * kMiB;
  if (!detail::is_large_block(bytes)) GTEST_SKIP() << "this build maps no block (a sanitizer build, or not Linux)";
  if (!detail::want_huge_pages(kernel_text("/sys/kernel/mm/transparent_hugepage/enabled"),
                               kernel_text("/proc/buddyinfo"), bytes))
    GTEST_SKIP() << "this kernel hands out no huge pages on request now (THP mode, or free 2 MiB blocks short)";
  terrain::Grid<float> g(2048, 2048, 3.25f);
  ASSERT_EQ(g.capacity() * sizeof(float), bytes);
  EXPECT_EQ(reinterpret_cast<std::uintptr_t>(g.data()) % (2 * kMiB), 0u);
  EXPECT_GE(huge_kb_at(g.data()), 16 * 1024) << "smaps shows the block not wholly on huge pages";
  g.at(2047, 2047) = -1.5f;
  EXPECT_EQ(g.at(0, 0), 3.25f);
  EXPECT_EQ(g.at(2047, 2046), 3.25f);
  EXPECT_EQ(g.at(2047, 2047), -1.5f);

  // Not while huge pages are disallowed (horizon/common/huge_pages.hpp).
  ASSERT_TRUE(huge_pages_allowed());
  allow_huge_pages(false);
  terrain::Grid<float> small(2048, 2048, 1.0f);
  allow_huge_pages(true);
  EXPECT_EQ(huge_kb_at(small.data()), 0) << "a block mapped while huge pages were disallowed is on them";
  EXPECT_EQ(small.at(2047, 2047), 1.0f);
}

// A block kept for many runs (a daemon's Workspace) asks for huge pages
// once; the kernel backs the block's aligned 2 MiB spans and the values stay.
TEST(LargeAllocator, AKeptBlockIsBackedByHugePagesWhereTheKernelCan) {
  terrain::Grid<float> small(100, 100, 1.0f);
  EXPECT_FALSE(back_with_huge_pages(small.data(), small.capacity() * sizeof(float)));  // operator new's, left alone
  // 16 MiB: a mapped block.
  terrain::Grid<float> g(2048, 2048, 3.25f);
  g.at(2047, 2047) = -1.5f;
  const std::size_t bytes = g.capacity() * sizeof(float);
  if (!back_with_huge_pages(g.data(), bytes))
    GTEST_SKIP() << "this kernel or build backs no block with huge pages (MADV_COLLAPSE: Linux 6.1+)";
  // Every whole 2 MiB span inside the block: at least 7 of the 8 (a block may be page-aligned only).
  EXPECT_GE(huge_kb_at(g.data()), 7 * 2048) << "smaps shows no huge pages for the block";
  EXPECT_EQ(g.at(0, 0), 3.25f);
  EXPECT_EQ(g.at(1024, 1000), 3.25f);
  EXPECT_EQ(g.at(2047, 2047), -1.5f);
  EXPECT_TRUE(back_with_huge_pages(g.data(), bytes));  // again: already backed
}

}  // namespace
}  // namespace horizon
