// horizon/evaluation/stress.hpp — numerical-stability stress checks, shared
// by the test suite (tests/stress/) and `horizon stress`.
//
// Each check builds inputs meant to break an algorithm and checks a property
// rather than a fixed output: invariance under a change that must not matter
// (moving the DEM 1e6 m, scaling cells and heights together, adding 8848 m to
// every height, cropping cells the viewshed never looks at), an analytic
// answer (flat terrain is all visible, nothing behind a 1000 m wall is seen,
// a neighbour cell is always seen), monotonicity (raising the eye or the
// target never hides a visible cell), consistency (the minimum visible height
// is >= 0 and reproduces the viewshed at any target height) and clean errors
// (an observer outside the DEM or on a void). Every check can fail: each one
// counts the cells (or cases) that break it and keeps the worst deviation.
//
// Monotonicity is held to what each algorithm promises, as matches_r3 is.
// R3 and exact give R3's answers, which are monotone: any cell that raising
// the eye hides fails them. fast and conservative take each cell's horizon
// from samples chosen by the eye's own height, so their *errors* move as the
// eye rises: a cell they wrongly see from the lower eye (an extra-visible
// error there, which both may make) can be rightly hidden from the higher
// one. Such a cell is counted as `explained`, with R3 asked at that cell
// whether it hides it from the lower eye; a cell R3 sees from the lower eye
// (and so from the higher one) that the algorithm hides from the higher eye
// fails the check. docs/stress.md explains why no O(cells) sampling whose
// samples follow the eye can be monotone outright.
//
// Deviations are in the unit the check names: "cells" (cells whose
// visibility differs from what the property demands) or "cases" (runs that
// failed or succeeded when they should not have); invariance checks also keep
// the worst OHF deviation in metres. Cells within the OHF tolerance of the
// engine's 1 mm tie threshold may flip in invariance checks (a tolerated OHF
// difference can legitimately decide a near-tie either way).
//
// The float32-against-double comparison is not here (it belongs with the
// algorithms).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "horizon/common/control.hpp"
#include "horizon/common/error.hpp"
#include "horizon/gpu/context_pool.hpp"
#include "horizon/visibility/options.hpp"

namespace horizon::evaluation {

struct StressConfig {
  std::vector<visibility::Algorithm> algorithms = {visibility::Algorithm::kRadial, visibility::Algorithm::kExact,
                                                   visibility::Algorithm::kConservative, visibility::Algorithm::kR3};
  // Real DEMs for the dem_* property checks (may be empty: those checks then
  // report 0 cases).
  std::vector<std::string> dems;
  int observers_per_dem = 3;  // random valid cells, fixed seed
  std::uint32_t seed = 20261122;
  // Radius of the dem_* viewsheds in cells of the DEM (0 = the whole DEM);
  // only the cells within reach are read (window reads), so large DEMs stay cheap.
  int radius_cells = 150;
  // Synthetic DEM side for the synthetic checks, cells (>= 64).
  int synthetic_size = 96;
  unsigned threads = 0;
  // When set, every check also runs fast on this pool's GL contexts
  // (backend gpu), reported as algorithm "fast-gpu".
  gpu::ContextPool* gpu = nullptr;
};

struct CheckResult {
  std::string check;          // e.g. "flat_all_visible"
  std::string algorithm;      // "fast", "exact", "conservative", "r3", "fast-gpu"
  std::string description;    // one line: what must hold
  std::uint64_t cases = 0;    // inputs tried
  std::uint64_t failed = 0;   // cases where the property did not hold
  double worst = 0;           // the worst deviation seen, in `unit`
  std::string unit;           // "cells", "cases"
  double worst_ohf = 0;       // the worst OHF deviation beyond the expected one, metres (invariance checks)
  std::string first_failure;  // the first failing case, precisely (empty when none)
  // Cells that broke the property as the algorithm's own documented error
  // explains (dem_raise_observer, see above): not failures, but reported.
  std::uint64_t explained = 0;
  std::string first_explained;  // the first such case, precisely
  bool passed() const { return failed == 0; }
};

// The names of every check, in report order.
std::vector<std::string> stress_check_names();

// Runs the named checks (all when `checks` is empty) for every configured
// algorithm. kInvalidArgument for an unknown check name; a DEM that cannot be
// read is an error. Progress through control->progress; cancellation polled
// between cases.
Result<std::vector<CheckResult>> run_stress(const StressConfig& config, const std::vector<std::string>& checks = {},
                                            const RunControl* control = nullptr);

// The report as a Markdown table (check, algorithm, cases, pass/fail, worst
// deviation, worst OHF deviation, cells explained by the algorithm's own
// error, first failure).
std::string stress_markdown(const std::vector<CheckResult>& results);

}  // namespace horizon::evaluation
