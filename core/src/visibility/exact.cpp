// Exact sweep: R3's maxima, found by pruning stretches of each sight line
// with a terrain max-pyramid below a lower bound (see exact.hpp).
#include "horizon/visibility/exact.hpp"

#include <algorithm>
#include <array>
#include <atomic>
#include <bit>
#include <cmath>
#include <limits>
#include <optional>
#include <vector>

#include "crossings.hpp"
#include "exact_screen.hpp"
#include "polar_bounds.hpp"
#include "horizon/common/parallel.hpp"
#include "horizon/terrain/pyramid.hpp"
#include "horizon/visibility/radial_sweep.hpp"
#include "horizon/visibility/viewshed.hpp"

namespace horizon::visibility {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
// Cells from the eye that the polar bounds cover (polar_bounds.hpp). On the
// 12 M-cell Everest case, measured with rings doubling: 256 cells built in
// 0.02 s and left 0.80 G crossings to screen; 512 cells, 0.07-0.09 s and
// the same 0.80 G; 1024 cells, 0.43 s.
constexpr double kPolarReach = 256;
// Stretches of kTile[l] cells along the major axis, bounded by the tile
// maxima of pyramid level l + 1 (tiles of kTile[l] cells; voids ignored,
// -inf for an all-void tile). A stretch of the sight line's leaf length that
// the pyramid does not prune is screened crossing by crossing. For R3's
// whole OHF the leaves are 64 cells: on the 12 M-cell case that took 2.9 s
// where 8-cell leaves, one pyramid read more each, took 3.4 s (0.73 G
// crossings screened against 0.41 G). To decide visibility alone, pruned
// against the target's own sight line, 8-cell leaves screened 50 M
// crossings and took 0.55 s; 64-cell ones, 55 M and 0.55 s.
constexpr int kLevels = 3;
constexpr std::array<int, kLevels> kTile = {8, 64, 512};
constexpr int kOhfLeaf = 1, kDecideLeaf = 0;  // indices into kTile
// Blocks of 1024 cells hold the levels of 8, 64 and 512 cells; build_all
// lays them out flat, with spans, so that a stretch spanning at most two
// tiles each way is answered by one read.
constexpr terrain::PyramidShape kMaxShape{8, 3};
constexpr terrain::PyramidOptions kMaxOptions{.block_cells = 1024, .spans = true};

// One target's sight line and the search state.
struct SightLine {
  const terrain::HeightView* z;
  const ViewFrame* f;
  const terrain::Pyramid* pyramid;   // kMax over the window, built
  const detail::PolarBounds* polar;  // null: no ring bounds (visibility only)
  double c0, r0, c1, r1;  // eye and target, grid coordinates
  double total;           // metres
  double major;           // |extent| along the major axis, cells
  double floor_slope;     // prune below this (the lower bound, minus a safety margin)
  int leaf = kOhfLeaf;    // the level of the stretches screened crossing by crossing
  double best = -kInf;    // highest exact sample slope found
  std::uint64_t samples = 0;
  // Visibility only: a crossing above floor_slope is checked against the
  // viewshed's rule at (target_ground, target_height); the first that hides
  // the target ends the search (stop).
  bool decide = false;
  float target_ground = 0, target_height = 0;
  bool stop = false;

  // The viewshed's own rule (viewshed.cpp: min_target_height, visibility_mask)
  // on the OHF value R3 would store for a maximum at slope s.
  bool hides(double s) const { return hides_value(static_cast<float>(detail::r3_ohf_value(*f, total, s))); }
  bool hides_value(float ohf) const { return !(target_height >= min_target_height_at(ohf, target_ground)); }

  double col_at(double t) const { return c0 + t * (c1 - c0); }
  double row_at(double t) const { return r0 + t * (r1 - r0); }

  // Search [ta, tb] as stretches of about kTile[l] cells along the major axis.
  void split(int l, double ta, double tb) {
    const int pieces = std::max(1, detail::ceil_to_int((tb - ta) * major / kTile[l]));
    const double step = (tb - ta) / pieces;
    for (int i = pieces - 1; i >= 0 && !stop; --i) search(l, ta + i * step, i + 1 == pieces ? tb : ta + (i + 1) * step);
  }

