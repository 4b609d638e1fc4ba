// The shared block cache: hits and LRU eviction under the byte budget, one
// decode for blocks asked for at once, failures that fail only their
// requests, and a stopped wait that keeps the decode for the next request;
// blocks built on the caller's thread kept, joined and evicted the same way.
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <thread>
#include <vector>

#include "horizon/terrain/block_cache.hpp"

namespace horizon::terrain {
namespace {

// A loader whose block of `cells` cells holds `value`, counting its calls.
BlockLoader counted(std::atomic<int>& calls, int cells, float value, int sleep_ms = 0) {
  return [&calls, cells, value, sleep_ms]() -> Result<Grid<float>> {
    ++calls;
    if (sleep_ms) std::this_thread::sleep_for(std::chrono::milliseconds(sleep_ms));
    return Grid<float>(cells, 1, value);
  };
}

BlockCache::Options cache_of(std::uint64_t budget, unsigned io_threads) {
  BlockCache::Options o;
  o.budget_bytes = budget;
  o.io_threads = io_threads;
  return o;
}

constexpr std::uint64_t kBlockBytes = 1000 * sizeof(float);

TEST(BlockCache, SecondFetchIsAHitAndDecodesNothing) {
  BlockCache cache(cache_of(10 * kBlockBytes, 2));
  std::atomic<int> calls{0};
  std::vector<BlockCache::Want> wants;
  for (int b = 0; b < 3; ++b) wants.push_back({{7, static_cast<std::uint64_t>(b)}, counted(calls, 1000, float(b))});
  FetchStats first, second;
  auto a = cache.fetch(wants, nullptr, &first);
  ASSERT_TRUE(a.ok());
  auto b = cache.fetch(wants, nullptr, &second);
  ASSERT_TRUE(b.ok());
  EXPECT_EQ(calls.load(), 3);
  EXPECT_EQ(first.misses, 3u);
  EXPECT_EQ(first.bytes_decoded, 3 * kBlockBytes);
  EXPECT_EQ(second.hits, 3u);
  EXPECT_EQ(second.misses, 0u);
  EXPECT_EQ(second.bytes_decoded, 0u);
  for (int i = 0; i < 3; ++i) {
    EXPECT_EQ((*b)[static_cast<std::size_t>(i)]->at(0, 0), float(i));
    EXPECT_EQ((*a)[static_cast<std::size_t>(i)].get(), (*b)[static_cast<std::size_t>(i)].get());  // the same block
  }
  const BlockCacheStats s = cache.stats();
  EXPECT_EQ(s.resident_blocks, 3u);
  EXPECT_EQ(s.resident_bytes, 3 * kBlockBytes);
}

TEST(BlockCache, EvictsTheLeastRecentlyUsedAndNeverExceedsTheBudget) {
  BlockCache cache(cache_of(3 * kBlockBytes, 1));
  std::atomic<int> calls{0};
  auto want = [&](std::uint64_t b) { return BlockCache::Want{{1, b}, counted(calls, 1000, float(b))}; };
  for (std::uint64_t b : {0, 1, 2}) ASSERT_TRUE(cache.fetch(std::vector{want(b)}).ok());
  ASSERT_TRUE(cache.fetch(std::vector{want(0)}).ok());  // 0 is now the most recent; 1 the least
  ASSERT_TRUE(cache.fetch(std::vector{want(3)}).ok());  // evicts 1
  EXPECT_EQ(calls.load(), 4);
  FetchStats s0, s1;
  ASSERT_TRUE(cache.fetch(std::vector{want(0)}, nullptr, &s0).ok());
  EXPECT_EQ(s0.hits, 1u);
  ASSERT_TRUE(cache.fetch(std::vector{want(1)}, nullptr, &s1).ok());
  EXPECT_EQ(s1.misses, 1u);  // it had gone
  const BlockCacheStats s = cache.stats();
  EXPECT_LE(s.peak_resident_bytes, 3 * kBlockBytes);
  EXPECT_EQ(s.resident_bytes, 3 * kBlockBytes);
  EXPECT_EQ(s.evictions, 2u);
}

TEST(BlockCache, HeldBlocksOutliveTheirEvictionAndAreCountedApart) {
  BlockCache cache(cache_of(1 * kBlockBytes, 1));
  std::atomic<int> calls{0};
  auto held = cache.fetch(std::vector{BlockCache::Want{{1, 0}, counted(calls, 1000, 5.0f)}});
  ASSERT_TRUE(held.ok());
  ASSERT_TRUE(cache.fetch(std::vector{BlockCache::Want{{1, 1}, counted(calls, 1000, 6.0f)}}).ok());
  EXPECT_EQ(cache.stats().held_bytes, kBlockBytes);  // block 0: evicted, still ours
  EXPECT_EQ((*held)[0]->at(999, 0), 5.0f);
  held = Error{};
  EXPECT_EQ(cache.stats().held_bytes, 0u);
}

TEST(BlockCache, ABlockLargerThanTheBudgetIsHandedOverButNotKept) {
  BlockCache cache(cache_of(kBlockBytes / 2, 1));
  std::atomic<int> calls{0};
  auto got = cache.fetch(std::vector{BlockCache::Want{{1, 0}, counted(calls, 1000, 1.0f)}});
  ASSERT_TRUE(got.ok());
  EXPECT_EQ((*got)[0]->width(), 1000);
  EXPECT_EQ(cache.stats().resident_bytes, 0u);
}

TEST(BlockCache, ConcurrentRequestsForOneBlockDecodeItOnce) {
  BlockCache cache(cache_of(100 * kBlockBytes, 4));
  std::atomic<int> calls{0};
  const BlockLoader slow = counted(calls, 1000, 3.0f, 50);
  std::vector<std::thread> threads;
  std::atomic<int> ok{0};
  std::atomic<std::uint64_t> joins{0};
  for (int t = 0; t < 6; ++t)
    threads.emplace_back([&] {
      FetchStats s;
      // The same block twice in one fetch, too.
      auto got =
          cache.fetch(std::vector{BlockCache::Want{{9, 42}, slow}, BlockCache::Want{{9, 42}, slow}}, nullptr, &s);
      if (got.ok() && (*got)[0]->at(0, 0) == 3.0f && (*got)[0].get() == (*got)[1].get()) ++ok;
      joins += s.joins;
    });
  for (auto& t : threads) t.join();
  EXPECT_EQ(calls.load(), 1);
  EXPECT_EQ(ok.load(), 6);
  EXPECT_GE(joins.load(), 6u);  // each fetch joins at least its own second want
}

TEST(BlockCache, AFailedDecodeFailsItsRequestsOnlyAndIsNotKept) {
  BlockCache cache(cache_of(100 * kBlockBytes, 2));
  std::atomic<int> good{0}, bad{0};
  const BlockLoader broken = [&bad]() -> Result<Grid<float>> {
    ++bad;
    return make_error(ErrorCode::kDataError, "dem 'tile_3.tif': cannot decode tile at col 256, row 0", "tile_3.tif");
  };
  auto failed =
      cache.fetch(std::vector{BlockCache::Want{{2, 0}, counted(good, 1000, 1.0f)}, BlockCache::Want{{2, 1}, broken}});
  ASSERT_FALSE(failed.ok());
  EXPECT_EQ(failed.error().code, ErrorCode::kDataError);
  EXPECT_NE(failed.error().message.find("tile_3.tif"), std::string::npos);
  // Another request for the good block only: served from the cache.
  FetchStats s;
  ASSERT_TRUE(cache.fetch(std::vector{BlockCache::Want{{2, 0}, counted(good, 1000, 1.0f)}}, nullptr, &s).ok());
  EXPECT_EQ(s.hits, 1u);
  EXPECT_EQ(good.load(), 1);
  // The failure was not kept: asked again, it is decoded again.
  EXPECT_FALSE(cache.fetch(std::vector{BlockCache::Want{{2, 1}, broken}}).ok());
  EXPECT_EQ(bad.load(), 2);
  EXPECT_EQ(cache.stats().failures, 2u);
}

TEST(BlockCache, ACancelledWaitReturnsAtOnceAndTheDecodeIsKept) {
  BlockCache cache(cache_of(100 * kBlockBytes, 1));
  std::atomic<int> calls{0};
  CancelToken token;
  RunControl control;
  control.cancel = &token;
  token.cancel();
  const auto start = std::chrono::steady_clock::now();
  auto got = cache.fetch(std::vector{BlockCache::Want{{4, 0}, counted(calls, 1000, 2.0f, 200)}}, &control);
  ASSERT_FALSE(got.ok());
  EXPECT_EQ(got.error().code, ErrorCode::kCancelled);
  EXPECT_LT(std::chrono::steady_clock::now() - start, std::chrono::milliseconds(150));
  // The decode goes on and lands in the cache for the next request.
  FetchStats s;
  auto again = cache.fetch(std::vector{BlockCache::Want{{4, 0}, counted(calls, 1000, 2.0f)}}, nullptr, &s);
  ASSERT_TRUE(again.ok());
  EXPECT_EQ(s.hits + s.joins, 1u);
  EXPECT_EQ(calls.load(), 1);
}

TEST(BlockCache, SourcesHaveDistinctKeys) {
  EXPECT_NE(BlockCache::next_source_id(), BlockCache::next_source_id());
}

// A built block: `n` floats, a size for the budget.
struct Built {
  std::vector<float> cells;
  std::uint64_t bytes() const { return cells.size() * sizeof(float); }
};

TEST(BlockCache, BuiltBlocksAreKeptBesideDecodedOnesUnderOneBudget) {
  BlockCache cache(cache_of(3 * kBlockBytes, 1));
  std::atomic<int> decodes{0};
  int builds = 0;
  const auto make = [&builds](float v) {
    return [&builds, v]() -> Result<Built> {
      ++builds;
      return Built{std::vector<float>(1000, v)};
    };
  };
  FetchStats s;
  auto a = cache.build<Built>({5, 1}, make(1.0f), nullptr, &s);
  ASSERT_TRUE(a.ok());
  EXPECT_EQ(s.misses, 1u);
  auto again = cache.build<Built>({5, 1}, make(9.0f), nullptr, &s);  // a hit: make is not called
  ASSERT_TRUE(again.ok());
  EXPECT_EQ(s.hits, 1u);
  EXPECT_EQ(builds, 1);
  EXPECT_EQ(a->get(), again->get());
  EXPECT_EQ((*again)->cells[0], 1.0f);
  EXPECT_EQ(cache.stats().builds, 1u);
  EXPECT_EQ(cache.stats().resident_bytes, kBlockBytes);
  // Three decoded blocks fill the budget: the built one, least recently used, goes first.
  std::vector<BlockCache::Want> wants;
  for (int b = 0; b < 3; ++b) wants.push_back({{7, static_cast<std::uint64_t>(b)}, counted(decodes, 1000, 0.0f)});
  ASSERT_TRUE(cache.fetch(wants).ok());
  const BlockCacheStats st = cache.stats();
  EXPECT_EQ(st.resident_bytes, 3 * kBlockBytes);
  EXPECT_EQ(st.evictions, 1u);
  EXPECT_EQ(cache.resident_bytes_of(5), 0u);
  // Still held here after its eviction: counted apart, and freed with the last holder.
  EXPECT_EQ(st.held_bytes, kBlockBytes);
  a = Error{};
  again = Error{};
  EXPECT_EQ(cache.stats().held_bytes, 0u);
  // Asked for again, it is built again.
  ASSERT_TRUE(cache.build<Built>({5, 1}, make(2.0f)).ok());
  EXPECT_EQ(builds, 2);
  EXPECT_LE(cache.stats().peak_resident_bytes, 3 * kBlockBytes);
}

TEST(BlockCache, ConcurrentBuildsOfOneKeyRunOnce) {
  BlockCache cache(cache_of(100 * kBlockBytes, 1));
  std::atomic<int> builds{0}, same{0};
  std::atomic<std::uint64_t> joins{0};
  std::atomic<const Built*> first{nullptr};
  std::vector<std::thread> threads;
  for (int t = 0; t < 6; ++t)
    threads.emplace_back([&] {
      FetchStats s;
      auto got = cache.build<Built>(
          {11, 3},
          [&builds]() -> Result<Built> {
            ++builds;
            std::this_thread::sleep_for(std::chrono::milliseconds(50));
            return Built{std::vector<float>(10, 4.0f)};
          },
          nullptr, &s);
      if (!got.ok() || (*got)->cells[9] != 4.0f) return;
      const Built* expected = nullptr;
      if (first.compare_exchange_strong(expected, got->get()) || expected == got->get()) ++same;
      joins += s.joins;
    });
  for (auto& t : threads) t.join();
  EXPECT_EQ(builds.load(), 1);
  EXPECT_EQ(same.load(), 6);
  EXPECT_EQ(joins.load() + cache.stats().hits, 5u);  // the others joined the build or found it resident
}

TEST(BlockCache, AFailedBuildFailsItsCallersAndIsNotKept) {
  BlockCache cache(cache_of(100 * kBlockBytes, 1));
  int calls = 0;
  const auto broken = [&calls]() -> Result<Built> {
    ++calls;
    return make_error(ErrorCode::kDataError, "tile.tif: block 4 is corrupt");
  };
  auto got = cache.build<Built>({12, 4}, broken);
  ASSERT_FALSE(got.ok());
  EXPECT_EQ(got.error().message, "tile.tif: block 4 is corrupt");
  EXPECT_EQ(cache.stats().failures, 1u);
  EXPECT_EQ(cache.stats().resident_blocks, 0u);
  auto retry = cache.build<Built>({12, 4}, [&calls]() -> Result<Built> {
    ++calls;
    return Built{std::vector<float>(3, 1.0f)};
  });
  ASSERT_TRUE(retry.ok());  // the failure was not kept
  EXPECT_EQ(calls, 2);
}

}  // namespace
}  // namespace horizon::terrain
