#include "observer_picks.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace horizon::accuracy {
namespace {

ObserverPick nearest_centre_at_percentile(const terrain::Dem& dem, const std::vector<float>& sorted, double pct,
                                          const char* kind) {
  const float level = sorted[static_cast<std::size_t>(pct * (sorted.size() - 1))];
  const float tolerance = std::max(1.0f, 0.01f * (sorted.back() - sorted.front()));
  ObserverPick best{kind, 0, 0};
  double best_d = std::numeric_limits<double>::infinity();
  const double cc = 0.5 * (dem.width() - 1), cr = 0.5 * (dem.height() - 1);
  for (int r = 1; r + 1 < dem.height(); ++r)
    for (int c = 1; c + 1 < dem.width(); ++c) {
      const float z = dem.elevation.at(c, r);
      if (std::isnan(z) || std::abs(z - level) > tolerance) continue;
      const double d = std::hypot(c - cc, r - cr);
      if (d < best_d) best_d = d, best = {kind, c, r};
    }
  return best;
}

}  // namespace

std::vector<ObserverPick> pick_observers(const terrain::Dem& dem) {
  std::vector<float> sorted;
  ObserverPick summit{"summit", 0, 0};
  float top = -std::numeric_limits<float>::infinity();
  for (int r = 0; r < dem.height(); ++r)
    for (int c = 0; c < dem.width(); ++c) {
      const float z = dem.elevation.at(c, r);
      if (std::isnan(z)) continue;
      sorted.push_back(z);
      if (z > top) top = z, summit = {"summit", c, r};
    }
  if (sorted.empty()) return {};
  std::sort(sorted.begin(), sorted.end());
  std::vector<ObserverPick> picks{summit, nearest_centre_at_percentile(dem, sorted, 0.85, "ridge"),
                                  nearest_centre_at_percentile(dem, sorted, 0.10, "valley")};
  const int mid = dem.height() / 2;
  for (int c = 3; c < dem.width(); ++c)
    if (!std::isnan(dem.elevation.at(c, mid))) {
      picks.push_back({"edge", c, mid});
      break;
    }
  return picks;
}

}  // namespace horizon::accuracy
