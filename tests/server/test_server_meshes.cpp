// The daemon's mesh registry (server/src/meshes.hpp) in process: a mesh's
// prepared size is reserved in the memory budget (and one that does not fit
// fails the load, naming it, leaving the running set as it was), a reload
// reuses an unchanged mesh and prepares a changed one again.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "config.hpp"
#include "datasets.hpp"
#include "meshes.hpp"
#include "test_support.hpp"

namespace horizon::server {
namespace {

// A 30 x 30 lattice with a ridge across it, as OBJ.
void write_ridge(const std::string& path, double height) {
  std::ofstream out(path);
  const int n = 30;
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) out << "v " << i * 10 << ' ' << j * 10 << ' ' << (i == 15 ? height : 0.0) << '\n';
  for (int j = 0; j + 1 < n; ++j)
    for (int i = 0; i + 1 < n; ++i) {
      const int a = j * n + i + 1, b = a + 1, c = a + n, d = c + 1;
      out << "f " << a << ' ' << b << ' ' << d << "\nf " << a << ' ' << d << ' ' << c << '\n';
    }
}

Config config_for(const testing::TempDir& root, const std::string& meshes) {
  auto c = parse_config(R"({"listen": "127.0.0.1:0", "plaintext": true, "data_root": ")" + root.path().string() +
                            R"(", "datasets": {}, "memory_budget_mb": 64, "meshes": )" + meshes + "}",
                        "meshes.json", root.path());
  EXPECT_TRUE(c.ok()) << c.error().message;
  return *c;
}

TEST(ServerMeshes, PreparedMeshesAreHeldInTheBudgetAndReusedWhenUnchanged) {
  testing::TempDir root;
  write_ridge(root.file("ridge.obj"), 50);
  const Config config = config_for(root, R"({"ridge": {"file": "ridge.obj", "min_group": 5}})");
  MemoryBudget memory(256ull << 20);
  MeshRegistry registry(memory, nullptr, 1);
  ASSERT_TRUE(registry.load(config, {}).ok());
  const auto first = registry.snapshot();
  ASSERT_EQ(first->size(), 1u);
  const ServedMesh& ridge = *first->at("ridge");
  EXPECT_EQ(ridge.source, "file:ridge.obj");
  EXPECT_GT(ridge.memory.bytes(), 0u);
  EXPECT_EQ(ridge.memory.bytes(), ridge.model.memory_bytes());
  EXPECT_EQ(memory.reserved(), ridge.memory.bytes());

  // Unchanged: the same prepared mesh, nothing reserved twice.
  ASSERT_TRUE(registry.load(config, {}).ok());
  EXPECT_EQ(registry.snapshot()->at("ridge"), first->at("ridge"));
  EXPECT_EQ(memory.reserved(), ridge.memory.bytes());

  // A knob changed: prepared again; the old one is freed with the last snapshot.
  const Config knob = config_for(root, R"({"ridge": {"file": "ridge.obj", "min_group": 6}})");
  ASSERT_TRUE(registry.load(knob, {}).ok());
  const auto second = registry.snapshot();
  EXPECT_NE(second->at("ridge"), first->at("ridge"));
  // `first` still holds the old one.
  EXPECT_EQ(memory.reserved(), ridge.memory.bytes() + second->at("ridge")->memory.bytes());

  // The file rewritten (another size): prepared again.
  write_ridge(root.file("ridge.obj"), 1234.5);
  ASSERT_TRUE(registry.load(knob, {}).ok());
  EXPECT_NE(registry.snapshot()->at("ridge"), second->at("ridge"));
}

