// A COG's overview levels (overviews.hpp).
#include "overviews.hpp"

#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <utility>
#include <type_traits>

#include "horizon/common/parallel.hpp"

namespace horizon::terrain::detail {
namespace {

template <class T>
struct Missing {
  bool has_nodata = false;
  T nodata{};
  bool operator()(T v) const {
    if constexpr (std::is_floating_point_v<T>)
      if (std::isnan(v)) return true;
    return has_nodata && v == nodata;
  }
  T value() const {
    if constexpr (std::is_floating_point_v<T>) return std::numeric_limits<T>::quiet_NaN();
    return nodata;
  }
};

template <class T>
T summarise(const std::array<T, 4>& cells, int n, OverviewResampling how, const Missing<T>& missing) {
  if (how == OverviewResampling::kNearest) return cells[0];
  std::array<T, 4> present{};
  int count = 0;
  for (int i = 0; i < n; ++i)
    if (!missing(cells[i])) present[count++] = cells[i];
  if (count == 0) return missing.value();
  if (how == OverviewResampling::kMode) {
    int best = 0, best_votes = 0;
    for (int i = 0; i < count; ++i) {
      int votes = 0;
      for (int j = 0; j < count; ++j) votes += present[j] == present[i];
      if (votes > best_votes) {  // strictly more: a tie keeps the earlier
        best = i;
        best_votes = votes;
      }
    }
    return present[best];
  }
  double sum = 0;
  for (int i = 0; i < count; ++i) sum += static_cast<double>(present[i]);
  const double mean = sum / count;
  if constexpr (std::is_floating_point_v<T>)
    return static_cast<T>(mean);
  else
    return static_cast<T>(std::floor(mean + 0.5));
}

template <class T>
Grid<T> halve(const Grid<T>& above, OverviewResampling how, const Missing<T>& missing) {
  const int w = (above.width() + 1) / 2, h = (above.height() + 1) / 2;
  Grid<T> out(w, h, kUninitialized);
  parallel_for(static_cast<std::size_t>(h), 0, [&](std::size_t r) {
    const int row = static_cast<int>(r);
    T* dst = out.row(row);
    const int r0 = 2 * row, r1 = std::min(r0 + 1, above.height() - 1);
    for (int c = 0; c < w; ++c) {
      const int c0 = 2 * c, c1 = std::min(c0 + 1, above.width() - 1);
      // The block's cells in row order; an odd edge repeats none: n counts the real ones.
      std::array<T, 4> cells{};
      int n = 0;
      cells[n++] = above.at(c0, r0);
      if (c1 != c0) cells[n++] = above.at(c1, r0);
      if (r1 != r0) {
        cells[n++] = above.at(c0, r1);
        if (c1 != c0) cells[n++] = above.at(c1, r1);
      }
      dst[c] = summarise(cells, n, how, missing);
    }
  });
  return out;
}

}  // namespace

template <class T>
std::vector<Grid<T>> build_overviews(const Grid<T>& full, int tile, OverviewResampling resampling,
                                     std::optional<double> nodata) {
  Missing<T> missing;
  if (nodata && !std::isnan(*nodata)) {
    missing.has_nodata = true;
    missing.nodata = static_cast<T>(*nodata);
  }
  std::vector<Grid<T>> levels;
  while (true) {
    const Grid<T>& above = levels.empty() ? full : levels.back();
    if (above.width() <= tile && above.height() <= tile) break;
    Grid<T> next = halve(above, resampling, missing);  // before push_back moves `above`
    levels.push_back(std::move(next));
  }
  return levels;
}

template std::vector<Grid<float>> build_overviews(const Grid<float>&, int, OverviewResampling, std::optional<double>);
template std::vector<Grid<std::uint8_t>> build_overviews(const Grid<std::uint8_t>&, int, OverviewResampling,
                                                         std::optional<double>);
template std::vector<Grid<std::uint32_t>> build_overviews(const Grid<std::uint32_t>&, int, OverviewResampling,
                                                          std::optional<double>);

}  // namespace horizon::terrain::detail
