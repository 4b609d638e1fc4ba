// Deterministic observer positions of different character on a DEM, for
// accuracy runs: summit, ridge, valley and near an edge. They are the first
// four picks of `horizon bench` (evaluation::pick_observers), so the accuracy
// report and the benchmark talk about the same observers.
#pragma once

#include <vector>

#include "horizon/evaluation/bench.hpp"
#include "horizon/geodesy/observer.hpp"
#include "horizon/terrain/dem.hpp"

namespace horizon::accuracy {

using ObserverPick = evaluation::ObserverPick;  // kind ("summit", "ridge", "valley", "edge"), col, row

// summit: the highest valid cell. ridge: among cells at the 85th elevation
// percentile, the one nearest the DEM centre. valley: the same at the 10th
// percentile. edge: the first valid cell of the middle row, 3 cells in from
// the west edge (or further in, past voids).
inline std::vector<ObserverPick> pick_observers(const terrain::Dem& dem) {
  return evaluation::pick_observers(dem, 4);
}

// The eye of a pick: the centre of its cell, `height` metres above ground.
inline Result<geodesy::GridPoint> pick_eye(const terrain::Dem& dem, const ObserverPick& pick, double height) {
  geodesy::PointSpec spec;
  spec.x = dem.georef.transform.x_at(pick.col);
  spec.y = dem.georef.transform.y_at(pick.row);
  spec.height = height;
  return geodesy::resolve_point(dem, spec, "observer");
}

}  // namespace horizon::accuracy