  // The whole sight line: beyond the polar bounds' rings, then ring by ring
  // outwards from the eye, skipping a ring whose bound in this direction is
  // below the slope to beat (by a margin past the rounding of both slopes),
  // and stopping where no ring further out can beat it. Neighbouring rings
  // that are not skipped are screened as one stretch, without the pyramid:
  // the ring's bound in this direction is far tighter than its square tiles
  // near the eye (on the 12 M-cell case, kept rings searched through the
  // pyramid took 1.84-1.92 s, screened outright 1.72-1.75 s).
  void search_all() {
    prepare_screens();
    if (polar == nullptr) {
      search_range(0.0, 1.0);
      return;
    }
    const double angle = detail::PolarBounds::pseudo_angle(c1 - c0, r1 - r0);
    double t_end = 1.0;  // where the rings end along this sight line
    const double t_out = polar->outer(polar->rings() - 1) / total;
    if (t_out < 1.0) {
      search_range(t_out, 1.0);
      t_end = t_out;
    }
    const auto skipped = [&](float bound) {
      const double T = std::max(floor_slope, best);
      return bound < T - 1e-9 * (1.0 + std::abs(T));
    };
    double t_lo = 0.0;    // ring k's inner end
    double run_lo = -1;   // the inner end of the rings kept and not searched yet, or -1
    for (int k = 0; k < polar->rings() && t_lo < t_end && !stop; ++k) {
      if (skipped(polar->beyond(k, angle))) break;
      const double t_hi = k + 1 == polar->rings() ? t_end : std::min(polar->inner(k + 1) / total, t_end);
      if (skipped(polar->bound(k, angle))) {
        if (run_lo >= 0) screen_stretch(run_lo, t_lo);
        run_lo = -1;
      } else if (run_lo < 0) {
        run_lo = t_lo;
      }
      t_lo = t_hi;
    }
    if (run_lo >= 0 && !stop) screen_stretch(run_lo, t_lo);
  }

  // The stretch t in [ta, tb], from the coarsest level shorter than it.
  void search_range(double ta, double tb) {
    int l = kLevels - 1;
    while (l > leaf && kTile[l] >= (tb - ta) * major) --l;
    split(l, ta, tb);
  }

  // Search the stretch t in [ta, tb] at level l.
  void search(int l, double ta, double tb) {
    // The cells that this stretch's crossings read lie within one cell of it
    // along the major axis (a crossing of a minor-axis line reads the cells
    // on either side of it).
    const double pad = 1.0 / major;
    const double lo = std::max(0.0, ta - pad), hi = std::min(1.0, tb + pad);
    const double ca = col_at(lo), cb = col_at(hi), ra = row_at(lo), rb = row_at(hi);
    // Grid coordinates are >= -0.5, so int(x + 1) - 1 is floor(x).
    const int c_lo = static_cast<int>(std::min(ca, cb) + 1.0) - 1, c_hi = static_cast<int>(std::max(ca, cb) + 1.0);
    const int r_lo = static_cast<int>(std::min(ra, rb) + 1.0) - 1, r_hi = static_cast<int>(std::max(ra, rb) + 1.0);
    const int wc = f->window.col0, wr = f->window.row0;
    const double zmax = pyramid->cover_built(l + 1, c_lo - wc, c_hi - wc, r_lo - wr, r_hi - wr);
    // A sample at distance d beats slope T only if its terrain reaches
    // eye + T d + curvature d^2 (convex in d): prune when zmax stays below
    // that height's minimum over [d_lo, d_hi]. The margin outweighs the
    // rounding of the samples' own arithmetic.
    const double T = std::max(floor_slope, best);
    if (T == -kInf) {
      if (zmax == -kInf) return;  // all void
    } else {
      const double d_lo = lo * total, d_hi = hi * total;
      const double curv = f->curvature;
      double d = T >= 0 ? d_lo : (curv > 0 ? std::clamp(-T / (2 * curv), d_lo, d_hi) : d_hi);
      const double needed = f->eye + T * d + curv * d * d;
      if (zmax < needed - 1e-6 * (1.0 + std::abs(needed))) return;
    }
    if (l > leaf) {
      split(l - 1, ta, tb);
      return;
    }
    screen_stretch(ta, tb);
  }

