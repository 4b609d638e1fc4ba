// horizon/visibility/agreement.hpp — how far a viewshed is from a reference.
//
// The measures of ../shared/DESIGN.md: visible-set IoU, missed-visible rate
// (visible in the reference, hidden here — the dangerous error), extra-visible
// rate, and OHF error in metres (on the OHF floored at the terrain). The
// observer's own cell and its 8 neighbours are excluded, as are cells either
// side has no answer for.
#pragma once

#include <cstdint>

#include "horizon/visibility/viewshed.hpp"

namespace horizon::visibility {

struct Agreement {
  std::uint64_t cells_compared = 0;
  std::uint64_t reference_visible = 0;
  std::uint64_t both_visible = 0;
  std::uint64_t missed_visible = 0;   // reference visible, test hidden
  std::uint64_t extra_visible = 0;    // reference hidden, test visible
  double iou = 1.0;                   // both / (both + missed + extra); 1 when nothing is visible anywhere
  double missed_rate = 0.0;           // missed / reference_visible
  double extra_rate = 0.0;            // extra / reference_visible
  double agreement = 1.0;             // (compared - missed - extra) / compared
  double ohf_rmse = 0.0;              // metres
  double ohf_max_error = 0.0;         // metres
};

// Both results must come from the same DEM, observer and window.
Agreement compare_viewsheds(const ViewshedResult& test, const ViewshedResult& reference, double target_height);

}  // namespace horizon::visibility
