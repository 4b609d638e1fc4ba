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

// For each name in order, the first of `offsets` (added to its y) whose box
// meets none of the boxes placed before it; the first offset when every one
// does. Returns the chosen offset of each name.
inline std::vector<int> place_labels(const std::vector<LabelBox>& names, const std::vector<int>& offsets) {
  std::vector<LabelBox> placed;
  std::vector<int> chosen;
  for (const LabelBox& name : names) {
    const auto meets = [&](int dy) {
      for (const LabelBox& p : placed)
        if (name.x < p.x + p.width && p.x < name.x + name.width && name.y + dy < p.y + p.height &&
            p.y < name.y + dy + name.height)
          return true;
      return false;
    };
    int dy = offsets.empty() ? 0 : offsets.front();
    for (const int candidate : offsets)
      if (!meets(candidate)) {
        dy = candidate;
        break;
      }
    chosen.push_back(dy);
    placed.push_back({name.x, name.y + dy, name.width, name.height});
  }
  return chosen;
}

}  // namespace horizon::evaluation