  // The column and row lines crossed within [ta, tb], widened by a hair
  // so that rounding cannot drop a line between neighbouring stretches
  // (one seen by both is harmless: the maximum is idempotent). Each crossing
  // is screened first (exact_screen.hpp); only one that may reach the
  // bound, or reads a void, is taken exactly as R3 takes it.
  void screen_stretch(double ta, double tb) {
    constexpr double kHair = 1e-9;  // cells
    const double cs = col_at(ta), ce = col_at(tb), rs = row_at(ta), re = row_at(tb);
    screen(detail::Axis::kColumns, detail::ceil_to_int(std::min(cs, ce) - kHair),
           detail::floor_to_int(std::max(cs, ce) + kHair));
    screen(detail::Axis::kRows, detail::ceil_to_int(std::min(rs, re) - kHair),
           detail::floor_to_int(std::max(rs, re) + kHair));
  }

  // The screen's view of this sight line's crossings with each family of
  // grid lines (index 0: column lines, 1: row lines).
  std::array<detail::ScreenedFamily, 2> families{};

  void prepare_screens() {
    for (const detail::Axis axis : {detail::Axis::kColumns, detail::Axis::kRows})
      families[axis == detail::Axis::kColumns ? 0 : 1] =
          detail::screen_family(*z, axis, c0, r0, c1, r1, total, f->eye, f->curvature);
  }

  // Screens the crossings with lines [line_lo, line_hi] of one family.
  void screen(detail::Axis axis, int line_lo, int line_hi) {
    const int i = axis == detail::Axis::kColumns ? 0 : 1;
    const int first = std::max(line_lo, families[i].first), last = std::min(line_hi, families[i].last);
    if (first > last) return;
    samples += static_cast<std::uint64_t>(last - first + 1);
    auto exact = [&](double t, double, double, double terrain) {
      const double s = detail::r3_slope(*f, total, t, terrain);
      if (!(s > best)) return;  // NaN (void) never wins
      best = s;
      if (decide && s > floor_slope && hides(s)) stop = true;
    };
    // Batches of up to 64 lines, screened against the slope to beat as it
    // stood when the batch began (a lower one only lets more through).
    for (int line = first; line <= last; line += 64) {
      std::uint64_t hits =
          detail::screen_crossings(families[i].screen, line, std::min(64, last - line + 1), std::max(floor_slope, best));
      for (; hits != 0; hits &= hits - 1) {
        const int hit = line + std::countr_zero(hits);
        detail::for_each_crossing_on(axis, *z, c0, r0, c1, r1, hit, hit, exact);
        if (stop) return;
      }
    }
  }
};

}  // namespace

