// Sessions: a client that applies each answer's changes to what it was told
// before holds, at every pose of a flight, exactly the session's culling of
// every box, and in conservative mode never a box hidden that R3 on the
// full-resolution terrain sees; boxes are added, moved and removed by id in
// batches that change nothing when any entry is wrong; an asynchronous
// session answers every pose while its loader follows.
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <map>
#include <random>
#include <vector>

#include "clipmap_world.hpp"
#include "horizon/clipmap/session.hpp"
#include "horizon/visibility/r3.hpp"
#include "horizon/visibility/view_frame.hpp"
#include "horizon/visibility/viewshed.hpp"

namespace horizon::clipmap {
namespace {

using testing::ClipWorld;
using testing::kHeight;
using testing::kWidth;
using testing::small_shape;
using visibility::Visibility;

// Cell (col, row) of the world's grid in its CRS.
double x_of(const ClipWorld& w, double col) {
  return w.dem.georef.transform.x_at(col);
}
double y_of(const ClipWorld& w, double row) {
  return w.dem.georef.transform.y_at(row);
}

SessionPose pose_at(const ClipWorld& w, double col, double row, std::uint64_t seq, double east = 0.0) {
  SessionPose p;
  p.position.x = x_of(w, col);
  p.position.y = y_of(w, row);
  p.position.height = 15.0;
  p.east_per_s = east;
  p.seq = seq;
  return p;
}

// `count` boxes of 1-3 cells on the ground, ids from `first_id`.
std::vector<SessionBox> boxes_on(const ClipWorld& w, int count, std::uint64_t first_id, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_int_distribution<int> cx(2, kWidth - 6), cy(2, kHeight - 6), side(1, 3);
  std::uniform_real_distribution<double> tall(1.0, 30.0);
  std::vector<SessionBox> out;
  for (int i = 0; i < count; ++i) {
    const int c = cx(rng), r = cy(rng), s = side(rng);
    SessionBox b;
    b.id = first_id + static_cast<std::uint64_t>(i);
    // The rectangle of the cell centres c .. c+s-1, r .. r+s-1.
    b.box.x_min = x_of(w, c);
    b.box.x_max = x_of(w, c + s - 1);
    b.box.y_min = y_of(w, r + s - 1);
    b.box.y_max = y_of(w, r);
    float ground = std::numeric_limits<float>::infinity();
    for (int rr = r; rr < r + s; ++rr)
      for (int cc = c; cc < c + s; ++cc) ground = std::min(ground, w.dem.elevation.at(cc, rr));
    b.box.z_min = ground;
    b.box.z_max = ground + tall(rng);
    out.push_back(b);
  }
  return out;
}

SessionOptions options_for(ClipMode mode, bool asynchronous) {
  SessionOptions o;
  o.shape = small_shape();
  o.mode = mode;
  o.rays = 512;
  o.asynchronous = asynchronous;
  return o;
}

std::shared_ptr<const terrain::SourcePyramid> pyramid_for(const ClipWorld& w, ClipMode mode) {
  ClipmapShape shape =
      small_shape(mode == ClipMode::kConservative ? terrain::Reduction::kMin : terrain::Reduction::kMean);
  auto made = terrain::SourcePyramid::make(w.source, const_cast<terrain::BlockCache&>(w.cache), shape.reduction,
                                           pyramid_options_for(shape));
  EXPECT_TRUE(made.ok()) << made.error().message;
  return *made;
}

// R3's frame for an eye at (col, row), `elevation` metres absolute, with no distance limit.
Result<visibility::ViewFrame> frame_at(const ClipWorld& w, double col, double row, double elevation) {
  visibility::ViewshedOptions vo;
  vo.max_distance = std::numeric_limits<double>::infinity();
  geodesy::GridPoint eye;
  eye.col = col;
  eye.row = row;
  eye.x = x_of(w, col);
  eye.y = y_of(w, row);
  eye.elevation = elevation;
  return visibility::make_view_frame(w.dem, eye, vo);
}

// R3's answer for a box at cells [c0, c1] x [r0, r1] from the eye of `answer`.
bool r3_sees(const ClipWorld& w, const visibility::ViewFrame& frame, const visibility::BoxFootprint& f) {
  const terrain::HeightView z(w.dem.elevation);
  float least = std::numeric_limits<float>::infinity();
  for (int r = f.cells.row0; r < f.cells.row1; ++r)
    for (int c = f.cells.col0; c < f.cells.col1; ++c) least = std::min(least, visibility::r3_ohf_at(z, frame, c, r));
  return f.z_max + visibility::kTieTolerance >= least;
}

TEST(ClipSession, AClientApplyingTheChangesHoldsEveryBoxsStateAndConservativeNeverHidesWhatR3Sees) {
  ClipWorld world;
  auto first = pose_at(world, 100.0, 350.0, 1, 250.0);
  auto session = ClipSession::open(world.source, world.cache, pyramid_for(world, ClipMode::kConservative),
                                   options_for(ClipMode::kConservative, false), first);
  ASSERT_TRUE(session.ok()) << session.error().message;
  const std::vector<SessionBox> boxes = boxes_on(world, 400, 1000, 4);
  ASSERT_TRUE((*session)->add_boxes(boxes).ok());
  auto footprints = visibility::resolve_boxes(world.dem.georef, kWidth, kHeight, "test", [&] {
    std::vector<visibility::BoxSpec> specs;
    for (const auto& b : boxes) specs.push_back(b.box);
    return specs;
  }());
  ASSERT_TRUE(footprints.ok());

  std::map<std::uint64_t, Visibility> told;
  std::size_t reported_after_first = 0, false_hidden = 0, hidden = 0;
  for (int step = 0; step < 40; ++step) {
    const double col = 100.0 + step * 20.0;  // 250 m/s at 30 m cells, 12 poses a second
    auto answer = (*session)->answer(pose_at(world, col, 350.0, static_cast<std::uint64_t>(step + 1), 250.0));
    ASSERT_TRUE(answer.ok()) << answer.error().message;
    EXPECT_EQ(answer->seq, static_cast<std::uint64_t>(step + 1));
    EXPECT_EQ(answer->boxes, boxes.size());
    if (step == 0)
      EXPECT_EQ(answer->changes.size(), boxes.size()) << "the first answer tells every box";
    else
      reported_after_first += answer->changes.size();
    for (const BoxChange& c : answer->changes) told[c.id] = c.state;
    ASSERT_EQ(told.size(), boxes.size());
    std::size_t visible = 0;
    for (const auto& [id, state] : told) visible += state == Visibility::kSeen;
    EXPECT_EQ(visible, answer->visible) << "the client's picture is the session's";
    if (step % 8 == 0) {  // against R3 on the full terrain
      auto frame = frame_at(world, col, 350.0, answer->eye_elevation);
      ASSERT_TRUE(frame.ok());
      for (std::size_t i = 0; i < boxes.size(); ++i) {
        const bool seen = told[boxes[i].id] == Visibility::kSeen;
        hidden += !seen;
        false_hidden += !seen && r3_sees(world, *frame, (*footprints)[i]);
      }
    }
  }
  EXPECT_GT(reported_after_first, 0u) << "the flight changes what is seen";
  EXPECT_LT(reported_after_first, 39u * boxes.size() / 4) << "and only changes are sent";
  EXPECT_GT(hidden, 100u);
  EXPECT_EQ(false_hidden, 0u);
}

TEST(ClipSession, AnExactSessionAnswersEveryBoxAsR3DoesAndBoundsItsMemory) {
  ClipWorld world;
  SessionOptions options = options_for(ClipMode::kExact, false);
  auto first = pose_at(world, 300.0, 200.0, 1, 250.0);
  auto session =
      ClipSession::open(world.source, world.cache, pyramid_for(world, ClipMode::kConservative), options, first);
  ASSERT_TRUE(session.ok()) << session.error().message;
  const std::vector<SessionBox> boxes = boxes_on(world, 300, 1, 9);
  ASSERT_TRUE((*session)->add_boxes(boxes).ok());
  EXPECT_EQ((*session)->bytes(), options.exact_bytes + boxes.size() * ClipSession::kBytesPerBox);
  std::vector<visibility::BoxSpec> specs;
  for (const auto& b : boxes) specs.push_back(b.box);
  auto footprints = visibility::resolve_boxes(world.dem.georef, kWidth, kHeight, "test", specs);
  ASSERT_TRUE(footprints.ok());
  std::map<std::uint64_t, Visibility> told;
  std::size_t hidden = 0, checked = 0;
  for (int step = 0; step < 3; ++step) {
    const double col = 300.0 + step * 140.0, row = 200.0 + step * 80.0;
    auto answer = (*session)->answer(pose_at(world, col, row, static_cast<std::uint64_t>(step + 1), 250.0));
    ASSERT_TRUE(answer.ok()) << answer.error().message;
    EXPECT_TRUE(answer->levels.empty()) << "no clip-map";
    for (const BoxChange& c : answer->changes) told[c.id] = c.state;
    ASSERT_EQ(told.size(), boxes.size());
    auto frame = frame_at(world, col, row, answer->eye_elevation);
    ASSERT_TRUE(frame.ok());
    for (std::size_t i = 0; i < boxes.size(); ++i) {
      const bool seen = told[boxes[i].id] == Visibility::kSeen;
      hidden += !seen;
      ++checked;
      ASSERT_EQ(seen, r3_sees(world, *frame, (*footprints)[i])) << "box " << boxes[i].id << " at step " << step;
    }
  }
  EXPECT_GT(hidden, checked / 10) << "the scene hides boxes";
  EXPECT_LT(hidden, checked * 9 / 10) << "and shows some";
  // A memory allowance too small for the boxes' reach refuses the answer, naming the boxes.
  options.exact_bytes = 1 << 16;
  auto small = ClipSession::open(world.source, world.cache, nullptr, options, first);
  ASSERT_TRUE(small.ok()) << small.error().message;
  ASSERT_TRUE((*small)->add_boxes(boxes).ok());
  auto refused = (*small)->answer(first);
  ASSERT_FALSE(refused.ok());
  EXPECT_EQ(refused.error().code, ErrorCode::kResourceExhausted);
  EXPECT_EQ(refused.error().field, "boxes");
}

// The session's viewshed mask against R3 at every cell it answers: {cells, false hidden, false visible}.
std::array<std::size_t, 3> against_r3(const ClipWorld& w, const SessionAnswer& answer, double col, double row) {
  auto frame = frame_at(w, col, row, answer.eye_elevation);
  EXPECT_TRUE(frame.ok());
  const terrain::HeightView z(w.dem.elevation);
  std::array<std::size_t, 3> out{};
  const ViewshedSummary& v = *answer.viewshed;
  for (int r = v.window.row0; r < v.window.row1; ++r)
    for (int c = v.window.col0; c < v.window.col1; ++c) {
      const std::uint8_t code = v.mask.at(c - v.window.col0, r - v.window.row0);
      if (code == visibility::kNoAnswer) continue;
      const bool r3 =
          visibility::min_target_height_at(visibility::r3_ohf_at(z, *frame, c, r), w.dem.elevation.at(c, r)) <= 0.0f;
      ++out[0];
      out[1] += r3 && code == visibility::kHidden;
      out[2] += !r3 && code == visibility::kVisible;
    }
  return out;
}

TEST(ClipSession, EachAnswerCarriesAViewshedConservativeNeverHidingWhatR3SeesAndExactEqualToIt) {
  ClipWorld world;
  for (ClipMode mode : {ClipMode::kConservative, ClipMode::kExact}) {
    SessionOptions options = options_for(mode, false);
    options.viewshed_radius = 1500.0;  // 50 cells
    auto session = ClipSession::open(world.source, world.cache, pyramid_for(world, ClipMode::kConservative), options,
                                     pose_at(world, 200.0, 300.0, 1));
    ASSERT_TRUE(session.ok()) << session.error().message;
    std::size_t hidden = 0, all = 0;
    for (int step = 0; step < 3; ++step) {
      const double col = 200.0 + step * 150.0, row = 300.0 + step * 40.0;
      auto answer = (*session)->answer(pose_at(world, col, row, static_cast<std::uint64_t>(step + 1)));
      ASSERT_TRUE(answer.ok()) << answer.error().message;
      ASSERT_TRUE(answer->viewshed.has_value());
      const auto [cells, false_hidden, false_visible] = against_r3(world, *answer, col, row);
      EXPECT_GT(cells, 7000u) << "about pi 50² cells";
      EXPECT_EQ(answer->viewshed->visible_cells + answer->viewshed->hidden_cells, cells);
      hidden += answer->viewshed->hidden_cells;
      all += cells;
      EXPECT_EQ(false_hidden, 0u) << mode_name(mode) << " at step " << step;
      if (mode == ClipMode::kExact) {
        EXPECT_EQ(false_visible, 0u) << "exact is R3 at step " << step;
      }
    }
    // R3 hides a third or more of these cells; the conservative bound finds some of them.
    EXPECT_GT(hidden, mode == ClipMode::kExact ? all / 3 : all / 50) << mode_name(mode);
  }
  SessionOptions bad = options_for(ClipMode::kFast, false);
  bad.viewshed_radius = -1.0;
  auto refused = ClipSession::open(world.source, world.cache, pyramid_for(world, ClipMode::kFast), bad,
                                   pose_at(world, 200.0, 300.0, 1));
  ASSERT_FALSE(refused.ok());
  EXPECT_EQ(refused.error().field, "viewshed_radius");
}

TEST(ClipSession, BoxBatchesChangeNothingWhenAnyEntryIsWrong) {
  ClipWorld world;
  SessionOptions options = options_for(ClipMode::kFast, false);
  options.max_boxes = 50;
  auto session = ClipSession::open(world.source, world.cache, pyramid_for(world, ClipMode::kFast), options,
                                   pose_at(world, 500.0, 350.0, 1));
  ASSERT_TRUE(session.ok()) << session.error().message;
  ClipSession& s = **session;
  std::vector<SessionBox> boxes = boxes_on(world, 10, 1, 9);
  ASSERT_TRUE(s.add_boxes(boxes).ok());
  // A repeated id, an id already registered, a box upside down: nothing changes.
  std::vector<SessionBox> more = boxes_on(world, 5, 100, 10);
  more[3].id = 100;
  Status repeated = s.add_boxes(more);
  ASSERT_FALSE(repeated.ok());
  EXPECT_EQ(repeated.error().field, "add[3].id");
  more[3].id = 5;
  EXPECT_EQ(s.add_boxes(more).error().field, "add[3].id");
  more[3].id = 103;
  more[4].box.z_max = more[4].box.z_min - 1.0;
  EXPECT_EQ(s.add_boxes(more).error().field, "add[4].z_max");
  EXPECT_EQ(s.box_count(), 10u);
  EXPECT_EQ(s.add_boxes(boxes_on(world, 41, 200, 11)).error().code, ErrorCode::kResourceExhausted);
  // Moves and removals by id.
  SessionBox unknown = boxes[0];
  unknown.id = 77;
  EXPECT_EQ(s.move_boxes(std::vector<SessionBox>{boxes[1], unknown}).error().field, "move[1].id");
  const std::vector<std::uint64_t> gone{3, 4, 99};
  EXPECT_EQ(s.remove_boxes(gone).error().field, "remove[2]");
  EXPECT_EQ(s.box_count(), 10u);
  // One delta: its adds are not kept when its move is wrong; an id removed may be added again in it.
  BoxDelta mixed;
  mixed.add = boxes_on(world, 2, 300, 12);
  mixed.move = {unknown};
  EXPECT_EQ(s.apply(mixed).error().field, "move[0].id");
  EXPECT_EQ(s.box_count(), 10u);
  BoxDelta again;
  again.remove = {1};
  again.add = {boxes[0]};
  ASSERT_TRUE(s.apply(again).ok());
  EXPECT_EQ(s.box_count(), 10u);

  auto first = s.answer(pose_at(world, 500.0, 350.0, 2));
  ASSERT_TRUE(first.ok());
  EXPECT_EQ(first->changes.size(), 10u);
  auto same = s.answer(pose_at(world, 500.0, 350.0, 3));
  ASSERT_TRUE(same.ok());
  EXPECT_TRUE(same->changes.empty()) << "nothing moved";
  ASSERT_TRUE(s.remove_boxes(std::vector<std::uint64_t>{3, 4}).ok());
  SessionBox moved = boxes[6];
  moved.box.z_max += 1.0;
  ASSERT_TRUE(s.move_boxes(std::vector<SessionBox>{moved}).ok());
  auto after = s.answer(pose_at(world, 500.0, 350.0, 4));
  ASSERT_TRUE(after.ok());
  ASSERT_EQ(after->changes.size(), 1u) << "a moved box is told again";
  EXPECT_EQ(after->changes[0].id, 7u);
  EXPECT_EQ(after->boxes, 8u);
  // A pose off the dataset names the pose.
  auto off = s.answer(pose_at(world, -40.0, 350.0, 5));
  ASSERT_FALSE(off.ok());
  EXPECT_EQ(off.error().code, ErrorCode::kOutOfRange);
}

// Per-box answers, as CullBoxes gives them: a box off the map is registered
// and answered out of range at every pose, costing the others nothing (their
// answers are those of a session without it); a box meeting a void is never
// hidden (undetermined instead), in every mode.
TEST(ClipSession, BoxesOffTheMapAreOutOfRangeAndBoxesOnVoidsAreNeverHidden) {
  const terrain::Window hole{600, 320, 612, 332};
  ClipWorld world(small_shape(), hole);
  // Buried boxes across the hole's west edge: hidden where the terrain is
  // known (below the ground of the cells around them), so undetermined.
  std::vector<SessionBox> on_void;
  for (int k = 0; k < 4; ++k) {
    const int c = hole.col0 - 2, r = hole.row0 + 3 * k;
    SessionBox b;
    b.id = 900 + static_cast<std::uint64_t>(k);
    b.box.x_min = x_of(world, c);
    b.box.x_max = x_of(world, c + 3);
    b.box.y_min = y_of(world, r + 1);
    b.box.y_max = y_of(world, r);
    b.box.z_min = world.dem.elevation.at(c, r) - 310.0;
    b.box.z_max = world.dem.elevation.at(c, r) - 300.0;
    on_void.push_back(b);
  }
  std::vector<SessionBox> off_map(2, on_void[0]);
  off_map[0].id = 950;  // past the east edge by a few cells
  off_map[0].box.x_min = x_of(world, kWidth - 3);
  off_map[0].box.x_max = x_of(world, kWidth + 4);
  off_map[1].id = 951;  // nowhere near the dataset
  off_map[1].box.x_min = x_of(world, -5000);
  off_map[1].box.x_max = x_of(world, -4990);
  std::vector<SessionBox> boxes = boxes_on(world, 200, 1, 21);
  // Keep the random boxes off the hole, so that only the chosen ones meet it.
  std::erase_if(boxes, [&](const SessionBox& b) {
    return b.box.x_max >= x_of(world, hole.col0 - 1) && b.box.x_min <= x_of(world, hole.col1) &&
           b.box.y_min <= y_of(world, hole.row0 - 1) && b.box.y_max >= y_of(world, hole.row1);
  });
  std::vector<SessionBox> all = boxes;
  all.insert(all.end(), on_void.begin(), on_void.end());
  all.insert(all.end(), off_map.begin(), off_map.end());

  for (ClipMode mode : {ClipMode::kFast, ClipMode::kConservative, ClipMode::kExact}) {
    const auto open = [&](const std::vector<SessionBox>& registered) {
      auto s = ClipSession::open(world.source, world.cache, pyramid_for(world, mode), options_for(mode, false),
                                 pose_at(world, 540.0, 330.0, 1));
      EXPECT_TRUE(s.ok()) << s.error().message;
      EXPECT_TRUE((*s)->add_boxes(registered).ok());
      return std::move(*s);
    };
    auto with = open(all), without = open(boxes);
    ASSERT_EQ(with->box_count(), all.size()) << mode_name(mode);
    std::size_t undetermined = 0;
    std::map<std::uint64_t, BoxChange> told_with, told_without;  // what each client holds
    for (int step = 0; step < 3; ++step) {
      const auto pose = pose_at(world, 540.0 + 15.0 * step, 330.0, static_cast<std::uint64_t>(step + 2));
      auto a = with->answer(pose), b = without->answer(pose);
      ASSERT_TRUE(a.ok()) << a.error().message;
      ASSERT_TRUE(b.ok()) << b.error().message;
      for (const BoxChange& c : a->changes) told_with[c.id] = c;
      for (const BoxChange& c : b->changes) told_without[c.id] = c;
      ASSERT_EQ(told_with.size(), all.size()) << mode_name(mode);
      for (const auto& [id, c] : told_without) {
        EXPECT_EQ(told_with[id].state, c.state) << mode_name(mode) << " box " << id;
        EXPECT_EQ(told_with[id].ohf_min, c.ohf_min) << mode_name(mode) << " box " << id;
      }
      for (const SessionBox& o : off_map) EXPECT_EQ(told_with[o.id].state, Visibility::kOutOfRange) << mode_name(mode);
      for (const SessionBox& v : on_void) {
        EXPECT_NE(told_with[v.id].state, Visibility::kOccluded) << mode_name(mode) << " box " << v.id;
        undetermined += step == 0 && told_with[v.id].state == Visibility::kUndetermined;
      }
      // Out of range and undetermined boxes may be seen: counted with the visible ones.
      EXPECT_EQ(a->visible, b->visible + off_map.size() + on_void.size()) << mode_name(mode);
    }
    // Buried under the known terrain: R3 (exact) and the min clip-map (conservative) hide them there.
    if (mode != ClipMode::kFast) {
      EXPECT_EQ(undetermined, on_void.size()) << mode_name(mode);
    }
  }
}

TEST(ClipSession, AnAsynchronousSessionAnswersEveryPoseWhileItsLoaderFollows) {
  ClipWorld world;
  auto session = ClipSession::open(world.source, world.cache, pyramid_for(world, ClipMode::kFast),
                                   options_for(ClipMode::kFast, true), pose_at(world, 60.0, 100.0, 1, 300.0));
  ASSERT_TRUE(session.ok()) << session.error().message;
  ASSERT_TRUE((*session)->add_boxes(boxes_on(world, 300, 1, 3)).ok());
  std::uint64_t loaded = 0;
  for (int step = 0; step < 120; ++step) {
    auto answer = (*session)->answer(
        pose_at(world, 60.0 + step * 7.0, 100.0 + step * 4.0, static_cast<std::uint64_t>(step + 2), 300.0));
    ASSERT_TRUE(answer.ok()) << answer.error().message;
    EXPECT_FALSE(answer->loader_error.has_value());
    ASSERT_EQ(answer->levels.size(), 4u);
    EXPECT_EQ(answer->levels[3].state.version, 1u) << "the full-extent level loads once";
    loaded += answer->subtiles_loaded;
  }
  EXPECT_GT(loaded, 0u) << "the loader followed the flight";
  EXPECT_GT((*session)->bytes(), 4u * 128u * 128u * 4u);
}

TEST(ClipSession, AGpuSessionAnswersEveryPoseAsTheCpuSessionDoes) {
  ClipWorld world;
  static auto pool = gpu::ContextPool::create({.contexts = 1});
  ASSERT_TRUE(pool.ok()) << pool.error().message;
  for (const ClipMode mode : {ClipMode::kFast, ClipMode::kConservative}) {
    SessionOptions cpu_options = options_for(mode, false);
    cpu_options.viewshed_radius = 4000.0;
    SessionOptions gpu_options = cpu_options;
    gpu_options.use_gpu = true;
    gpu_options.gpu = pool->get();
    const SessionPose first = pose_at(world, 80.0, 120.0, 1, 250.0);
    auto cpu = ClipSession::open(world.source, world.cache, pyramid_for(world, mode), cpu_options, first);
    auto gl = ClipSession::open(world.source, world.cache, pyramid_for(world, mode), gpu_options, first);
    ASSERT_TRUE(cpu.ok() && gl.ok()) << (cpu.ok() ? gl.error().message : cpu.error().message);
    const std::vector<SessionBox> boxes = boxes_on(world, 400, 1, 8);
    ASSERT_TRUE((*cpu)->add_boxes(boxes).ok());
    ASSERT_TRUE((*gl)->add_boxes(boxes).ok());
    std::size_t changes = 0;
    for (int step = 0; step < 40; ++step) {  // a diagonal flight: levels move and lag
      const SessionPose pose =
          pose_at(world, 80.0 + step * 19.0, 120.0 + step * 11.0, static_cast<std::uint64_t>(step + 2), 250.0);
      auto a = (*cpu)->answer(pose);
      auto b = (*gl)->answer(pose);
      ASSERT_TRUE(a.ok() && b.ok()) << (a.ok() ? b.error().message : a.error().message);
      EXPECT_FALSE(a->cull.gpu);
      EXPECT_TRUE(b->cull.gpu) << b->gpu_fallback;
      EXPECT_TRUE(b->gpu_fallback.empty()) << b->gpu_fallback;
      ASSERT_EQ(a->changes.size(), b->changes.size()) << mode_name(mode) << " pose " << pose.seq;
      for (std::size_t i = 0; i < a->changes.size(); ++i) {
        EXPECT_EQ(a->changes[i].id, b->changes[i].id);
        EXPECT_EQ(a->changes[i].state, b->changes[i].state);
        EXPECT_EQ(a->changes[i].ohf_min, b->changes[i].ohf_min);
      }
      EXPECT_EQ(a->cull.fallbacks, b->cull.fallbacks);
      ASSERT_TRUE(a->viewshed && b->viewshed);
      EXPECT_EQ(a->viewshed->hidden_cells, b->viewshed->hidden_cells);
      if (step > 0) changes += a->changes.size();
    }
    EXPECT_GT(changes, 0u) << "boxes must change state along the flight to mean anything";
  }
  // Without contexts every answer says why it ran on the CPU; exact sessions refuse the GPU.
  SessionOptions no_pool = options_for(ClipMode::kFast, false);
  no_pool.use_gpu = true;
  auto session = ClipSession::open(world.source, world.cache, pyramid_for(world, ClipMode::kFast), no_pool,
                                   pose_at(world, 300.0, 300.0, 1));
  ASSERT_TRUE(session.ok()) << session.error().message;
  auto answer = (*session)->answer(pose_at(world, 300.0, 300.0, 2));
  ASSERT_TRUE(answer.ok());
  EXPECT_FALSE(answer->cull.gpu);
  EXPECT_NE(answer->gpu_fallback.find("no GPU"), std::string::npos) << answer->gpu_fallback;
  SessionOptions exact = options_for(ClipMode::kExact, false);
  exact.use_gpu = true;
  exact.gpu = pool->get();
  auto refused = ClipSession::open(world.source, world.cache, pyramid_for(world, ClipMode::kConservative), exact,
                                   pose_at(world, 300.0, 300.0, 1));
  ASSERT_FALSE(refused.ok());
  EXPECT_EQ(refused.error().code, ErrorCode::kInvalidArgument);
  EXPECT_EQ(refused.error().field, "backend");
}

}  // namespace
}  // namespace horizon::clipmap
