// horizon/terrain/height_edit.hpp — dynamic terrain: patches of cells
// changed on top of a source, for one request, with nothing rebuilt.
//
// A crater, a new embankment, a flood, a building's block: an edit names a
// rectangle of cells in the source's grid and sets them to, or raises them
// by, a height (one for the whole patch, or one per cell). Edits apply in
// order to the cells a request has read, never to the source or the shared
// block cache: other requests see the terrain unchanged. The camera trace
// (trace/) needs no preprocessing, so an edited frame costs what an
// unedited one does.
#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include "horizon/common/error.hpp"
#include "horizon/terrain/dem.hpp"
#include "horizon/terrain/grid.hpp"

namespace horizon::terrain {

enum class EditMode {
  kSet,    // the cells become the heights (metres)
  kRaise,  // the heights are added to the cells (negative: lowered); voids stay voids
};

struct HeightEdit {
  Window cells;  // in the source's grid, non-empty, inside it
  // One height for every cell, or one per cell, row-major over `cells`.
  std::vector<float> heights;
  EditMode mode = EditMode::kSet;
};

// The most cells all edits of one request may cover: 16 M (64 MiB of heights).
inline constexpr std::uint64_t kMaxEditCells = std::uint64_t{1} << 24;

// Checks each edit against a source of width x height cells: the window
// inside it and non-empty, 1 or window-size heights, every height finite,
// and the cells of all edits together within kMaxEditCells. Errors name the
// edit ("edits[2].heights").
Status validate_edits(std::span<const HeightEdit> edits, int width, int height);

// Applies the edits in order to `dem`, whose cell (0, 0) is cell (col0,
// row0) of the source; the parts of edits outside it are skipped. Returns
// the cells changed.
std::uint64_t apply_edits(Dem& dem, int col0, int row0, std::span<const HeightEdit> edits);

}  // namespace horizon::terrain
