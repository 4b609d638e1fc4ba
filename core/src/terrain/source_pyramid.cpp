// Reduced levels of a whole elevation source, block by block, in the shared
// block cache. See source_pyramid.hpp.
#include "horizon/terrain/source_pyramid.hpp"

#include <algorithm>
#include <bit>
#include <chrono>
#include <string>
#include <utility>

namespace horizon::terrain {
namespace {

bool power_of_two(int v) {
  return v > 0 && std::has_single_bit(static_cast<unsigned>(v));
}

}  // namespace

Result<std::shared_ptr<const SourcePyramid>> SourcePyramid::make(std::shared_ptr<const ElevationSource> source,
                                                                 BlockCache& cache, Reduction reduction,
                                                                 SourcePyramidOptions options) {
  if (!source) return make_error(ErrorCode::kInvalidArgument, "a source pyramid needs a source", "source");
  if (!power_of_two(options.factor) || options.factor > 8)
    return make_error(ErrorCode::kInvalidArgument,
                      "pyramid factor must be 2, 4 or 8, got " + std::to_string(options.factor), "factor");
  if (!power_of_two(options.block_cells) || options.block_cells < options.factor || options.block_cells > (1 << 14))
    return make_error(ErrorCode::kInvalidArgument,
                      "pyramid block_cells must be a power of two from the factor to 16384, got " +
                          std::to_string(options.block_cells),
                      "block_cells");
  const int most = std::countr_zero(static_cast<unsigned>(options.block_cells)) /
                   std::countr_zero(static_cast<unsigned>(options.factor));
  if (options.levels == PyramidShape::kToOneCell) options.levels = most;
  if (options.levels < 1 || options.levels > most)
    return make_error(ErrorCode::kInvalidArgument,
                      "pyramid levels must be 1.." + std::to_string(most) + " for blocks of " +
                          std::to_string(options.block_cells) + " cells and factor " + std::to_string(options.factor) +
                          ", got " + std::to_string(options.levels),
                      "levels");
  return std::shared_ptr<const SourcePyramid>(new SourcePyramid(std::move(source), cache, reduction, options));
}

SourcePyramid::SourcePyramid(std::shared_ptr<const ElevationSource> source, BlockCache& cache, Reduction reduction,
                             const SourcePyramidOptions& options)
    : source_(std::move(source)),
      cache_(cache),
      reduction_(reduction),
      factor_(options.factor),
      log_factor_(std::countr_zero(static_cast<unsigned>(options.factor))),
      levels_(options.levels),
      block_cells_(options.block_cells),
      log_block_(std::countr_zero(static_cast<unsigned>(options.block_cells))),
      blocks_x_(((source_->width() - 1) >> log_block_) + 1),
      blocks_y_(((source_->height() - 1) >> log_block_) + 1),
      id_(BlockCache::next_source_id()) {}

std::vector<std::uint64_t> SourcePyramid::blocks_in(int level, const Window& window) const {
  std::vector<std::uint64_t> out;
  const Window w = window.intersect({0, 0, level_width(level), level_height(level)});
  if (w.empty()) return out;
  const int shift = log_block_ - level * log_factor_;  // block side in level cells: 2^shift
  for (int by = w.row0 >> shift; by <= (w.row1 - 1) >> shift; ++by)
    for (int bx = w.col0 >> shift; bx <= (w.col1 - 1) >> shift; ++bx)
      out.push_back(static_cast<std::uint64_t>(by) * static_cast<std::uint64_t>(blocks_x_) +
                    static_cast<std::uint64_t>(bx));
  return out;
}

Result<std::shared_ptr<const PyramidBlock>> SourcePyramid::block(std::uint64_t index, const RunControl* control,
                                                                 SourcePyramidStats& stats) const {
  const int bx = static_cast<int>(index % static_cast<std::uint64_t>(blocks_x_));
  const int by = static_cast<int>(index / static_cast<std::uint64_t>(blocks_x_));
  const Window cells =
      Window{bx << log_block_, by << log_block_, (bx + 1) << log_block_, (by + 1) << log_block_}.intersect(
          {0, 0, source_->width(), source_->height()});
  FetchStats fetched;
  auto got = cache_.build<PyramidBlock>(
      BlockKey{id_, index},
      [&]() -> Result<PyramidBlock> {
        SourceReadStats read;
        auto dem = source_->read(cells, &cache_, control, &read);
        stats.elevation_blocks_decoded += read.cache.misses;
        if (!dem.ok()) return dem.error();
        return reduce_block(dem->elevation, reduction_, factor_, levels_);
      },
      control, &fetched);
  stats.hits += fetched.hits;
  stats.joins += fetched.joins;
  stats.builds += fetched.misses;
  return got;
}

Result<Grid<float>> SourcePyramid::read(int level, const Window& window, const RunControl* control,
                                        SourcePyramidStats* stats) const {
  const auto start = std::chrono::steady_clock::now();
  if (level < 0 || level > levels_)
    return make_error(ErrorCode::kInvalidArgument,
                      "pyramid level " + std::to_string(level) + " is not in 0.." + std::to_string(levels_), "level");
  const Window w = window.intersect({0, 0, level_width(level), level_height(level)});
  if (w.empty())
    return make_error(ErrorCode::kOutOfRange, "the window lies outside pyramid level " + std::to_string(level) + " (" +
                                                  std::to_string(level_width(level)) + " x " +
                                                  std::to_string(level_height(level)) + " cells)");
  if (level == 0) {
    auto dem = source_->read(w, &cache_, control);
    if (!dem.ok()) return dem.error();
    return std::move(dem->elevation);
  }
  SourcePyramidStats local;
  Grid<float> out(w.width(), w.height());
  const int shift = log_block_ - level * log_factor_;
  for (std::uint64_t index : blocks_in(level, w)) {
    ++local.blocks;
    if (auto s = check_control(control); !s.ok()) return s.error();
    auto b = block(index, control, local);
    if (!b.ok()) return b.error();
    const PyramidLevel& cells = (*b)->levels[static_cast<std::size_t>(level - 1)];
    const int i0 = static_cast<int>(index % static_cast<std::uint64_t>(blocks_x_)) << shift;
    const int j0 = static_cast<int>(index / static_cast<std::uint64_t>(blocks_x_)) << shift;
    const Window part = w.intersect({i0, j0, i0 + cells.width, j0 + cells.height});
    for (int j = part.row0; j < part.row1; ++j) {
      const float* from = cells.values.data() + static_cast<std::size_t>(j - j0) * cells.width + (part.col0 - i0);
      std::copy_n(from, part.width(), out.row(j - w.row0) + (part.col0 - w.col0));
    }
  }
  local.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  if (stats) *stats = local;
  return out;
}

}  // namespace horizon::terrain
