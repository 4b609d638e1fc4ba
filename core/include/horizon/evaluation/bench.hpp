// horizon/evaluation/bench.hpp — runtime against error: the sweep behind
// `horizon bench`.
//
// For every DEM, every observer and every *setting* (an algorithm with one
// choice of its accuracy knobs), run_bench() computes the viewshed `warmup`
// times untimed and `repeats` times timed (wall time of compute_viewshed(),
// median and minimum kept), and measures the result against R3 on the same
// DEM, observer and window with visibility::compare_viewsheds() (IoU,
// missed-visible, extra-visible, OHF RMSE and max error; the observer's cell
// and its 8 neighbours excluded). R3's first run is the reference, and R3 is
// timed like any other setting (its error is 0 by definition).
//
// Peers (gdal_viewshed, GRASS r.viewshed; evaluation/peers.hpp) run on the
// same DEM files and observers when installed; their output rasters are read
// back, aligned to the reference window by georeference, and measured the same
// way. A peer that is not installed is reported in BenchReport::notes, not an
// error.
//
// The knob table is data: kKnobTable in bench.cpp holds one line per named
// setting ("fast" x ray spacing x blend, "exact", "conservative", "r3").
// Adding a knob to the sweep is one line there.
//
// Cost: settings x observers x (warmup + repeats) viewsheds per DEM, plus one
// R3 per observer. R3 is O(cells^1.5) on a square DEM: seconds at 1 M cells on
// two cores.
//
// This module is for tools and tests; the daemon does not link it
// (CMake target horizon_evaluation).
#pragma once

#include <cstdint>
#include <functional>
#include <limits>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "horizon/common/control.hpp"
#include "horizon/common/error.hpp"
#include "horizon/gpu/context_pool.hpp"
#include "horizon/terrain/dem.hpp"
#include "horizon/visibility/agreement.hpp"
#include "horizon/visibility/options.hpp"

