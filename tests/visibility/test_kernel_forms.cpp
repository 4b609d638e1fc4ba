// The whole radial sweep with its kernels capped at each instruction set
// (scalar, AVX2, AVX-512: core/src/visibility/simd.hpp) on the real DEMs
// bundled in data/dem, at summit, ridge, valley and edge observers: fast,
// conservative and exact (whose crossing screen has the forms too,
// exact_screen.hpp) must give the same OHF bits whichever form runs. The kernel
// tests (test_ray_steps.cpp, test_resample_cells.cpp) compare the forms loop
// by loop; this compares what a user gets.
#include <gtest/gtest.h>

#include <cstring>
#include <vector>

#include "horizon/geodesy/observer.hpp"
#include "horizon/terrain/dem_reader.hpp"
#include "horizon/visibility/viewshed.hpp"
#include "observer_picks.hpp"
#include "simd.hpp"
#include "test_support.hpp"
#include "vector_forms.hpp"

namespace horizon {
namespace {

using visibility::sweep::simd::Isa;

class KernelForms : public ::testing::TestWithParam<const char*> {};

std::vector<float> ohf_with(const terrain::Dem& dem, const geodesy::GridPoint& eye, visibility::Algorithm algorithm,
                            Isa isa) {
  visibility::sweep::simd::isa_limit() = isa;
  visibility::ViewshedOptions o;
  o.algorithm = algorithm;
  auto result = visibility::compute_viewshed(dem, eye, o);
  visibility::sweep::simd::isa_limit() = Isa::kAvx512;
  EXPECT_TRUE(result.ok()) << result.error().message;
  if (!result.ok()) return {};
  return {result->ohf.data(), result->ohf.data() + result->ohf.size()};
}

TEST_P(KernelForms, EveryFormGivesTheSameOhf) {
  if (visibility::sweep::simd::cpu_isa() == Isa::kScalar) GTEST_SKIP() << "this CPU runs the scalar kernels only";
  auto dem = terrain::read_dem(testing::bundled_dem(GetParam()));
  ASSERT_TRUE(dem.ok()) << dem.error().message;
  for (const auto& pick : accuracy::pick_observers(*dem)) {
    auto eye = accuracy::pick_eye(*dem, pick, 2.0);
    ASSERT_TRUE(eye.ok()) << eye.error().message;
    for (const auto algorithm :
         {visibility::Algorithm::kRadial, visibility::Algorithm::kConservative, visibility::Algorithm::kExact}) {
      const std::vector<float> scalar = ohf_with(*dem, *eye, algorithm, Isa::kScalar);
      ASSERT_FALSE(scalar.empty());
      for (const Isa isa : {Isa::kAvx2, Isa::kAvx512}) {
        if (visibility::sweep::simd::cpu_isa() < isa) continue;
        const std::vector<float> vector = ohf_with(*dem, *eye, algorithm, isa);
        ASSERT_EQ(vector.size(), scalar.size());
        std::size_t differ = 0;
        for (std::size_t i = 0; i < scalar.size(); ++i)
          differ += std::memcmp(&scalar[i], &vector[i], sizeof(float)) != 0;
        EXPECT_EQ(differ, 0u) << visibility::algorithm_name(algorithm) << ", " << pick.kind << " (" << pick.col << ","
                              << pick.row << "), kernels capped at " << visibility::sweep::isa_name(isa);
      }
    }
  }
}

INSTANTIATE_TEST_SUITE_P(DataDem, KernelForms,
                         ::testing::Values("ecuador_andes_utm17s_10m_383x415.tif",
                                           "everest_summit_voids_srtm3_300x300.tif", "olinda_coast_utm25s_111x111.tif",
                                           "rainier_summit_srtm3_400x400.tif", "zion_canyon_srtm3_465x457.tif"),
                         [](const ::testing::TestParamInfo<const char*>& test) {
                           return testing::dem_name(test.param);
                         });

}  // namespace
}  // namespace horizon
