// Dynamic terrain edits (horizon/terrain/height_edit.hpp).
#include "horizon/terrain/height_edit.hpp"

#include <algorithm>
#include <cmath>
#include <string>

namespace horizon::terrain {

Status validate_edits(std::span<const HeightEdit> edits, int width, int height) {
  std::uint64_t cells = 0;
  for (std::size_t i = 0; i < edits.size(); ++i) {
    const HeightEdit& e = edits[i];
    const std::string name = "edits[" + std::to_string(i) + "]";
    const Window& w = e.cells;
    if (w.col0 < 0 || w.row0 < 0 || w.col1 > width || w.row1 > height || w.col0 >= w.col1 || w.row0 >= w.row1)
      return make_error(ErrorCode::kOutOfRange,
                        name + ".cells: " + std::to_string(w.col0) + ".." + std::to_string(w.col1) + " x " +
                            std::to_string(w.row0) + ".." + std::to_string(w.row1) +
                            " must be a non-empty window inside the dataset's " + std::to_string(width) + "x" +
                            std::to_string(height) + " cells",
                        name + ".cells");
    if (e.heights.size() != 1 && e.heights.size() != w.cell_count())
      return make_error(ErrorCode::kInvalidArgument,
                        name + ".heights: " + std::to_string(e.heights.size()) + " heights for a window of " +
                            std::to_string(w.cell_count()) + " cells (give 1, or 1 per cell)",
                        name + ".heights");
    for (float h : e.heights)
      if (!std::isfinite(h) || std::abs(h) > 100000.0f)
        return make_error(ErrorCode::kInvalidArgument,
                          name + ".heights: must be finite metres within +-100 km, got " + number_text(h),
                          name + ".heights");
    cells += w.cell_count();
    if (cells > kMaxEditCells)
      return make_error(
          ErrorCode::kResourceExhausted,
          "edits: " + std::to_string(cells) + " cells or more, over the limit of " + std::to_string(kMaxEditCells),
          "edits");
  }
  return Status::Ok();
}

std::uint64_t apply_edits(Dem& dem, int col0, int row0, std::span<const HeightEdit> edits) {
  std::uint64_t changed = 0;
  for (const HeightEdit& e : edits) {
    const int c0 = std::max(e.cells.col0, col0), c1 = std::min(e.cells.col1, col0 + dem.width());
    const int r0 = std::max(e.cells.row0, row0), r1 = std::min(e.cells.row1, row0 + dem.height());
    for (int r = r0; r < r1; ++r)
      for (int c = c0; c < c1; ++c) {
        const float h =
            e.heights.size() == 1
                ? e.heights[0]
                : e.heights[static_cast<std::size_t>(r - e.cells.row0) * static_cast<std::size_t>(e.cells.width()) +
                            static_cast<std::size_t>(c - e.cells.col0)];
        float& cell = dem.elevation.at(c - col0, r - row0);
        cell = e.mode == EditMode::kSet ? h : cell + h;  // a void raised stays a void (NaN + h)
        ++changed;
      }
  }
  return changed;
}

}  // namespace horizon::terrain
