// horizon/evaluation/region_bench.hpp — from-region visibility's runtime
// against error: the sweep behind `horizon bench --region`.
//
// For every DEM, `regions` region centres (valid ground, drawn with a fixed
// seed in the middle 60 % of the DEM), every region size (the side of a
// square footprint, ground metres), every fuzzy-array resolution
// (RegionOptions::face_resolution), every footprint split and every
// fuzzy_rows (0, the continuous cover, by default; N > 0 the seed's array
// of N slope rows on the same occluders, for comparison), run() times
// region::classify_cells (`warmup` untimed runs, then `repeats` timed, the
// median kept) over every cell within `max_distance` of the footprint, and
// counts the verdicts. A from-region answer is never wrong by construction,
// so its "error" is what it leaves undecided: the undetermined share of the
// answered cells. Soundness is checked too: with `check_points` > 0 each
// setting's verdicts on up to `check_cells` cells are tested with exact R3
// from the region's corners, edge midpoints, 8 points a face and
// `check_points` interior points (evaluation/region_check.hpp); any wrong
// verdict is reported in the row (and must be zero).
//
// Cost: DEMs x regions x sizes x resolutions x splits x rows x (warmup + repeats)
// classifications, plus one R3 check per setting (check_cells x viewpoints
// sight lines).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "horizon/common/control.hpp"
#include "horizon/common/error.hpp"
#include "horizon/evaluation/bench.hpp"

namespace horizon::evaluation {

struct RegionBenchConfig {
  std::vector<std::string> dems;                              // file paths
  int regions = 2;                                            // centres per DEM, >= 1
  std::vector<double> sizes = {30, 120, 480};                 // footprint sides, ground metres, > 0
  std::vector<int> face_resolutions = {64, 256, 1024, 4096};  // each [8, 65536]
  std::vector<int> footprint_splits = {2};                    // each [1, 16]
  std::vector<int> fuzzy_rows = {0};                          // each 0 or [2, 65536]
  // > 0: each region and size is also answered by the seed's own
  // construction (seed_fuzzy.hpp) on a fuzzy array of each face resolution
  // x seed_rows elements, beside the walls at footprint split 1 and rows 0
  // (both must be in the sweep); [8, 4096].
  int seed_rows = 0;
  double z_min = 2, z_max = 20;  // viewpoint heights above the ground, metres
  double target_height = 1.5;    // metres above each cell
  double max_distance = 3000;    // ground metres from the footprint, > 0
  double curvature = 0.85714;
  int repeats = 3, warmup = 1;
  int check_points = 200;  // interior viewpoints of the R3 check; 0: no check
  std::size_t check_cells = 2000;
  unsigned threads = 0;  // 0: all cores
};

struct RegionBenchRow {
  std::string dem;     // file name without directory
  std::string region;  // "region 1", ...
  // The footprint in the DEM's CRS (`horizon region --from-box` takes it as is).
  double x_min = 0, y_min = 0, x_max = 0, y_max = 0;
  double size_m = 0;
  std::string construction = "walls";  // or "seed" (seed_fuzzy.hpp: no always-visible test)
  int face_resolution = 0, footprint_splits = 0, fuzzy_rows = 0;
  int repeats = 0;
  double seconds_median = 0, seconds_min = 0;
  std::uint64_t cells = 0, always_hidden = 0, always_visible = 0, undetermined = 0;
  std::uint64_t walls_swept = 0, wall_nodes_read = 0, pyramid_cells_read = 0;
  // The seed's (SeedFuzzyStats), over its faces: patches and sub-surfaces,
  // the undecided items by reason, and its umbra elements.
  std::uint64_t patches = 0, sub_surfaces = 0, not_umbra = 0, too_deep = 0, off_array = 0;
  std::uint64_t elements = 0, umbra_elements = 0;
  std::uint64_t seed_only = 0;  // cells the seed hides and the walls (the row before, same cells) do not
  // The R3 check (zeros when not run).
  std::uint64_t checked_cells = 0, viewpoints = 0, wrong = 0;
  std::uint64_t sampled_hidden = 0, hidden_checked = 0;  // of the checked cells
  double decided() const { return cells ? double(always_hidden + always_visible) / double(cells) : 0.0; }
};

struct RegionBenchReport {
  std::vector<RegionBenchRow> rows;
  std::vector<std::string> notes;  // centres skipped (a region off the DEM or over voids)
};

// Validates the config (kInvalidArgument naming the field: "sizes",
// "face_resolutions", ...), then runs the sweep; progress is the fraction
// of (DEM, region, size) units done, cancellation polled between runs.
Result<RegionBenchReport> run_region_bench(const RegionBenchConfig& config, const RunControl* control = nullptr);

// Per DEM and setting (size, resolution, splits, rows), pooled over the
// regions: time summed, verdicts summed. As bench.hpp's Aggregate for the
// chart: algorithm = "<size> m region" (" (seed)" for the seed's
// rows), setting = "<resolution>" (", NxN"
// when the splits are not 2, ", R rows" for the seed's array), iou =
// decided share (so error() is the
// undetermined share), the front marked per DEM and size.
std::vector<Aggregate> aggregate_regions(const std::vector<RegionBenchRow>& rows);

// CSV, one line per row, with a header line.
Status write_region_csv(const std::string& path, const std::vector<RegionBenchRow>& rows);
// Markdown: per DEM a table of the pooled settings (time, decided, hidden,
// visible, undetermined, wrong, the share of sampled-hidden cells decided).
Status write_region_markdown(const std::string& path, const RegionBenchReport& report, const std::string& command);
// The chart's words for aggregate_regions' groups.
ChartText region_chart_text();

}  // namespace horizon::evaluation