Status exact_ohf(const terrain::HeightView& z, const ViewFrame& f, const RadialOptions& radial, unsigned threads,
                 const RunControl* control, terrain::Grid<float>& ohf, WorkStats& stats,
                 std::optional<double> visibility_only_at) {
  // 1. Lower bounds (into `ohf`, overwritten below cell by cell).
  // Progress: the bound is a few percent of the work; report it as the first 5 %.
  constexpr double kBoundShare = 0.05;
  RunControl bound_control;
  if (control) {
    bound_control.cancel = control->cancel;
    bound_control.deadline = control->deadline;
    if (control->progress) bound_control.progress = [control](double x) { control->progress(kBoundShare * x); };
  }
  WorkStats radial_stats;
  HORIZON_RETURN_IF_ERROR(radial_ohf(z, f, radial, threads, control ? &bound_control : nullptr, ohf, radial_stats,
                                     RadialBound::kLowerBound));
  terrain::Pyramid pyramid(z, f.window, terrain::Reduction::kMax, kMaxShape, kMaxOptions);
  pyramid.build_all(threads);  // every sight line reads it: built up front, read without checks
  // Near the eye, bounds that follow the sight lines, out to kPolarReach
  // cells or the window's farthest corner. Not for visibility only: there
  // the target's own sight line already prunes the near stretches.
  std::optional<detail::PolarBounds> polar;
  if (!visibility_only_at) {
    const double farthest = std::sqrt(f.farthest_distance2(f.window));
    polar.emplace(z, f, std::min(farthest, kPolarReach * std::max(f.metres_per_col, f.metres_per_row)), threads);
  }
  const detail::PolarBounds* rings = polar ? &*polar : nullptr;
  const terrain::Window& win = f.window;

  std::atomic<std::uint64_t> evaluated{0}, samples{0};
  const auto search_row = [&](std::size_t i) {
    const int row = win.row0 + static_cast<int>(i);
    float* out = ohf.row(static_cast<int>(i));
    std::uint64_t n = 0, s = 0;
    for (int col = win.col0; col < win.col1; ++col) {
      float& cell = out[col - win.col0];
      if (std::isnan(cell)) continue;  // out of range or a void target: no answer, as in R3
      const double d = f.distance(col, row);
      ++n;
      if (d == 0) {
        cell = -std::numeric_limits<float>::infinity();
        continue;
      }
      SightLine line{&z, &f, &pyramid, rings, f.observer_col, f.observer_row, double(col), double(row), d,
                     std::max(std::abs(col - f.observer_col), std::abs(row - f.observer_row)), -kInf};
      if (visibility_only_at) {
        line.decide = true;
        line.leaf = kDecideLeaf;
        line.target_ground = z.at(col, row);
        line.target_height = static_cast<float>(*visibility_only_at);
        // The bound hides the target: so does R3's maximum (at least the bound).
        if (std::isfinite(cell) && line.hides_value(cell)) continue;
        // Below this slope no crossing can hide the target: the highest OHF
        // value that leaves it visible, stepped down past float rounding.
        const double ceiling = double(line.target_ground) +
                               std::max(double(kTieTolerance), double(line.target_height));
        const double slack = 4.0 * std::numeric_limits<float>::epsilon() * std::abs(ceiling) + 1e-6;
        const double slope = (ceiling - slack - f.eye - f.curvature * d * d) / d;
        line.floor_slope = slope - 1e-9 * (1.0 + std::abs(slope));
        line.search_all();
        s += line.samples;
        // Hidden: the value that hid it (R3's maximum or below, same answer);
        // visible: the higher of the bound and the samples seen, both visible.
        if (line.best != -kInf) {
          const float found = static_cast<float>(detail::r3_ohf_value(f, d, line.best));
          cell = std::isfinite(cell) ? std::max(cell, found) : found;
        }
        continue;
      }
      if (std::isfinite(cell)) {
        // The bound arrives rounded to float, possibly upwards by half a unit
        // in the last place: step below that before turning it into a slope.
        const double slack = 2.0 * std::numeric_limits<float>::epsilon() * std::abs(double(cell)) + 1e-6;
        const double lower = (double(cell) - slack - f.eye - f.curvature * d * d) / d;
        line.floor_slope = lower - 1e-9 * (1.0 + std::abs(lower));
      }
      line.search_all();
      s += line.samples;
      cell = line.best == -kInf ? -std::numeric_limits<float>::infinity()
                                : static_cast<float>(detail::r3_ohf_value(f, d, line.best));
    }
    evaluated += n;
    samples += s;
  };
  HORIZON_RETURN_IF_ERROR(
      parallel_for(static_cast<std::size_t>(win.height()), threads, control, search_row, kBoundShare, 1.0));
  stats.cells_evaluated = evaluated;
  stats.rays = radial_stats.rays;
  stats.terrain_samples = radial_stats.terrain_samples + samples;
  return Status::Ok();
}

}  // namespace horizon::visibility