namespace horizon::evaluation {

// One named setting of one algorithm's accuracy knobs: a line of the table.
struct KnobSetting {
  std::string_view algorithm;  // as visibility::algorithm_name(): "fast", "exact", "conservative", "r3"
  std::string_view name;       // "spacing 0.5, linear"; unique within the algorithm
  void (*apply)(visibility::ViewshedOptions& options);  // sets knobs on top of the defaults; null: none
};

// The whole table, in sweep order.
std::span<const KnobSetting> knob_table();

// A setting as swept: is_default marks the one equal to the engine's default
// knobs (what `horizon viewshed --algorithm X` runs without knob flags). When
// no line of the table is the engine's default, a "default (...)" setting is
// added first, so the default is always measured.
struct SweepSetting {
  std::string algorithm, name;
  bool is_default = false;
  void (*apply)(visibility::ViewshedOptions& options) = nullptr;
};

// The settings of the named algorithms, in table order; kInvalidArgument
// (field "algorithms") for a name that is not an algorithm or has no setting.
Result<std::vector<SweepSetting>> settings_for(std::span<const std::string> algorithms);

// An observer position with a label ("summit", "random 3", "given 1").
struct ObserverPick {
  std::string kind;
  int col = 0, row = 0;
};

// `count` deterministic observers of different character: summit (highest
// valid cell), ridge and valley (nearest the centre at the 85th / 10th
// elevation percentile), edge (middle row, 3 cells in), then valid cells drawn
// with a fixed seed. Fewer when the DEM has fewer valid cells.
std::vector<ObserverPick> pick_observers(const terrain::Dem& dem, int count, std::uint32_t seed = 20261122);

enum class Peer { kGdal, kGrass };
std::string_view peer_name(Peer peer);  // "gdal", "grass"

struct BenchConfig {
  std::vector<std::string> dems;  // file paths
  int observers = 4;              // picked per DEM when `observer_xy` is empty
  // In each DEM's CRS; overrides `observers`. Each is snapped to the centre of
  // the cell it falls in (the peers are given the same point); one outside a
  // DEM is skipped with a note.
  std::vector<std::pair<double, double>> observer_xy;
  std::vector<std::string> algorithms = {"fast", "exact", "conservative", "r3"};
  int repeats = 3;  // timed runs per setting, >= 1
  int warmup = 1;   // untimed runs first, >= 0
  std::vector<Peer> peers = {Peer::kGdal, Peer::kGrass};
  double observer_height = 2.0;  // metres above ground
  double target_height = 0.0;    // metres above ground
  double curvature = 0.85714;    // GDAL's coefficient
  double max_distance = std::numeric_limits<double>::infinity();
  unsigned threads = 0;  // 0 = all cores (peers use their own defaults)
  std::string work_dir;  // where peer rasters are written (must exist)
  // Runs the knob table's GPU rows ("gpu ...") on this pool; null: they are
  // skipped, with a note. The fragment one-step row draws once per step
  // outward and is skipped (with a note) on windows wider than this.
  gpu::ContextPool* gpu = nullptr;
  int gpu_one_step_limit = 1024;
};

struct BenchRow {
  std::string dem;  // file name without directory
  int epsg = 0;
  int dem_width = 0, dem_height = 0;
  std::string observer;   // ObserverPick::kind
  int col = 0, row = 0;   // observer cell
  double x = 0, y = 0;    // its centre in the DEM's CRS
  std::string algorithm;  // "fast", ..., or the peer's name
  std::string setting;    // KnobSetting::name, or the peer's command
  bool is_default = false;
  bool is_peer = false;
  std::string timing;  // what the time covers ("compute", "process", "r.viewshed module")
  int repeats = 0;
  double seconds_median = 0, seconds_min = 0;
  std::uint64_t cells_evaluated = 0;
  visibility::Agreement error;  // against R3; ohf_* NaN when the peer gives no heights
};

struct BenchReport {
  std::vector<BenchRow> rows;
  std::vector<std::string> notes;  // peers missing or failing, observers skipped
};

// Validates the config (kInvalidArgument naming the field), then runs the
// sweep. Progress is reported through control->progress as the fraction of
// (DEM, observer, setting-or-peer) units done; cancellation is polled between
// runs. A DEM that cannot be read is an error; an observer on a void is
// skipped with a note.
Result<BenchReport> run_bench(const BenchConfig& config, const RunControl* control = nullptr);

// --- Aggregates and outputs (report.cpp) -----------------------------------

// A setting's results pooled over observers: time summed, agreement counts
// pooled, OHF RMSE pooled by cells compared, OHF max the worst.
struct Aggregate {
  std::string dem;  // "" for the pool over every DEM
  std::string algorithm, setting;
  bool is_default = false, is_peer = false;
  int observers = 0;
  double seconds = 0;  // sum of the per-observer medians
  std::uint64_t cells_compared = 0, reference_visible = 0, missed = 0, extra = 0, both = 0;
  double iou = 1, missed_rate = 0, extra_rate = 0, ohf_rmse = 0, ohf_max = 0;
  bool on_front = false;  // not dominated in (seconds, 1 - iou) within its group
  double error() const { return 1.0 - iou; }
};

// Per DEM (in row order) and, when `overall`, pooled over all DEMs (dem "").
// Each group's Pareto front is marked. Only settings present for every
// observer of a DEM are pooled across DEMs.
std::vector<Aggregate> aggregate(const std::vector<BenchRow>& rows, bool overall);

// Marks the members of `group` that no other member beats on both time and
// error (ties on both count as not dominated).
void mark_front(std::vector<Aggregate*>& group);

// CSV, one line per BenchRow, with a header line.
Status write_csv(const std::string& path, const std::vector<BenchRow>& rows);
// The Markdown tables of docs/benchmarks.md: per DEM, then pooled.
Status write_markdown(const std::string& path, const BenchReport& report, const std::vector<Aggregate>& aggregates,
                      const std::string& command);

// A PNG chart of one group (aggregates with the same `dem`): time on a
// log axis against 1 - IoU on a log axis (exact answers on a "0" line),
// one colour per algorithm with a legend, the Pareto front drawn.
// The words around the plot: the region sweep (region_bench.hpp) draws its
// own axes' meaning on the same chart.
struct ChartText {
  std::string x_axis = "time, summed over the observers (log scale)";
  std::string y_axis = "error: 1 - IoU against R3 (log scale)";
  std::string zero_line = "0 (exact)";
  std::vector<std::string> notes = {"time: Horizon compute;", "gdal whole process;", "grass r.viewshed module"};
  int error_floor_log = -3;  // the error axis' lowest decade: 10^-3 %
  // Draw the Pareto front and name its points; otherwise join each
  // algorithm's points in group order and name every point by its setting.
  bool pareto_front = true;
};
Status write_chart(const std::string& path, const std::vector<Aggregate>& group, const std::string& title,
                   const ChartText& text = {});

}  // namespace horizon::evaluation
