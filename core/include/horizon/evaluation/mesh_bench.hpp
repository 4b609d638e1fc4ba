// horizon/evaluation/mesh_bench.hpp — TIN culling's runtime against
// error: the sweep behind `horizon bench --mesh`.
//
// For every DEM, a TIN of `vertices` vertices by greedy insertion (in the
// DEM's metric frame); for every sectors/subsectors shape, prepare_mesh
// timed once (its phases kept); then, in each cull mode, `cameras`
// viewpoints above vertices drawn with a fixed seed (mesh_bench_cameras:
// in valleys, on slopes, on ridges, and high), each culled
// `cull_repeats` times (the median microseconds a query kept). The
// first `exact_cameras` of them are checked against exact sight lines over
// the TIN (tin_visibility.hpp) at each triangle's corners and centroid: how
// many triangles no sample of which is seen ("exactly hidden", what a
// perfect cull could skip), and how many culled triangles have a sample in
// sight ("false hidden": the approximate mode's error; the conservative
// mode must have none).
//
// The same checked cameras are also read against R3 on the DEM the TIN
// was made from (mesh_r3.hpp): over the DEM cells under the TIN's
// triangles, how many R3 hides ("truly hidden"), how many lie under a
// culled triangle, and how many of those R3 sees. The eye is the same
// point in both frames (the vertex's CRS place, its height plus
// `height`); R3 runs on a flat earth, as the TIN's frame is. The two
// references differ by the TIN's vertical error: the TIN-exact measure
// judges the cull by the surface drawn, the R3 one by the terrain.
//
// Cameras: mesh_bench_cameras(), the same for every shape and mode, of
// four kinds in turn (camera c is of kind c mod 4), each `height` above a
// vertex drawn uniformly from a band of the vertices sorted by height:
// valley (the lowest tenth), slope (the middle, 30 % to 70 %), ridge (the
// highest tenth), and high (any vertex, `high_eye` metres higher still).
//
// Cost: DEMs x shapes x (one preparation + modes x cameras x cull_repeats
// culls) plus modes x exact_cameras x triangles x 4 sight lines, plus
// DEMs x exact_cameras exact viewsheds of the whole DEM.
#pragma once

#include <cstddef>
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
  double height = 2.0;      // metres above the vertex
  double high_eye = 300.0;  // metres more for the high cameras, >= 0
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
  // R3 on the source DEM, the same cameras: cell-views (DEM cells under a
  // triangle with an R3 answer), those R3 hides, those under a culled
  // triangle, and those culled that R3 sees (mesh_r3.hpp).
  std::uint64_t r3_cells = 0, r3_hidden = 0, r3_culled = 0, r3_culled_visible = 0;
};

struct MeshBenchReport {
  std::vector<MeshBenchRow> rows;
  std::string markdown() const;
  std::string csv() const;
};

enum class CameraKind { kValley, kSlope, kRidge, kHigh };
const char* camera_kind_name(CameraKind kind);

struct MeshBenchCamera {
  std::uint32_t vertex = 0;
  double height = 0.0;  // above the vertex: config.height, plus config.high_eye for kHigh
  CameraKind kind = CameraKind::kValley;
};

// The cameras over `z` (the TIN's vertex heights, > 0 of them): `count`
// of the kinds above, drawn with a fixed seed (std::mt19937_64 seeded 1),
// so that a test can say where each camera stands.
std::vector<MeshBenchCamera> mesh_bench_cameras(const std::vector<double>& z, int count, double height,
                                                double high_eye);

// kInvalidArgument for a bad config; a DEM's read or TIN error as it is.
Result<MeshBenchReport> run_mesh_bench(const MeshBenchConfig& config, const RunControl* control = nullptr);

}  // namespace horizon::evaluation
