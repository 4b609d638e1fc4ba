// horizon/terrain/height_view.hpp — the elevations a kernel reads.
//
// A HeightView borrows a rectangle of float cells laid out in rows `stride`
// floats apart (a whole Grid, a window of one, a buffer a plan assembled) and
// says how its voids read. Every visibility kernel (radial sweep, exact, R3,
// line of sight, culling's ground, the GL upload) takes one, so none of them
// needs its cells copied into a Grid of their own.
//
// Frame: view cell (c, r) is cell (window().col0 + c, window().row0 + r) of
// the raster the view was cut from, whose georeference (when known) is
// georef(); cell centres sit at whole coordinates as in grid.hpp.
//
// Voids: cells hold NaN where the source has no data. at() applies the view's
// void policy as it reads: with void_fill() NaN (transparent, the default)
// a void reads as NaN, which no kernel lets raise a horizon; with a fill
// height a void reads as terrain at that height. A kernel that reads row()
// pointers itself applies fill() to every value it takes, so the two ways
// of reading give the same number for every cell.
//
// Ownership: the view borrows; the cells (and georef) must outlive it and
// stay unchanged while a kernel reads them. Copying a view is cheap.
#pragma once

#include <cassert>
#include <cmath>
#include <cstddef>
#include <limits>

#include "horizon/terrain/georef.hpp"
#include "horizon/terrain/grid.hpp"

namespace horizon::terrain {

class HeightView {
 public:
  // The value of void_fill() that leaves voids as NaN.
  static constexpr float kTransparent = std::numeric_limits<float>::quiet_NaN();

  HeightView() = default;
  // A whole grid, voids transparent. Implicit: a Grid reads as its own view.
  HeightView(const Grid<float>& grid)  // NOLINT(google-explicit-constructor)
      : cells_(grid.data()),
        width_(grid.width()),
        height_(grid.height()),
        stride_(grid.width()),
        window_{0, 0, grid.width(), grid.height()} {}
  HeightView(const float* cells, int width, int height, std::ptrdiff_t stride)
      : cells_(cells), width_(width), height_(height), stride_(stride), window_{0, 0, width, height} {
    assert(width >= 0 && height >= 0 && stride >= width);
  }

  // The same cells with voids reading as `height` (kTransparent: as NaN).
  HeightView with_void_fill(float height) const {
    HeightView v = *this;
    v.fill_ = height;
    return v;
  }
  // The same cells, placed in a raster with this georeference.
  HeightView with_georef(const Georeference* georef) const {
    HeightView v = *this;
    v.georef_ = georef;
    return v;
  }
  // The cells of `w` (view coordinates, inside the view) as a view of their own.
  HeightView sub(const Window& w) const {
    assert(w.col0 >= 0 && w.row0 >= 0 && w.col1 <= width_ && w.row1 <= height_);
    HeightView v = *this;
    v.cells_ = cells_ + static_cast<std::ptrdiff_t>(w.row0) * stride_ + w.col0;
    v.width_ = w.width();
    v.height_ = w.height();
    v.window_ = {window_.col0 + w.col0, window_.row0 + w.row0, window_.col0 + w.col1, window_.row0 + w.row1};
    return v;
  }

  int width() const { return width_; }
  int height() const { return height_; }
  std::size_t cell_count() const { return static_cast<std::size_t>(width_) * static_cast<std::size_t>(height_); }
  std::ptrdiff_t stride() const { return stride_; }  // floats from one row to the next
  bool empty() const { return width_ == 0 || height_ == 0; }
  bool contains(int col, int row) const { return col >= 0 && col < width_ && row >= 0 && row < height_; }

  // Cell (col, row) under the void policy.
  float at(int col, int row) const {
    assert(contains(col, row));
    return fill(cells_[static_cast<std::ptrdiff_t>(row) * stride_ + col]);
  }
  // A stored value under the void policy.
  float fill(float raw) const { return raw == raw ? raw : fill_; }
  // True when the cell holds a void (whatever the policy makes of it).
  bool is_void(int col, int row) const { return std::isnan(raw(col, row)); }
  float raw(int col, int row) const {
    assert(contains(col, row));
    return cells_[static_cast<std::ptrdiff_t>(row) * stride_ + col];
  }

  // Stored values, voids still NaN: readers apply fill() themselves.
  const float* row(int r) const {
    assert(r >= 0 && r < height_);
    return cells_ + static_cast<std::ptrdiff_t>(r) * stride_;
  }
  const float* data() const { return cells_; }

  float void_fill() const { return fill_; }
  bool fills_voids() const { return !std::isnan(fill_); }

  // The view's cells in the raster it was cut from, and that raster's
  // georeference (null when the caller gave none).
  const Window& window() const { return window_; }
  const Georeference* georef() const { return georef_; }

 private:
  const float* cells_ = nullptr;
  int width_ = 0, height_ = 0;
  std::ptrdiff_t stride_ = 0;
  float fill_ = kTransparent;
  Window window_{};
  const Georeference* georef_ = nullptr;
};

// The view's cells under its void policy, into `out` (reshaped to the
// view's size, its storage reused when large enough): for the rasters a
// result keeps, the elevations its answers were computed on.
inline void copy_cells(const HeightView& view, Grid<float>& out) {
  out.reshape(view.width(), view.height());
  for (int r = 0; r < view.height(); ++r) {
    const float* src = view.row(r);
    float* dst = out.row(r);
    for (int c = 0; c < view.width(); ++c) dst[c] = view.fill(src[c]);
  }
}
inline Grid<float> copy_cells(const HeightView& view) {
  Grid<float> out(view.width(), view.height(), kUninitialized);
  copy_cells(view, out);
  return out;
}

}  // namespace horizon::terrain
