// R3: the exact line-of-sight reference (Franklin & Ray, "Higher isn't
// necessarily better: visibility algorithms and experiments", 1994), with the
// crossing rule of ../shared/DESIGN.md. Deliberately simple: every target walks
// its own segment. Double precision throughout.
#include "horizon/visibility/r3.hpp"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <limits>

#include "horizon/common/parallel.hpp"
#include "crossings.hpp"

namespace horizon::visibility {
namespace {
constexpr double kNoHorizon = -std::numeric_limits<double>::infinity();
}  // namespace

double r3_horizon(const terrain::HeightView& z, const ViewFrame& f, double tc, double tr) {
  const double total = f.distance(tc, tr);
  double horizon = kNoHorizon;
  if (total == 0) return horizon;
  detail::for_each_crossing(z, f.observer_col, f.observer_row, tc, tr,
                            [&](double t, double, double, double terrain) {
                              const double slope = detail::r3_slope(f, total, t, terrain);
                              if (slope > horizon) horizon = slope;  // NaN (void) never wins
                            });
  return horizon;
}

float r3_ohf_at(const terrain::HeightView& z, const ViewFrame& f, int col, int row) {
  const double horizon = r3_horizon(z, f, col, row);
  if (horizon == kNoHorizon) return -std::numeric_limits<float>::infinity();
  return static_cast<float>(detail::r3_ohf_value(f, f.distance(col, row), horizon));
}

Status r3_ohf(const terrain::HeightView& z, const ViewFrame& f, unsigned threads, const RunControl* control,
              terrain::Grid<float>& ohf, WorkStats& stats) {
  const terrain::Window& win = f.window;
  reset_output(ohf, win, threads);
  std::atomic<std::uint64_t> evaluated{0}, samples{0};
  const Status run = parallel_for(static_cast<std::size_t>(win.height()), threads, control, [&](std::size_t i) {
    const int row = win.row0 + static_cast<int>(i);
    std::uint64_t n = 0, s = 0;
    for (int col = win.col0; col < win.col1; ++col) {
      if (!f.in_range(col, row) || std::isnan(z.at(col, row))) continue;
      ohf.at(col - win.col0, static_cast<int>(i)) = r3_ohf_at(z, f, col, row);
      ++n;
      s += static_cast<std::uint64_t>(std::abs(std::floor(col) - std::floor(f.observer_col)) +
                                      std::abs(std::floor(row) - std::floor(f.observer_row)));
    }
    evaluated += n;
    samples += s;
  });
  HORIZON_RETURN_IF_ERROR(run);
  stats.cells_evaluated = evaluated;
  stats.rays = evaluated;
  stats.terrain_samples = samples;
  return Status::Ok();
}

}  // namespace horizon::visibility