TEST(ServerMeshes, AMeshThatDoesNotFitFailsTheLoadNamingIt) {
  testing::TempDir root;
  write_ridge(root.file("ridge.obj"), 50);
  const Config config = config_for(root, R"({"ridge": {"file": "ridge.obj", "min_group": 5}})");
  MemoryBudget roomy(256ull << 20);
  MeshRegistry measure(roomy, nullptr, 1);
  ASSERT_TRUE(measure.load(config, {}).ok());
  const std::uint64_t bytes = measure.snapshot()->at("ridge")->memory.bytes();

  MemoryBudget tight(MemoryBudget::kBaseBytes + bytes - 1);
  MeshRegistry registry(tight, nullptr, 1);
  const Status s = registry.load(config, {});
  ASSERT_FALSE(s.ok());
  EXPECT_EQ(s.error().code, ErrorCode::kResourceExhausted);
  EXPECT_EQ(s.error().field, "meshes.ridge");
  EXPECT_NE(s.error().message.find("memory_budget_mb"), std::string::npos) << s.error().message;
  EXPECT_TRUE(registry.snapshot()->empty());
  EXPECT_EQ(tight.reserved(), 0u);

  // Room for the prepared mesh but not for preparing it: refused before the
  // preparation starts, naming what did not fit.
  const std::uint64_t working = mesh::preparation_bytes(30 * 30, config.meshes[0].prepare, 1);
  ASSERT_GT(working, bytes);
  MemoryBudget no_room_to_work(MemoryBudget::kBaseBytes + working - 1);
  MeshRegistry cramped(no_room_to_work, nullptr, 1);
  const Status preparing = cramped.load(config, {});
  ASSERT_FALSE(preparing.ok());
  EXPECT_EQ(preparing.error().code, ErrorCode::kResourceExhausted);
  EXPECT_EQ(preparing.error().field, "meshes.ridge");
  EXPECT_NE(preparing.error().message.find("preparing its 900 vertices needs about"), std::string::npos)
      << preparing.error().message;
  EXPECT_EQ(preparing.error().message.find("config 'meshes.json': meshes.ridge: config"), std::string::npos)
      << preparing.error().message;  // said once
  EXPECT_EQ(no_room_to_work.reserved(), 0u);

  // A bad mesh file fails the load naming the mesh, and the set stays as it was.
  std::ofstream(root.file("bad.obj")) << "v 0 0 0\nv 1 0 0\nv 0 1 nan\nf 1 2 3\n";
  ASSERT_TRUE(measure.load(config, {}).ok());
  const Config bad =
      config_for(root, R"({"ridge": {"file": "ridge.obj", "min_group": 5}, "bad": {"file": "bad.obj"}})");
  const Status refused = measure.load(bad, {});
  ASSERT_FALSE(refused.ok());
  EXPECT_EQ(refused.error().field, "meshes.bad") << refused.error().message;
  EXPECT_EQ(measure.snapshot()->size(), 1u);

  // A stop while loading (SIGTERM: main.cpp cancels the load) ends the
  // preparation; nothing is swapped in or held.
  CancelToken stop;
  stop.cancel();
  RunControl control;
  control.cancel = &stop;
  MemoryBudget fresh(256ull << 20);
  MeshRegistry stopped(fresh, nullptr, 1);
  const Status cancelled = stopped.load(config, {}, &control);
  ASSERT_FALSE(cancelled.ok());
  EXPECT_EQ(cancelled.error().code, ErrorCode::kCancelled) << cancelled.error().message;
  EXPECT_TRUE(stopped.snapshot()->empty());
  EXPECT_EQ(fresh.reserved(), 0u);

  const Config missing = config_for(root, R"({"gone": {"file": "gone.obj"}})");
  const Status not_found = measure.load(missing, {});
  ASSERT_FALSE(not_found.ok());
  EXPECT_EQ(not_found.error().code, ErrorCode::kNotFound);
  EXPECT_EQ(not_found.error().field, "meshes.gone.file");
}

// A dataset's TIN reads the whole DEM: a dataset over limits.max_cells is
// refused before any cell is read; under it, the TIN is built and held.
TEST(ServerMeshes, ADatasetsTinIsBoundedByMaxCells) {
  testing::TempDir root;
  std::filesystem::copy_file(testing::bundled_dem("olinda_coast_utm25s_111x111.tif"), root.file("olinda.tif"));
  for (const std::uint64_t max_cells : {12'000u, 13'000u}) {  // the DEM has 111 x 111 = 12 321 cells
    auto c = parse_config(R"({"listen": "127.0.0.1:0", "plaintext": true, "data_root": ")" + root.path().string() +
                              R"(", "datasets": {"olinda": "olinda.tif"}, "memory_budget_mb": 64,
                                 "limits": {"max_cells": )" +
                              std::to_string(max_cells) + R"(},
                                 "meshes": {"tin": {"dataset": "olinda", "vertices": 500}}})",
                          "cells.json", root.path());
    ASSERT_TRUE(c.ok()) << c.error().message;
    DatasetRegistry datasets(nullptr, 1);
    ASSERT_TRUE(datasets.load(*c).ok());
    MemoryBudget memory(256ull << 20);
    MeshRegistry meshes(memory, nullptr, 1);
    const Status s = meshes.load(*c, *datasets.snapshot());
    if (max_cells < 12'321) {
      ASSERT_FALSE(s.ok());
      EXPECT_EQ(s.error().code, ErrorCode::kResourceExhausted);
      EXPECT_EQ(s.error().field, "meshes.tin.dataset");
      EXPECT_NE(s.error().message.find("12321 cells, more than limits.max_cells = 12000"), std::string::npos)
          << s.error().message;
      EXPECT_EQ(memory.reserved(), 0u);
    } else {
      ASSERT_TRUE(s.ok()) << s.error().message;
      EXPECT_EQ(meshes.snapshot()->at("tin")->model.prepared().tin.vertices.size(), 500u);
      EXPECT_EQ(memory.reserved(), meshes.snapshot()->at("tin")->memory.bytes());
    }
  }
}

}  // namespace
}  // namespace horizon::server
