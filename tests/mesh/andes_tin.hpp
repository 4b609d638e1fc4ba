// andes_tin.hpp — the TIN the mesh tests share: 3 000 vertices by greedy
// insertion from the bundled Ecuadorian Andes crop (UTM 17S, 10 m), built
// once per test binary.
#pragma once

#include <gtest/gtest.h>

#include "horizon/mesh/tin_from_dem.hpp"
#include "horizon/terrain/dem_reader.hpp"
#include "test_support.hpp"

namespace horizon::mesh::testing_tins {

inline const Tin& andes_tin() {
  static const Tin tin = [] {
    auto dem = terrain::read_dem(horizon::testing::bundled_dem("ecuador_andes_utm17s_10m_383x415.tif"));
    EXPECT_TRUE(dem.ok()) << dem.error().message;
    auto built = tin_from_dem(*dem, {3000, 0.0});
    EXPECT_TRUE(built.ok()) << built.error().message;
    return built->tin;
  }();
  return tin;
}

}  // namespace horizon::mesh::testing_tins
