// Tests for mesh/prepared_cache.cpp: a prepared mesh saved and loaded
// culls exactly as the original; other knobs miss; a cut or damaged file
// is refused (never followed out of bounds) and prepared afresh.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <random>

#include "horizon/mesh/cull.hpp"
#include "horizon/mesh/prepared_cache.hpp"
#include "horizon/mesh/tin_from_dem.hpp"
#include "horizon/terrain/dem_reader.hpp"
#include "test_support.hpp"

namespace horizon::mesh {
namespace {

const Tin& tin() {
  static const Tin t = [] {
    auto dem = terrain::read_dem(testing::bundled_dem("ecuador_andes_utm17s_10m_383x415.tif"));
    EXPECT_TRUE(dem.ok());
    auto built = tin_from_dem(*dem, {1500, 0.0});
    EXPECT_TRUE(built.ok());
    return built->tin;
  }();
  return t;
}

PrepareOptions options() {
  PrepareOptions o;
  o.crystals.seeds = 40;
  o.crystals.max_groups = 100;
  return o;
}

std::string read_bytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), {}};
}

void write_bytes(const std::string& path, const std::string& bytes) {
  std::ofstream(path, std::ios::binary | std::ios::trunc) << bytes;
}

TEST(PreparedCache, ALoadedMeshCullsAsThePreparedOne) {
  testing::TempDir dir;
  CacheUse first, second;
  auto a = prepare_cached(tin(), options(), dir.file("cache"), &first);
  ASSERT_TRUE(a.ok()) << a.error().message;
  EXPECT_FALSE(first.hit);
  EXPECT_TRUE(first.note.empty()) << first.note;
  EXPECT_TRUE(std::filesystem::exists(first.path));
  auto b = prepare_cached(tin(), options(), dir.file("cache"), &second);
  ASSERT_TRUE(b.ok()) << b.error().message;
  EXPECT_TRUE(second.hit);
  EXPECT_EQ(second.path, first.path);
  EXPECT_EQ(a->source_triangle, b->source_triangle);
  EXPECT_EQ(a->tin.triangles, b->tin.triangles);
  EXPECT_EQ(a->regions, b->regions);
  EXPECT_EQ(a->top_level, b->top_level);
  for (std::size_t v = 0; v < tin().vertices.size(); v += 97) {
    for (double above : {2.0, 40.0}) {
      TinVertex camera = tin().vertices[v];
      camera.z += above;
      for (CullMode mode : {CullMode::kApproximate, CullMode::kConservative}) {
        auto x = cull(*a, {camera, {}, {}, mode});
        auto y = cull(*b, {camera, {}, {}, mode});
        ASSERT_TRUE(x.ok() && y.ok());
        EXPECT_EQ(x->visible_groups, y->visible_groups);
        EXPECT_EQ(x->triangles_culled, y->triangles_culled);
      }
    }
  }
  // Other knobs: another name, and the first file does not answer for them.
  PrepareOptions other = options();
  other.crystals.random_seed = 7;
  EXPECT_NE(prepared_cache_name(tin(), other), prepared_cache_name(tin(), options()));
  auto miss = load_prepared(first.path, tin(), other);
  ASSERT_TRUE(miss.ok());
  EXPECT_FALSE(miss->has_value());
  // The thread count is not a knob.
  PrepareOptions threads = options();
  threads.horizons.threads = 1;
  EXPECT_EQ(prepared_cache_name(tin(), threads), prepared_cache_name(tin(), options()));
}

TEST(PreparedCache, ACutOrDamagedFileIsRefusedAndPreparedAfresh) {
  testing::TempDir dir;
  CacheUse use;
  ASSERT_TRUE(prepare_cached(tin(), options(), dir.file("cache"), &use).ok());
  const std::string good = read_bytes(use.path);

  write_bytes(use.path, good.substr(0, good.size() / 2));
  auto cut = load_prepared(use.path, tin(), options());
  ASSERT_FALSE(cut.ok());
  EXPECT_EQ(cut.error().code, ErrorCode::kDataError);
  EXPECT_NE(cut.error().message.find("not a readable prepared mesh (checksum mismatch: damaged or cut short)"),
            std::string::npos)
      << cut.error().message;
  CacheUse again;
  auto fresh = prepare_cached(tin(), options(), dir.file("cache"), &again);
  ASSERT_TRUE(fresh.ok());
  EXPECT_FALSE(again.hit);
  EXPECT_NE(again.note.find("prepared afresh"), std::string::npos) << again.note;
  auto rewritten = load_prepared(use.path, tin(), options());  // rewritten whole
  ASSERT_TRUE(rewritten.ok()) << rewritten.error().message;
  EXPECT_TRUE(rewritten->has_value());

  // Random damage anywhere: the checksum refuses it.
  std::mt19937_64 rng(23);
  const std::size_t tail = 0;
  int refused = 0;
  for (int trial = 0; trial < 200; ++trial) {
    std::string damaged = good;
    for (int k = 0; k < 4; ++k) damaged[tail + rng() % (good.size() - tail)] = static_cast<char>(rng());
    write_bytes(use.path, damaged);
    auto loaded = load_prepared(use.path, tin(), options());
    refused += loaded.ok() ? 0 : 1;
  }
  EXPECT_EQ(refused, 200);
}

}  // namespace
}  // namespace horizon::mesh
