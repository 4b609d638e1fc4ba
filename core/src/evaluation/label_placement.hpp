// Private to the charts (chart.cpp): where to put the names of points that
// may sit close together, so that no two names overprint.
#pragma once

#include <vector>

namespace horizon::evaluation {

// A name's box in pixels, top-left (x, y) as it would be drawn with no
// vertical offset.
struct LabelBox {
  int x = 0, y = 0, width = 0, height = 0;
};

// For each name in order: the first of the first two `offsets` (added to
// its y: just above or below its point) whose box meets neither a name
// placed before it nor an obstacle (the chart's points); failing that, the
// first of all `offsets` that meets no name (further out only to keep names
// apart, never to dodge a point, so that a name stays by its point);
// failing that, the first offset. Returns the chosen offset of each name.
inline std::vector<int> place_labels(const std::vector<LabelBox>& names, const std::vector<int>& offsets,
                                     const std::vector<LabelBox>& obstacles = {}) {
  const auto meets = [](const LabelBox& a, int dy, const LabelBox& b) {
    return a.x < b.x + b.width && b.x < a.x + a.width && a.y + dy < b.y + b.height && b.y < a.y + dy + a.height;
  };
  const auto meets_any = [&](const LabelBox& a, int dy, const std::vector<LabelBox>& boxes) {
    for (const LabelBox& b : boxes)
      if (meets(a, dy, b)) return true;
    return false;
  };
  std::vector<LabelBox> placed;
  std::vector<int> chosen;
  for (const LabelBox& name : names) {
    int dy = offsets.empty() ? 0 : offsets.front();
    bool found = false;
    for (std::size_t i = 0; i < offsets.size() && i < 2; ++i)
      if (!meets_any(name, offsets[i], placed) && !meets_any(name, offsets[i], obstacles)) {
        dy = offsets[i];
        found = true;
        break;
      }
    if (!found)
      for (const int candidate : offsets)
        if (!meets_any(name, candidate, placed)) {
          dy = candidate;
          break;
        }
    chosen.push_back(dy);
    placed.push_back({name.x, name.y + dy, name.width, name.height});
  }
  return chosen;
}

}  // namespace horizon::evaluation
