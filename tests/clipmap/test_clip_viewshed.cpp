// Viewsheds over a clip-map against R3 on the full-resolution terrain, cell
// by cell: the conservative mode never calls hidden a cell R3 sees, with the
// levels complete and with the finest levels left behind; the fast mode
// agrees with R3 on most cells (no more than 12 % wrong on rough terrain); cells beyond the radius, off the source or
// on a void have no answer; wrong radii and heights are refused by name.
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "clipmap_world.hpp"
#include "horizon/clipmap/clip_viewshed.hpp"
#include "horizon/visibility/r3.hpp"
#include "horizon/visibility/view_frame.hpp"
#include "horizon/visibility/viewshed.hpp"

namespace horizon::clipmap {
namespace {

using testing::ClipWorld;
using testing::small_shape;

struct Eye {
  visibility::ViewFrame frame;
  ClipEye clip;
};

Eye eye_at(const ClipWorld& world, double col, double row, double height) {
  visibility::ViewshedOptions options;
  options.max_distance = std::numeric_limits<double>::infinity();
  geodesy::GridPoint observer;
  observer.col = col;
  observer.row = row;
  observer.elevation = world.bilinear(0, col, row) + height;
  observer.x = world.dem.georef.transform.x_at(col);
  observer.y = world.dem.georef.transform.y_at(row);
  auto frame = visibility::make_view_frame(world.dem, observer, options);
  EXPECT_TRUE(frame.ok()) << frame.error().message;
  return {*frame, {col, row, observer.elevation, frame->metres_per_col, frame->metres_per_row, frame->curvature}};
}

struct Agreement {
  std::uint64_t cells = 0, false_hidden = 0, false_visible = 0, r3_hidden = 0;
};

// The mask against R3's answer at every cell it answers.
Agreement compare(const ClipWorld& world, const Eye& eye, const ClipViewshed& got) {
  const terrain::HeightView z(world.dem.elevation);
  Agreement a;
  for (int r = got.window.row0; r < got.window.row1; ++r)
    for (int c = got.window.col0; c < got.window.col1; ++c) {
      const std::uint8_t code = got.mask.at(c - got.window.col0, r - got.window.row0);
      if (code == visibility::kNoAnswer) continue;
      ++a.cells;
      const float ohf = visibility::r3_ohf_at(z, eye.frame, c, r);
      const bool r3 = visibility::min_target_height_at(ohf, world.dem.elevation.at(c, r)) <= 0.0f;
      const bool seen = code == visibility::kVisible;
      a.r3_hidden += !r3;
      a.false_hidden += r3 && !seen;
      a.false_visible += !r3 && seen;
    }
  return a;
}

TEST(ClipViewshed, ConservativeNeverCallsHiddenACellR3SeesEvenWhenLevelsLag) {
  ClipWorld world(small_shape(terrain::Reduction::kMin));
  auto map = world.map(small_shape(terrain::Reduction::kMin));
  ClipmapUpdater updater = world.updater(map);
  for (const auto& [col, row, height] : {std::tuple{500.0, 350.0, 12.0}, std::tuple{130.0, 610.0, 80.0}}) {
    const Eye eye = eye_at(world, col, row, height);
    ASSERT_TRUE(updater.update_all({.col = col, .row = row}).ok());
    for (int rays : {256, 2048}) {
      ClipmapReader view(*map);
      auto got = viewshed_on_clipmap(view, eye.clip, {.mode = ClipMode::kConservative, .rays = rays, .radius = 1800});
      ASSERT_TRUE(got.ok()) << got.error().message;
      const Agreement a = compare(world, eye, *got);
      EXPECT_EQ(a.false_hidden, 0u) << "eye (" << col << ", " << row << "), " << rays << " rays";
      EXPECT_GT(a.r3_hidden, a.cells / 10) << "the scene must hide cells to mean anything";
      EXPECT_GT(a.r3_hidden - a.false_visible, a.r3_hidden / 20) << rays << " rays: sound and still useful";
      EXPECT_EQ(got->visible_cells + got->hidden_cells, a.cells);
    }
  }
  // Levels 0 and 1 left at the far corner: the eye's surroundings come from level 2 or 3.
  world.lag_finest_levels(map, 300.0, 300.0);
  const Eye eye = eye_at(world, 300.0, 300.0, 12.0);
  ClipmapReader view(*map);
  auto got = viewshed_on_clipmap(view, eye.clip, {.mode = ClipMode::kConservative, .rays = 1024, .radius = 1800});
  ASSERT_TRUE(got.ok()) << got.error().message;
  EXPECT_GT(got->stats.fallbacks, got->stats.samples / 4) << "the finest levels are elsewhere";
  EXPECT_EQ(compare(world, eye, *got).false_hidden, 0u);
}

TEST(ClipViewshed, FastAgreesWithR3OnMostCells) {
  ClipWorld world;
  auto map = world.map();
  ClipmapUpdater updater = world.updater(map);
  for (const auto& [col, row] : {std::pair{500.0, 350.0}, std::pair{130.0, 610.0}}) {
    const Eye eye = eye_at(world, col, row, 12.0);
    ASSERT_TRUE(updater.update_all({.col = col, .row = row}).ok());
    ClipmapReader view(*map);
    auto got = viewshed_on_clipmap(view, eye.clip, {.mode = ClipMode::kFast, .rays = 2048, .radius = 1800});
    ASSERT_TRUE(got.ok()) << got.error().message;
    const Agreement a = compare(world, eye, *got);
    // The test terrain has 12 m of noise between 30 m cells: a cell's answer
    // turns on its neighbours, which the mean levels' bilinear samples along
    // rings only approximate.
    const double wrong = static_cast<double>(a.false_hidden + a.false_visible) / static_cast<double>(a.cells);
    EXPECT_LT(wrong, 0.12) << "eye (" << col << ", " << row << "): " << a.false_hidden << " false hidden, "
                           << a.false_visible << " false visible of " << a.cells;
    EXPECT_LT(a.false_hidden, a.cells / 25);
    // A cell beyond the radius has no answer; the eye's own cell is visible.
    const int c = static_cast<int>(col) - got->window.col0, r = static_cast<int>(row) - got->window.row0;
    EXPECT_EQ(got->mask.at(c, r), visibility::kVisible);
    EXPECT_EQ(got->mask.at(0, 0), visibility::kNoAnswer) << "the window's corner is beyond the radius";
  }
}

TEST(ClipViewshed, WrongRadiiAndHeightsAreRefusedByName) {
  ClipWorld world;
  auto map = world.map();
  ClipmapUpdater updater = world.updater(map);
  ASSERT_TRUE(updater.update_all({.col = 500.0, .row = 350.0}).ok());
  const Eye eye = eye_at(world, 500.0, 350.0, 12.0);
  ClipmapReader view(*map);
  for (double radius : {0.0, -5.0, std::nan(""), 1e9}) {
    auto got = viewshed_on_clipmap(view, eye.clip, {.radius = radius});
    ASSERT_FALSE(got.ok()) << radius;
    EXPECT_EQ(got.error().field, "viewshed_radius");
  }
  auto got = viewshed_on_clipmap(view, eye.clip, {.radius = 900, .target_height = -1.0});
  ASSERT_FALSE(got.ok());
  EXPECT_EQ(got.error().field, "target_height");
  got = viewshed_on_clipmap(view, eye.clip, {.mode = ClipMode::kConservative, .radius = 900});
  ASSERT_FALSE(got.ok());
  EXPECT_EQ(got.error().field, "mode") << "a mean clip-map cannot answer conservatively";
}

}  // namespace
}  // namespace horizon::clipmap
