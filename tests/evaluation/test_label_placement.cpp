// The charts' name placement (core/src/evaluation/label_placement.hpp): names
// of points a few pixels apart must not overprint, a lone name keeps the
// first offset, a name moves to its point's other side to clear another
// point, and when nothing fits the first offset is used.
#include <gtest/gtest.h>

#include <vector>

#include "evaluation/label_placement.hpp"

namespace horizon::evaluation {
namespace {

bool overlap(const LabelBox& a, int dya, const LabelBox& b, int dyb) {
  return a.x < b.x + b.width && b.x < a.x + a.width && a.y + dya < b.y + dyb + b.height &&
         b.y + dyb < a.y + dya + a.height;
}

const std::vector<int> kOffsets = {-16, 6, -30, 20, -44, 34, -58, 48};

TEST(LabelPlacement, NamesOfNearbyPointsDoNotOverprint) {
  // Rainier's front on 2026-12-06: four points within 20 px of each other.
  const std::vector<LabelBox> names = {
      {178, 343, 170, 13}, {181, 356, 150, 13}, {185, 376, 140, 13}, {200, 428, 150, 13}};
  const std::vector<int> dy = place_labels(names, kOffsets);
  ASSERT_EQ(dy.size(), names.size());
  for (std::size_t i = 0; i < names.size(); ++i)
    for (std::size_t j = i + 1; j < names.size(); ++j)
      EXPECT_FALSE(overlap(names[i], dy[i], names[j], dy[j])) << i << " and " << j;
  EXPECT_EQ(dy[0], -16);  // the first name takes the first place
}

TEST(LabelPlacement, ALoneNameAndNamesFarApartKeepTheFirstOffset) {
  const std::vector<int> dy = place_labels({{100, 100, 80, 13}, {400, 300, 80, 13}}, kOffsets);
  EXPECT_EQ(dy, (std::vector<int>{-16, -16}));
}

TEST(LabelPlacement, NamesOnOnePointStackAndFallBackWhenNothingFits) {
  const std::vector<LabelBox> same(10, LabelBox{50, 200, 100, 13});
  const std::vector<int> dy = place_labels(same, kOffsets);
  // Eight offsets 14 px or more apart hold eight names; the ninth and tenth
  // fit nowhere and take the first offset.
  for (int i = 0; i < 8; ++i) EXPECT_EQ(dy[i], kOffsets[i]) << i;
  EXPECT_EQ(dy[8], -16);
  EXPECT_EQ(dy[9], -16);
  for (int i = 0; i < 8; ++i)
    for (int j = i + 1; j < 8; ++j) EXPECT_FALSE(overlap(same[i], dy[i], same[j], dy[j])) << i << " and " << j;
}

TEST(LabelPlacement, NamesStepAsideFromPointsOnlyToTheOtherSide) {
  // A point right above the name's first place: it goes below instead.
  const LabelBox name{100, 200, 120, 13};
  EXPECT_EQ(place_labels({name}, kOffsets, {{150, 180, 11, 11}}), (std::vector<int>{6}));
  // Points above and below: the name stays above its point rather than
  // wander off; a second name still never overprints the first.
  const std::vector<LabelBox> points = {{150, 180, 11, 11}, {150, 208, 11, 11}};
  const std::vector<int> dy = place_labels({name, name}, kOffsets, points);
  EXPECT_EQ(dy[0], -16);
  EXPECT_EQ(dy[1], 6);
}

}  // namespace
}  // namespace horizon::evaluation
