// Min / max / mean pyramids, built block by block on first use. The min
// pyramid and its exact rectangle query are the hierarchical Z-buffer of
// Greene, Kass and Miller, "Hierarchical Z-Buffer Visibility" (SIGGRAPH
// 1993), used on the occlusion height field; the max pyramid bounds terrain
// along sight lines (visibility/exact.cpp). See pyramid.hpp.
#include "horizon/terrain/pyramid.hpp"

#include <algorithm>
#include <bit>
#include <cassert>
#include <cmath>
#include <limits>
#include <utility>

#include "horizon/common/parallel.hpp"

namespace horizon::terrain {
namespace {

constexpr float kInf = std::numeric_limits<float>::infinity();
constexpr int kMaxFactor = 8;

// A pyramid cell and its value.
struct Cell {
  float value;
  int i, j;
};

// Orders cells best first (insertion sort, stable: std::sort on a
// four-element array trips GCC 12's -Warray-bounds).
template <class Better>
void sort_cells(Cell* cells, int n, Better better) {
  for (int a = 1; a < n; ++a)
    for (int b = a; b > 0 && better(cells[b].value, cells[b - 1].value); --b) std::swap(cells[b], cells[b - 1]);
}

// The reduction of two values (min, max: NaN never reaches here).
float combine(Reduction r, float a, float b) {
  return r == Reduction::kMin ? std::min(a, b) : std::max(a, b);
}

// Spans of one level: each cell with its east neighbour, south neighbour
// and the 2x2 cells it leads, clamped to the level.
void fill_spans(Reduction r, PyramidLevel& level) {
  const int w = level.width, h = level.height;
  const std::size_t n = level.values.size();
  level.east.resize(n);
  level.south.resize(n);
  level.quad.resize(n);
  const auto at = [&](int j, int i) { return level.values[static_cast<std::size_t>(j) * w + i]; };
  for (int j = 0; j < h; ++j)
    for (int i = 0; i < w; ++i) {
      const int i1 = std::min(i + 1, w - 1), j1 = std::min(j + 1, h - 1);
      const std::size_t k = static_cast<std::size_t>(j) * w + i;
      level.east[k] = combine(r, at(j, i), at(j, i1));
      level.south[k] = combine(r, at(j, i), at(j1, i));
      level.quad[k] = combine(r, level.east[k], combine(r, at(j1, i), at(j1, i1)));
    }
}

}  // namespace

Pyramid::Pyramid(const HeightView& source, const Window& window, Reduction reduction, PyramidShape shape,
                 PyramidOptions options)
    : source_(source),
      window_(window),
      reduction_(reduction),
      factor_(shape.factor),
      log_factor_(std::countr_zero(static_cast<unsigned>(shape.factor))),
      width_(window.width()),
      height_(window.height()),
      block_cells_(options.block_cells),
      log_block_(std::countr_zero(static_cast<unsigned>(options.block_cells))),
      spans_(options.spans) {
  assert(window.col0 >= 0 && window.row0 >= 0 && window.col1 <= source.width() && window.row1 <= source.height());
  assert(std::has_single_bit(static_cast<unsigned>(factor_)) && factor_ >= 2 && factor_ <= kMaxFactor);
  assert(std::has_single_bit(static_cast<unsigned>(block_cells_)) && block_cells_ >= factor_);
  assert(!spans_ || reduction_ != Reduction::kMean);
  if (shape.levels == PyramidShape::kToOneCell) {
    level_count_ = 1;
    for (int lw = width_, lh = height_; lw > 1 || lh > 1;
         lw = (lw + factor_ - 1) / factor_, lh = (lh + factor_ - 1) / factor_)
      ++level_count_;
  } else {
    assert(shape.levels >= 0 && (shape.levels + 1) * log_factor_ < 31);
    level_count_ = shape.levels + 1;
  }
  for (int l = 0; l < level_count_; ++l) {
    const int shift = l * log_factor_;
    level_w_.push_back(((width_ - 1) >> shift) + 1);
    level_h_.push_back(((height_ - 1) >> shift) + 1);
  }
  if (window.empty()) {  // nothing to reduce; no query is possible
    width_ = height_ = level_count_ = 0;
    level_w_.clear();
    level_h_.clear();
  }
  block_levels_ = std::max(0, std::min(level_count_ - 1, log_block_ / log_factor_));
  blocks_x_ = ((width_ - 1) >> log_block_) + 1;
  blocks_y_ = ((height_ - 1) >> log_block_) + 1;
  invalidate();
}

void Pyramid::invalidate() {
  slots_ = std::make_unique<Slot[]>(block_count());
  flat_.clear();
  blocks_built_.store(0, std::memory_order_relaxed);
  upper_.clear();
  for (int l = block_levels_ + 1; l < level_count_; ++l) {
    UpperLevel u;
    u.cells.width = level_width(l);
    u.cells.height = level_height(l);
    const std::size_t n = static_cast<std::size_t>(u.cells.width) * u.cells.height;
    u.cells.values.assign(n, 0.0f);
    if (reduction_ == Reduction::kMean) u.cells.counts.assign(n, 0);
    u.once = std::make_unique<std::once_flag[]>(n);
    upper_.push_back(std::move(u));
  }
}

float Pyramid::source_cell(int i, int j) const {
  const float v = source_.fill(source_.row(window_.row0 + j)[window_.col0 + i]);
  return reduction_ != Reduction::kMean && std::isnan(v) ? -kInf : v;
}

PyramidBlock reduce_block(const HeightView& cells, Reduction reduction, int factor, int levels) {
  assert(std::has_single_bit(static_cast<unsigned>(factor)) && factor >= 2 && factor <= kMaxFactor);
  assert(levels >= 1 && !cells.empty());
  const int log_factor = std::countr_zero(static_cast<unsigned>(factor));
  const int bw = cells.width(), bh = cells.height();
  PyramidBlock out;
  out.levels.resize(static_cast<std::size_t>(levels));
  const bool mean = reduction == Reduction::kMean;
  std::vector<double> sums, below_sums;  // kMean: exact sums of the valid cells below, per cell

  // Level 1 from the source.
  {
    PyramidLevel& l1 = out.levels[0];
    l1.width = ((bw - 1) >> log_factor) + 1;
    l1.height = ((bh - 1) >> log_factor) + 1;
    const std::size_t n = static_cast<std::size_t>(l1.width) * l1.height;
    if (mean) {
      sums.assign(n, 0.0);
      l1.counts.assign(n, 0);
    }
    l1.values.assign(n, reduction == Reduction::kMin ? kInf : -kInf);
    for (int r = 0; r < bh; ++r) {
      const float* src = cells.row(r);
      const std::size_t base = static_cast<std::size_t>(r >> log_factor) * l1.width;
      float* dst = l1.values.data() + base;
      switch (reduction) {
        case Reduction::kMin:
          for (int c = 0; c < bw; ++c) {
            const float z = cells.fill(src[c]);
            const float v = std::isnan(z) ? -kInf : z;
            float& m = dst[c >> log_factor];
            m = std::min(m, v);
          }
          break;
        case Reduction::kMax:
          for (int c = 0; c < bw; ++c) {
            const float v = cells.fill(src[c]);
            float& m = dst[c >> log_factor];
            if (v > m) m = v;  // NaN never wins
          }
          break;
        case Reduction::kMean:
          for (int c = 0; c < bw; ++c) {
            const float v = cells.fill(src[c]);
            if (!std::isnan(v)) {
              sums[base + (c >> log_factor)] += v;
              ++l1.counts[base + (c >> log_factor)];
            }
          }
          break;
      }
    }
  }
  // Levels 2.. from the level below, within the block.
  for (int l = 2; l <= levels; ++l) {
    const PyramidLevel& below = out.levels[static_cast<std::size_t>(l - 2)];
    PyramidLevel& level = out.levels[static_cast<std::size_t>(l - 1)];
    level.width = ((below.width - 1) >> log_factor) + 1;
    level.height = ((below.height - 1) >> log_factor) + 1;
    const std::size_t n = static_cast<std::size_t>(level.width) * level.height;
    level.values.assign(n, reduction == Reduction::kMin ? kInf : -kInf);
    if (mean) {
      below_sums.swap(sums);
      sums.assign(n, 0.0);
      level.counts.assign(n, 0);
    }
    for (int j = 0; j < below.height; ++j)
      for (int i = 0; i < below.width; ++i) {
        const std::size_t from = static_cast<std::size_t>(j) * below.width + i;
        const std::size_t to = static_cast<std::size_t>(j >> log_factor) * level.width + (i >> log_factor);
        if (mean) {
          sums[to] += below_sums[from];
          level.counts[to] += below.counts[from];
        } else {
          level.values[to] = combine(reduction, level.values[to], below.values[from]);
        }
      }
    // The level below is final now: its means from its sums.
    if (mean) {
      PyramidLevel& b = out.levels[static_cast<std::size_t>(l - 2)];
      for (std::size_t k = 0; k < b.values.size(); ++k)
        b.values[k] = b.counts[k] ? static_cast<float>(below_sums[k] / b.counts[k]) : std::nanf("");
    }
  }
  if (mean && levels >= 1) {
    PyramidLevel& top = out.levels[static_cast<std::size_t>(levels - 1)];
    for (std::size_t k = 0; k < top.values.size(); ++k)
      top.values[k] = top.counts[k] ? static_cast<float>(sums[k] / top.counts[k]) : std::nanf("");
  }
  return out;
}

void Pyramid::fill_block(int bi, int bj, PyramidBlock& out) const {
  const int c0 = bi << log_block_, r0 = bj << log_block_;
  const int bw = std::min(block_cells_, width_ - c0), bh = std::min(block_cells_, height_ - r0);
  const Window cells{window_.col0 + c0, window_.row0 + r0, window_.col0 + c0 + bw, window_.row0 + r0 + bh};
  out = reduce_block(source_.sub(cells), reduction_, factor_, block_levels_);
}

const PyramidBlock& Pyramid::build_block(int bi, int bj) const {
  Slot& s = slots_[static_cast<std::size_t>(bj) * blocks_x_ + bi];
  std::call_once(s.once, [&] {
    auto b = std::make_unique<PyramidBlock>();
    fill_block(bi, bj, *b);
    s.ready.store(b.get(), std::memory_order_release);
    s.block = std::move(b);
    blocks_built_.fetch_add(1, std::memory_order_relaxed);
  });
  return *s.ready.load(std::memory_order_acquire);
}

const PyramidBlock& Pyramid::block(int bi, int bj) const {
  const PyramidBlock* b = slots_[static_cast<std::size_t>(bj) * blocks_x_ + bi].ready.load(std::memory_order_acquire);
  return b ? *b : build_block(bi, bj);
}

void Pyramid::ensure_upper(int l, int i, int j) const {
  UpperLevel& u = upper_[static_cast<std::size_t>(l - block_levels_ - 1)];
  const std::size_t k = static_cast<std::size_t>(j) * u.cells.width + i;
  std::call_once(u.once[k], [&] {
    const int i1 = std::min((i + 1) * factor_, level_width(l - 1));
    const int j1 = std::min((j + 1) * factor_, level_height(l - 1));
    if (reduction_ == Reduction::kMean) {
      double sum = 0;
      std::uint32_t n = 0;
      for (int jj = j * factor_; jj < j1; ++jj)
        for (int ii = i * factor_; ii < i1; ++ii) {
          const std::uint32_t c = count(l - 1, ii, jj);
          if (c) sum += double(value(l - 1, ii, jj)) * c;
          n += c;
        }
      u.cells.counts[k] = n;
      u.cells.values[k] = n ? static_cast<float>(sum / n) : std::nanf("");
    } else {
      float m = reduction_ == Reduction::kMin ? kInf : -kInf;
      for (int jj = j * factor_; jj < j1; ++jj)
        for (int ii = i * factor_; ii < i1; ++ii) m = combine(reduction_, m, value(l - 1, ii, jj));
      u.cells.values[k] = m;
    }
  });
}

float Pyramid::value(int l, int i, int j) const {
  assert(l >= 0 && l < level_count_ && i >= 0 && j >= 0 && i < level_width(l) && j < level_height(l));
  if (l == 0) return source_cell(i, j);
  if (l <= block_levels_) {
    const int shift = log_block_ - l * log_factor_;
    block(i >> shift, j >> shift);
    return built_value(l, i, j);
  }
  ensure_upper(l, i, j);
  const UpperLevel& u = upper_[static_cast<std::size_t>(l - block_levels_ - 1)];
  return u.cells.values[static_cast<std::size_t>(j) * u.cells.width + i];
}

std::uint32_t Pyramid::count(int l, int i, int j) const {
  assert(reduction_ == Reduction::kMean);
  assert(l >= 0 && l < level_count_ && i >= 0 && j >= 0 && i < level_width(l) && j < level_height(l));
  if (l == 0) return std::isnan(source_cell(i, j)) ? 0 : 1;
  if (l <= block_levels_) {
    const int shift = log_block_ - l * log_factor_;
    block(i >> shift, j >> shift);
    std::size_t k;
    return block_level(l, i, j, k).counts[k];
  }
  ensure_upper(l, i, j);
  const UpperLevel& u = upper_[static_cast<std::size_t>(l - block_levels_ - 1)];
  return u.cells.counts[static_cast<std::size_t>(j) * u.cells.width + i];
}

// Cell (i, j) of `level` covers level-0 cells [i s, (i+1) s) x [j s, (j+1) s),
// s = factor^level. Called only for cells that intersect `w` and whose value
// is better than `best`.
template <class Better>
void Pyramid::descend(const Window& w, int level, int i, int j, float& best, std::uint64_t& reads,
                      Better better) const {
  const int size = cell_side(level);
  const int c0 = i * size, r0 = j * size;
  const bool inside = c0 >= w.col0 && c0 + size <= w.col1 && r0 >= w.row0 && r0 + size <= w.row1;
  if (inside || level == 0) {
    const float v = value(level, i, j);
    if (better(v, best)) best = v;
    return;
  }
  // Children in the window, best first, so that the first one visited
  // tightens `best` and prunes the others.
  const int part = size / factor_;
  Cell children[kMaxFactor * kMaxFactor];
  int n = 0;
  for (int dj = 0; dj < factor_; ++dj) {
    const int cj = factor_ * j + dj;
    if (cj >= level_height(level - 1) || cj * part >= w.row1 || (cj + 1) * part <= w.row0) continue;
    for (int di = 0; di < factor_; ++di) {
      const int ci = factor_ * i + di;
      if (ci >= level_width(level - 1) || ci * part >= w.col1 || (ci + 1) * part <= w.col0) continue;
      children[n++] = {value(level - 1, ci, cj), ci, cj};
      ++reads;
    }
  }
  sort_cells(children, n, better);
  for (int k = 0; k < n; ++k)
    if (better(children[k].value, best)) descend(w, level - 1, children[k].i, children[k].j, best, reads, better);
}

// The level where the window spans at most 2x2 cells: factor^level >= its
// longer side (or the top level, if the shape stops short of that).
int Pyramid::start_level(const Window& window) const {
  const int extent = std::max(window.width(), window.height());
  int level = 0;
  while (cell_side(level) < extent && level + 1 < level_count_) ++level;
  return level;
}

template <class Better>
float Pyramid::extreme_in(const Window& window, std::uint64_t* cells_read, Better better, float worst) const {
  assert(!window.empty());
  assert(window.col0 >= 0 && window.row0 >= 0 && window.col1 <= width_ && window.row1 <= height_);
  const int level = start_level(window);

  const int size = cell_side(level);
  float best = worst;
  std::uint64_t reads = 0;
  Cell cells[kMaxFactor * kMaxFactor];
  int n = 0;
  const auto visit = [&] {
    sort_cells(cells, n, better);
    for (int k = 0; k < n; ++k)
      if (better(cells[k].value, best)) descend(window, level, cells[k].i, cells[k].j, best, reads, better);
    n = 0;
  };
  for (int j = window.row0 / size; j <= (window.row1 - 1) / size; ++j)
    for (int i = window.col0 / size; i <= (window.col1 - 1) / size; ++i) {
      if (n == kMaxFactor * kMaxFactor) visit();  // a shape cut short: many top cells, in batches
      cells[n++] = {value(level, i, j), i, j};
      ++reads;
    }
  visit();
  if (cells_read) *cells_read += reads;
  return best;
}

float Pyramid::min_in(const Window& window, std::uint64_t* cells_read) const {
  assert(reduction_ == Reduction::kMin);
  return extreme_in(
      window, cells_read, [](float a, float b) { return a < b; }, kInf);
}

float Pyramid::max_in(const Window& window, std::uint64_t* cells_read) const {
  assert(reduction_ == Reduction::kMax);
  return extreme_in(
      window, cells_read, [](float a, float b) { return a > b; }, -kInf);
}

void Pyramid::mean_descend(const Window& w, int level, int i, int j, double& sum, double& n,
                           std::uint64_t& reads) const {
  const int size = cell_side(level);
  const int c0 = i * size, r0 = j * size;
  const bool inside = c0 >= w.col0 && c0 + size <= w.col1 && r0 >= w.row0 && r0 + size <= w.row1;
  if (inside || level == 0) {
    ++reads;
    const std::uint32_t c = count(level, i, j);
    if (c) {
      sum += double(value(level, i, j)) * c;
      n += c;
    }
    return;
  }
  const int part = size / factor_;
  for (int cj = std::max(factor_ * j, w.row0 / part);
       cj < std::min(factor_ * (j + 1), level_height(level - 1)) && cj * part < w.row1; ++cj)
    for (int ci = std::max(factor_ * i, w.col0 / part);
         ci < std::min(factor_ * (i + 1), level_width(level - 1)) && ci * part < w.col1; ++ci)
      mean_descend(w, level - 1, ci, cj, sum, n, reads);
}

float Pyramid::mean_in(const Window& window, std::uint64_t* cells_read) const {
  assert(reduction_ == Reduction::kMean);
  assert(!window.empty());
  assert(window.col0 >= 0 && window.row0 >= 0 && window.col1 <= width_ && window.row1 <= height_);
  const int level = start_level(window);
  const int size = cell_side(level);
  double sum = 0, n = 0;
  std::uint64_t reads = 0;
  for (int j = window.row0 / size; j <= (window.row1 - 1) / size; ++j)
    for (int i = window.col0 / size; i <= (window.col1 - 1) / size; ++i)
      mean_descend(window, level, i, j, sum, n, reads);
  if (cells_read) *cells_read += reads;
  return n > 0 ? static_cast<float>(sum / n) : std::nanf("");
}

void Pyramid::build_all(unsigned threads) {
  if (block_levels_ >= 1)
    parallel_for(block_count(), threads, [&](std::size_t k) {
      block(static_cast<int>(k % static_cast<std::size_t>(blocks_x_)),
            static_cast<int>(k / static_cast<std::size_t>(blocks_x_)));
    });
  for (int l = block_levels_ + 1; l < level_count_; ++l)
    for (int j = 0; j < level_height(l); ++j)
      for (int i = 0; i < level_width(l); ++i) ensure_upper(l, i, j);
  if (!flat_.empty() || block_levels_ < 1 || reduction_ == Reduction::kMean) return;
  // The flat levels: each block's rows copied into place (blocks write
  // disjoint cells), then the spans over the whole level.
  std::vector<PyramidLevel> flat(static_cast<std::size_t>(block_levels_));
  for (int l = 1; l <= block_levels_; ++l) {
    PyramidLevel& f = flat[static_cast<std::size_t>(l - 1)];
    f.width = level_width(l);
    f.height = level_height(l);
    f.values.resize(static_cast<std::size_t>(f.width) * f.height);
  }
  parallel_for(block_count(), threads, [&](std::size_t k) {
    const int bi = static_cast<int>(k % static_cast<std::size_t>(blocks_x_));
    const int bj = static_cast<int>(k / static_cast<std::size_t>(blocks_x_));
    const PyramidBlock& b = block(bi, bj);
    for (int l = 1; l <= block_levels_; ++l) {
      const PyramidLevel& from = b.levels[static_cast<std::size_t>(l - 1)];
      PyramidLevel& to = flat[static_cast<std::size_t>(l - 1)];
      const int shift = log_block_ - l * log_factor_;  // block side in level-l cells: 2^shift
      const std::size_t i0 = static_cast<std::size_t>(bi) << shift, j0 = static_cast<std::size_t>(bj) << shift;
      for (int r = 0; r < from.height; ++r) {
        const std::size_t src = static_cast<std::size_t>(r) * from.width;
        const std::size_t dst = (j0 + r) * static_cast<std::size_t>(to.width) + i0;
        std::copy_n(from.values.data() + src, from.width, to.values.data() + dst);
      }
    }
  });
  if (spans_)
    for (PyramidLevel& f : flat) fill_spans(reduction_, f);
  flat_ = std::move(flat);
}

std::size_t Pyramid::bytes() const {
  std::size_t n = 0;
  for (std::size_t k = 0; k < block_count(); ++k)
    if (const PyramidBlock* b = slots_[k].ready.load(std::memory_order_acquire)) n += b->bytes();
  for (const UpperLevel& u : upper_) n += u.cells.bytes();
  for (const PyramidLevel& f : flat_) n += f.bytes();
  return n;
}

}  // namespace horizon::terrain
