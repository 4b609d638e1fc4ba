// horizon/evaluation/mesh_bench.hpp — TIN culling's runtime against
// error: the sweep behind `horizon bench --mesh`.
//
// For every DEM, a TIN of `vertices` vertices by greedy insertion (in the
// DEM's metric frame); for every sectors/subsectors shape, prepare_mesh
// timed once (its phases kept); then, in each cull mode, `cameras`
// viewpoints 2 m (`height`) above vertices drawn with a fixed seed, each
// culled `cull_repeats` times (the median microseconds a query kept). The
// first `exact_cameras` of them are checked against exact sight lines over
// the TIN (tin_visibility.hpp) at each triangle's corners and centroid: how
// many triangles no sample of which is seen ("exactly hidden", what a
// perfect cull could skip), and how many culled triangles have a sample in
// sight ("false hidden": the approximate mode's error; the conservative
// mode must have none).
//
// Cost: DEMs x shapes x (one preparation + modes x cameras x cull_repeats
// culls) plus modes x exact_cameras x triangles x 4 sight lines.
#pragma once

#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "horizon/common/control.hpp"
#include "horizon/common/error.hpp"

namespace horizon::evaluation {

struct MeshBenchConfig {
  std::vector<std::string> dems;
  std::uint32_t vertices = 10'000;  // >= 4
  std::vector<std::pair<int, int>> shapes = {{8, 1}, {8, 4}, {16, 4}, {32, 2}};
  int seeds = 100, max_groups = 200;  // the thesis's settings for 10^4 vertices
  int cameras = 50, cull_repeats = 20, exact_cameras = 5;
  double height = 2.0;  // metres above the vertex
  unsigned threads = 0;
};

struct MeshBenchRow {
  std::string dem;  // file name
  std::uint32_t vertices = 0, triangles = 0;
  int sectors = 0, subsectors = 0;
  std::string mode;  // "approximate" or "conservative"
  double prepare_seconds = 0, horizon_seconds = 0, grouping_seconds = 0, hierarchy_seconds = 0, wall_seconds = 0;
  std::uint32_t groups = 0, nodes = 0, always_visible = 0;
  double cull_us_median = 0, groups_tested = 0, culled_share = 0;  // share of triangle-views culled
  // The exact check over the first exact_cameras cameras.
  std::uint64_t checked_views = 0, exactly_hidden = 0, culled_checked = 0, false_hidden = 0;
};

struct MeshBenchReport {
  std::vector<MeshBenchRow> rows;
  std::string markdown() const;
  std::string csv() const;
};

// kInvalidArgument for a bad config; a DEM's read or TIN error as it is.
Result<MeshBenchReport> run_mesh_bench(const MeshBenchConfig& config, const RunControl* control = nullptr);

}  // namespace horizon::evaluation
