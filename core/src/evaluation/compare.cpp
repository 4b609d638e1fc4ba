// compare.cpp — a peer's raster against R3 (compare.hpp).
#include "horizon/evaluation/compare.hpp"

#include <cassert>
#include <cmath>
#include <limits>

namespace horizon::evaluation {

visibility::Agreement compare_mask(const terrain::Grid<float>& mask, const terrain::Grid<float>* heights,
                                   const visibility::ViewshedResult& reference, double target_height) {
  const auto mask_r = visibility::visibility_mask(reference, target_height);
  const auto ohf_r = visibility::ohf_raster(reference);
  assert(mask.width() == mask_r.width() && mask.height() == mask_r.height());
  const terrain::Window& w = reference.frame.window;
  const double oc = std::round(reference.frame.observer_col), orow = std::round(reference.frame.observer_row);
  visibility::Agreement a;
  double sq = 0;
  std::uint64_t ohf_cells = 0;
  for (int r = 0; r < mask_r.height(); ++r)
    for (int c = 0; c < mask_r.width(); ++c) {
      if (std::abs(c + w.col0 - oc) <= 1 && std::abs(r + w.row0 - orow) <= 1) continue;
      const std::uint8_t vr = mask_r.at(c, r);
      const float vt = mask.at(c, r);
      if (vr == visibility::kNoAnswer || !(vt == 0.0f || vt == 1.0f)) continue;
      const bool test_visible = vt == 1.0f, ref_visible = vr == visibility::kVisible;
      ++a.cells_compared;
      a.reference_visible += ref_visible;
      a.both_visible += ref_visible && test_visible;
      a.missed_visible += ref_visible && !test_visible;
      a.extra_visible += !ref_visible && test_visible;
      if (heights) {
        const float h = heights->at(c, r), z = reference.terrain.at(c, r);
        if (std::isnan(h) || std::isnan(z)) continue;
        const double e = (double(z) + std::max(0.0, double(h))) - double(ohf_r.at(c, r));
        sq += e * e;
        ++ohf_cells;
        a.ohf_max_error = std::max(a.ohf_max_error, std::abs(e));
      }
    }
  const double united = double(a.both_visible + a.missed_visible + a.extra_visible);
  a.iou = united > 0 ? double(a.both_visible) / united : 1.0;
  a.missed_rate = a.reference_visible ? double(a.missed_visible) / double(a.reference_visible) : 0.0;
  a.extra_rate = a.reference_visible ? double(a.extra_visible) / double(a.reference_visible) : 0.0;
  a.agreement =
      a.cells_compared ? double(a.cells_compared - a.missed_visible - a.extra_visible) / double(a.cells_compared) : 1.0;
  if (heights && ohf_cells) {
    a.ohf_rmse = std::sqrt(sq / double(ohf_cells));
  } else {
    a.ohf_rmse = a.ohf_max_error = std::numeric_limits<double>::quiet_NaN();
  }
  return a;
}

}  // namespace horizon::evaluation
