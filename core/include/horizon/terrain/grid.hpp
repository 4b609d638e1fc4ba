// horizon/terrain/grid.hpp — a dense row-major 2-D array of cells.
//
// Frame: column c grows east (x), row r grows south (down the image), cell
// (0, 0) is the first value stored. Throughout the engine the *centre* of cell
// (c, r) sits at continuous grid coordinates (c, r); the cell covers
// [c - 0.5, c + 0.5] x [r - 0.5, r + 0.5]. A Grid owns its storage (large
// ones mapped and populated whole: horizon/common/large_allocator.hpp).
#pragma once

#include <cassert>
#include <cstddef>
#include <cstdint>
#include <span>
#include <utility>
#include <vector>

#include "horizon/common/large_allocator.hpp"

namespace horizon::terrain {

// A half-open rectangle of cells: columns [col0, col1), rows [row0, row1).
struct Window {
  int col0 = 0, row0 = 0, col1 = 0, row1 = 0;

  int width() const { return col1 - col0; }
  int height() const { return row1 - row0; }
  bool empty() const { return col1 <= col0 || row1 <= row0; }
  std::size_t cell_count() const {
    return empty() ? 0 : static_cast<std::size_t>(width()) * static_cast<std::size_t>(height());
  }
  bool contains(int col, int row) const { return col >= col0 && col < col1 && row >= row0 && row < row1; }
  // The cells in both (empty() when they do not meet).
  Window intersect(const Window& o) const {
    return {col0 > o.col0 ? col0 : o.col0, row0 > o.row0 ? row0 : o.row0, col1 < o.col1 ? col1 : o.col1,
            row1 < o.row1 ? row1 : o.row1};
  }
  friend bool operator==(const Window&, const Window&) = default;
};

// Tag for a Grid whose cells are left unset, for a caller about to write
// every one of them (a reader decoding a whole window, a pass over all cells).
struct Uninitialized {};
inline constexpr Uninitialized kUninitialized{};

template <class T>
class Grid {
 public:
  Grid() = default;
  Grid(int width, int height, T fill = T{})
      : width_(width), height_(height),
        cells_(static_cast<std::size_t>(width) * static_cast<std::size_t>(height), fill) {
    assert(width >= 0 && height >= 0);
  }
  // Cells unset (whatever the memory holds): the caller must write them all.
  Grid(int width, int height, Uninitialized)
      : width_(width), height_(height), cells_(static_cast<std::size_t>(width) * static_cast<std::size_t>(height)) {
    assert(width >= 0 && height >= 0);
  }

  // A grid moved from is empty, 0 x 0 (a buffer handed on must not keep the
  // shape of cells it no longer has: reset_output and reshape trust it).
  Grid(const Grid&) = default;
  Grid& operator=(const Grid&) = default;
  Grid(Grid&& other) noexcept
      : width_(std::exchange(other.width_, 0)),
        height_(std::exchange(other.height_, 0)),
        cells_(std::move(other.cells_)) {
    other.cells_.clear();
  }
  Grid& operator=(Grid&& other) noexcept {
    if (this != &other) {
      width_ = std::exchange(other.width_, 0);
      height_ = std::exchange(other.height_, 0);
      cells_ = std::move(other.cells_);
      other.cells_.clear();
    }
    return *this;
  }

  // Makes this a width x height grid, keeping its storage when it is large
  // enough (no new pages, no page faults: for buffers a caller reuses).
  // The cells' values are unspecified afterwards: the caller writes them all.
  void reshape(int width, int height) {
    assert(width >= 0 && height >= 0);
    width_ = width;
    height_ = height;
    cells_.resize(static_cast<std::size_t>(width) * static_cast<std::size_t>(height));
  }
  std::size_t capacity() const { return cells_.capacity(); }

  int width() const { return width_; }
  int height() const { return height_; }
  std::size_t size() const { return cells_.size(); }
  bool empty() const { return cells_.empty(); }
  bool contains(int col, int row) const { return col >= 0 && col < width_ && row >= 0 && row < height_; }

  T& at(int col, int row) { assert(contains(col, row)); return cells_[index(col, row)]; }
  const T& at(int col, int row) const { assert(contains(col, row)); return cells_[index(col, row)]; }

  T* row(int r) { assert(r >= 0 && r < height_); return cells_.data() + static_cast<std::size_t>(r) * width_; }
  const T* row(int r) const { assert(r >= 0 && r < height_); return cells_.data() + static_cast<std::size_t>(r) * width_; }

  T* data() { return cells_.data(); }
  const T* data() const { return cells_.data(); }
  std::span<T> values() { return cells_; }
  std::span<const T> values() const { return cells_; }

  std::size_t index(int col, int row) const {
    return static_cast<std::size_t>(row) * static_cast<std::size_t>(width_) + static_cast<std::size_t>(col);
  }

 private:
  int width_ = 0;
  int height_ = 0;
  std::vector<T, LargeAllocator<T>> cells_;  // large rasters mapped whole (large_allocator.hpp)
};

}  // namespace horizon::terrain
