// Deterministic observer positions of different character on a DEM, for
// accuracy and benchmark runs: summit, ridge, valley and near an edge.
#pragma once

#include <string>
#include <vector>

#include "horizon/terrain/dem.hpp"

namespace horizon::accuracy {

struct ObserverPick {
  std::string kind;  // "summit", "ridge", "valley", "edge"
  int col = 0, row = 0;
};

// summit: the highest valid cell. ridge: among cells at the 85th elevation
// percentile, the one nearest the DEM centre. valley: the same at the 10th
// percentile. edge: the first valid cell of the middle row, 3 cells in from
// the west edge (or further in, past voids).
std::vector<ObserverPick> pick_observers(const terrain::Dem& dem);

}  // namespace horizon::accuracy
