// Viewshed agreement measures (../shared/DESIGN.md, "How we measure").
#include "horizon/visibility/agreement.hpp"

#include <cassert>
#include <cmath>

namespace horizon::visibility {

Agreement compare_viewsheds(const ViewshedResult& test, const ViewshedResult& reference, double target_height) {
  assert(test.frame.window == reference.frame.window);
  const auto mask_t = visibility_mask(test, target_height);
  const auto mask_r = visibility_mask(reference, target_height);
  const auto ohf_t = ohf_raster(test);
  const auto ohf_r = ohf_raster(reference);
  const terrain::Window& w = reference.frame.window;
  const double oc = std::round(reference.frame.observer_col), orow = std::round(reference.frame.observer_row);

  Agreement a;
  double sq = 0;
  for (int r = 0; r < mask_r.height(); ++r) {
    for (int c = 0; c < mask_r.width(); ++c) {
      if (std::abs(c + w.col0 - oc) <= 1 && std::abs(r + w.row0 - orow) <= 1) continue;  // observer and neighbours
      const std::uint8_t vt = mask_t.at(c, r), vr = mask_r.at(c, r);
      if (vt == kNoAnswer || vr == kNoAnswer) continue;
      ++a.cells_compared;
      a.reference_visible += vr == kVisible;
      a.both_visible += vr == kVisible && vt == kVisible;
      a.missed_visible += vr == kVisible && vt == kHidden;
      a.extra_visible += vr == kHidden && vt == kVisible;
      const double e = double(ohf_t.at(c, r)) - double(ohf_r.at(c, r));
      sq += e * e;
      a.ohf_max_error = std::max(a.ohf_max_error, std::abs(e));
    }
  }
  const double united = double(a.both_visible + a.missed_visible + a.extra_visible);
  a.iou = united > 0 ? a.both_visible / united : 1.0;
  a.missed_rate = a.reference_visible ? double(a.missed_visible) / a.reference_visible : 0.0;
  a.extra_rate = a.reference_visible ? double(a.extra_visible) / a.reference_visible : 0.0;
  a.agreement = a.cells_compared ? double(a.cells_compared - a.missed_visible - a.extra_visible) / a.cells_compared : 1.0;
  a.ohf_rmse = a.cells_compared ? std::sqrt(sq / a.cells_compared) : 0.0;
  return a;
}

}  // namespace horizon::visibility
