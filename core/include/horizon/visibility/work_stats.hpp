// horizon/visibility/work_stats.hpp — what a computation touched, so that
// "skip what a scene doesn't need" is a number.
#pragma once

#include <cstdint>

namespace horizon::visibility {

struct WorkStats {
  std::uint64_t dem_cells = 0;         // cells in the whole DEM
  std::uint64_t window_cells = 0;      // cells in the max-distance bounding window
  std::uint64_t cells_evaluated = 0;   // target cells given an answer
  std::uint64_t terrain_samples = 0;   // grid-line crossings (terrain interpolations) evaluated
  std::uint64_t rays = 0;              // sight lines traced (radial: sweep rays; R3: one per target)
  double seconds = 0.0;                // wall time of the algorithm itself
};

}  // namespace horizon::visibility
