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
#include "horizon/common/parallel.hpp"
#include "horizon/terrain/pyramid.hpp"
#include "horizon/visibility/radial_sweep.hpp"
#include "horizon/visibility/viewshed.hpp"
#include "sector_bounds.hpp"

namespace horizon::visibility {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
// Cells by which a range of grid lines is widened, so that rounding cannot
// drop a line between neighbouring stretches (one seen by both is harmless:
// the maximum is idempotent).
constexpr double kHair = 1e-9;
// Cells from the eye (along the coarser grid axis, and at most kNearLines
// along the finer one: oblong cells, as a geographic DEM's, would make the
// table long) that the sector bounds cover (sector_bounds.hpp), and the
// side of the square tiles targets are searched in. On the 12 M-cell
// Everest case, against the ring bounds out to 307 cells this replaced
// (1.87 s): reach 512 cells and tiles of 32, 1.63 s; 768 and 64, 1.50 s
// with 4096 sectors, 1.40 s with 1024 or 2048; 1536 cells, 1.39-1.43 s
// with a table four times the size. On Rainier's SRTM tile (cells 0.68 as
// wide as high) 768 cells along the finer axis took 0.34 s, along the
// coarser 0.25 s.
constexpr double kNearReach = 768;
constexpr double kNearLines = 2048;
constexpr int kTargetTile = 64;
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
  const terrain::Pyramid* pyramid;      // kMax over the window, built
  const detail::SectorBounds* sectors;  // near the eye, built
  double c0, r0, c1, r1;                // eye and target, grid coordinates
  double total;                         // metres
  double major;                         // |extent| along the major axis, cells
  double floor_slope;                   // prune below this (the lower bound, minus a safety margin)
  int leaf = kOhfLeaf;                  // the level of the stretches screened crossing by crossing
  double best = -kInf;                  // highest exact sample slope found
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

  // The slope a sector bound must reach for its crossings to be searched:
  // the slope to beat, less a margin past the rounding of both slopes.
  double to_beat() const {
    const double T = std::max(floor_slope, best);
    return T - 1e-9 * (1.0 + std::abs(T));
  }

  // The whole sight line: beyond the sector bounds' reach through the
  // pyramid, unless the sector's far bound is below the slope to beat;
  // then within it only the lines whose bound in this sight line's sector
  // reaches that slope.
  void search_all() {
    prepare_screens();
    const double t_near = std::min(1.0, sectors->reach() / total);
    const double angle = detail::SectorBounds::pseudo_angle(c1 - c0, r1 - r0);
    if (t_near < 1.0 && !(sectors->beyond(angle, total) < to_beat())) search_range(t_near, 1.0);
    search_near(detail::Axis::kColumns, angle, t_near);
    if (!stop) search_near(detail::Axis::kRows, angle, t_near);
  }

