// horizon/evaluation/compare.hpp — the error of a raster from elsewhere (a
// peer program's output) against an R3 result.
//
// The measures and exclusions are visibility::compare_viewsheds()'s: the
// observer's cell and its 8 neighbours are skipped, as are cells either side
// has no answer for; rates are relative to the reference's visible count.
#pragma once

#include "horizon/terrain/grid.hpp"
#include "horizon/visibility/agreement.hpp"
#include "horizon/visibility/viewshed.hpp"

namespace horizon::evaluation {

// `mask` and `heights` are sized like reference.frame.window. mask: 1 visible,
// 0 hidden, anything else (NaN, 255) no answer. heights (may be null): the
// minimum visible target height above the ground, metres; the test OHF is then
// terrain + height and ohf_rmse / ohf_max_error are measured, else both NaN.
visibility::Agreement compare_mask(const terrain::Grid<float>& mask, const terrain::Grid<float>* heights,
                                   const visibility::ViewshedResult& reference, double target_height);

}  // namespace horizon::evaluation
