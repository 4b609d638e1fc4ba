// horizon/visibility/work_stats.hpp — what a computation touched, so that
// "skip what a scene doesn't need" is a number.
#pragma once

#include <cstdint>
#include <string>

namespace horizon::visibility {

struct WorkStats {
  std::uint64_t dem_cells = 0;         // cells in the whole DEM
  std::uint64_t window_cells = 0;      // cells in the max-distance bounding window
  std::uint64_t cells_evaluated = 0;   // target cells given an answer
  std::uint64_t terrain_samples = 0;   // grid-line crossings (terrain interpolations) evaluated
  std::uint64_t rays = 0;              // sight lines traced (radial: sweep rays; R3: one per target)
  double seconds = 0.0;                // wall time of the algorithm itself
  // Where the OHF was computed: "cpu" or "gpu".
  std::string backend = "cpu";
  std::string gpu_variant;  // on the GPU: which GL variant ran ("fragment, log-step", ...)
  // Set when the GPU was asked for (backend gpu, or auto choosing it) but
  // failed and the CPU answered instead: what failed (context lost, out of
  // memory, texture too large). Empty otherwise.
  std::string gpu_fallback;
  // GPU only: time the device spent in the passes themselves (GL timestamp
  // queries around modulation .. resolve), without the upload, the read-back
  // and the OHF's final multiply on the CPU that `seconds` also covers.
  double device_seconds = 0.0;
};

}  // namespace horizon::visibility