  // The crossings with one family's lines up to t_near, on the lines whose
  // sector bound is not below the slope to beat (by a margin past the
  // rounding of both slopes): spans, then blocks, then entries, each kept
  // where its maximum reaches that slope.
  void search_near(detail::Axis axis, double angle, double t_near) {
    using detail::SectorBounds;
    constexpr int kBlock = SectorBounds::kBlock, kSpan = SectorBounds::kSpan;
    const SectorBounds::Lines lines = sectors->lines(angle, axis);
    const double end = axis == detail::Axis::kColumns ? col_at(t_near) : row_at(t_near);
    const int count = std::min(lines.count, detail::floor_to_int((end - lines.first) * lines.step + kHair) + 1);
    const auto threshold = [&] { return SectorBounds::round_up(to_beat()); };
    float below = threshold();
    int run = -1, next = 0;  // the kept entries [run, next) not screened yet; run -1: none
    const auto flush = [&] {
      if (run < 0) return;
      const int a = lines.first + lines.step * run, b = lines.first + lines.step * (next - 1);
      screen(axis, std::min(a, b), std::max(a, b));
      run = -1;
      below = threshold();
    };
    for (int span = 0; span * kSpan < count && !stop; ++span) {
      if (lines.span[span] < below) continue;
      std::uint32_t blocks = SectorBounds::at_least(lines.block + span * (kSpan / kBlock), below);
      while (blocks != 0 && !stop) {
        const int j0 = span * kSpan + std::countr_zero(blocks) * kBlock;
        blocks &= blocks - 1;
        if (j0 >= count) break;
        std::uint32_t kept = SectorBounds::at_least(lines.bound + j0, below);
        if (count - j0 < kBlock) kept &= (std::uint32_t{1} << (count - j0)) - 1;
        while (kept != 0) {
          const int i = std::countr_zero(kept), len = std::countr_one(kept >> i);
          kept &= ~(((std::uint32_t{1} << len) - 1) << i);
          if (run >= 0 && next == j0 + i) {
            next += len;
          } else {
            flush();
            if (stop) return;
            run = j0 + i;
            next = run + len;
          }
        }
      }
    }
    flush();
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

  // The column and row lines crossed within [ta, tb], widened by kHair.
  // Each crossing is screened first (exact_screen.hpp); only one that may
  // reach the bound, or reads a void, is taken exactly as R3 takes it.
  void screen_stretch(double ta, double tb) {
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
      std::uint64_t hits = detail::screen_crossings(families[i].screen, line, std::min(64, last - line + 1),
                                                    std::max(floor_slope, best));
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
  // Near the eye, bounds by direction sector and grid line, out to
  // kNearReach cells or the window's farthest corner.
  const double farthest = std::sqrt(f.farthest_distance2(f.window));
  const double reach = std::min({farthest, kNearReach * std::max(f.metres_per_col, f.metres_per_row),
                                 kNearLines * std::min(f.metres_per_col, f.metres_per_row)});
  const detail::SectorBounds sectors(z, pyramid, f, reach, threads);
  const terrain::Window& win = f.window;

  std::atomic<std::uint64_t> evaluated{0}, samples{0};
  // Targets in square tiles: neighbouring targets' sight lines share their
  // sectors' bounds and the terrain and pyramid around them.
  const int tiles_across = (win.width() + kTargetTile - 1) / kTargetTile;
  const int tiles_down = (win.height() + kTargetTile - 1) / kTargetTile;
  const auto search_tile = [&](std::size_t i) {
    const int col0 = win.col0 + static_cast<int>(i % tiles_across) * kTargetTile;
    const int row0 = win.row0 + static_cast<int>(i / tiles_across) * kTargetTile;
    const int col1 = std::min(col0 + kTargetTile, win.col1), row1 = std::min(row0 + kTargetTile, win.row1);
    std::uint64_t n = 0, s = 0;
    for (int row = row0; row < row1; ++row) {
      float* out = ohf.row(row - win.row0);
      for (int col = col0; col < col1; ++col) {
        float& cell = out[col - win.col0];
        if (std::isnan(cell)) continue;  // out of range or a void target: no answer, as in R3
        const double d = f.distance(col, row);
        ++n;
        if (d == 0) {
          cell = -std::numeric_limits<float>::infinity();
          continue;
        }
        SightLine line{&z,
                       &f,
                       &pyramid,
                       &sectors,
                       f.observer_col,
                       f.observer_row,
                       double(col),
                       double(row),
                       d,
                       std::max(std::abs(col - f.observer_col), std::abs(row - f.observer_row)),
                       -kInf};
        if (visibility_only_at) {
          line.decide = true;
          line.leaf = kDecideLeaf;
          line.target_ground = z.at(col, row);
          line.target_height = static_cast<float>(*visibility_only_at);
          // The bound hides the target: so does R3's maximum (at least the bound).
          if (std::isfinite(cell) && line.hides_value(cell)) continue;
          // Below this slope no crossing can hide the target: the highest OHF
          // value that leaves it visible, stepped down past float rounding.
          const double ceiling =
              double(line.target_ground) + std::max(double(kTieTolerance), double(line.target_height));
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
    }
    evaluated += n;
    samples += s;
  };
  HORIZON_RETURN_IF_ERROR(parallel_for(static_cast<std::size_t>(tiles_across) * tiles_down, threads, control,
                                       search_tile, kBoundShare, 1.0));
  stats.cells_evaluated = evaluated;
  stats.rays = radial_stats.rays;
  stats.terrain_samples = radial_stats.terrain_samples + samples;
  return Status::Ok();
}

}  // namespace horizon::visibility
