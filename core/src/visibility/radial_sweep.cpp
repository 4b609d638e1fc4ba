// Radial sweep occlusion height field.
//
// After US patent 7,027,046 (Benton et al., "Occlusion height field"):
// perspective modulation divides heights relative to the eye by distance, which
// turns "is this point above every sight line from the eye?" into a running
// maximum of slopes along radial lines; multiplying the maximum back by the
// distance gives the occlusion height field. Here the radial lines are exact
// rays marched grid line by grid line, sampling the terrain exactly where R3
// does (see r3.hpp). Each ray also records *where* its maximum lies. A cell
// centre lies between two rays; by default (RayBlend::kResample) it re-samples
// its own sight line on the grid lines where those two rays found their
// maxima, plus the line just before it, and takes the highest: every value is
// one of R3's samples of the cell's sight line, so the only error is a
// maximum that neither bracketing ray saw, and it errs towards "visible".
// RadialBound::kLowerBound takes those samples through R3's own arithmetic,
// which makes the result a strict lower bound of R3's OHF (Algorithm::
// kConservative, and the pruning bound of Algorithm::kExact).
//
// Geometry of one sector. Sectors are described in (u, v) coordinates: u runs
// along the sector's major axis away from the eye (rows for north/south,
// columns for east/west) and v across it. Line i of the sector is the grid line
// u = i, at "step" k_i = |i - u_eye| > 0 from the eye. Ray r has slope
// m_r = dv/dk, evenly spaced in [-1, 1]; at step k it is at v = v_eye + m_r k.
// Walking from line i-1 to line i a ray crosses at most one v grid line (since
// |m| <= 1) and then line i itself; both crossings are linear interpolations
// along a grid line, i.e. R3's samples. A cell (i, j) takes its horizon from
// the rays' state *before* their crossings in (k_{i-1}, k_i]: the exact segment
// to a cell centre crosses no v line in its last unit step, so this is the
// state that segment would have (the blends kLinear / kMin interpolate the
// two rays' horizons by angle instead of re-sampling).
//
// Horizons are kept per unit step rather than per metre: a ray sample at step
// k contributes sigma = (z - eye - curvature d^2) / k. Along one ray that is the
// slope times a constant, so the running maximum is the same; across rays it
// is linear in the ray slope on any planar terrain, so blending sigma between
// two rays is exact on planes (per-metre slopes carry the convex 1/|ray|).
//
// Rays are kept as structures of arrays, marched by tasks of kRaysPerTask
// neighbouring rays line by line; the per-line loops over a task's rays and
// over a line's cells are kernels with scalar, AVX2 and AVX-512 forms that
// give the same bits (ray_steps.hpp, resample_cells.hpp, resample_r3.hpp,
// simd.hpp).
#include "horizon/visibility/radial_sweep.hpp"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "column_lines.hpp"
#include "horizon/common/parallel.hpp"
#include "ray_steps.hpp"
#include "resample_cells.hpp"
#include "resample_r3.hpp"
#include "sweep_geometry.hpp"
#include "sweep_samples.hpp"

namespace horizon::visibility {
namespace {

using sweep::CellLine;
using sweep::CellRay;
using sweep::kNoHorizon;
using sweep::LineStep;
using sweep::sample_at;
using sweep::Sector;

constexpr int kRaysPerTask = 512;
// RadialOptions::thinning_levels: rays may be thinned near the eye, where
// they crowd together: at step k only every 2^L-th ray marches, L =
// floor(log2(k_far / k)) capped at the option, so the spacing between
// marching rays stays within (ray_spacing / 2, ray_spacing] cells there.
// Going outward, a ray that starts marching re-samples its path where its
// neighbours found their horizons (see spawn_rays). kRaysPerTask is a
// multiple of 2^kMaxThinning.
constexpr int kMaxThinning = 6;
static_assert(kRaysPerTask % (1 << kMaxThinning) == 0);

struct SweepConstants {
  double eye = 0.0;
  double curvature = 0.0;
  double max_distance = 0.0;
  RayBlend blend = RayBlend::kLinear;
  bool precise = false;                       // re-sample through R3's arithmetic (RadialBound::kLowerBound)
  float target_height = 0.0f;                 // radial_mask's: the codes' target height
  const terrain::HeightView* grid = nullptr;  // for R3's arithmetic
  const ViewFrame* frame = nullptr;
};

// Per-sector ray set and the nested per-line ranges of rays and cells.
struct SectorPlan {
  sweep::RayTable rays;               // rays r in [-rays.half, rays.half] (sweep_geometry.hpp)
  std::vector<int> cell_lo, cell_hi;  // per line: target cells j in [lo, hi], empty if lo > hi
  std::vector<int> ray_lo, ray_hi;    // per line: rays to update (nested: shrinking outward)
  double k0 = 1.0, level_far = 0.0;   // first step; the far step that thinning levels are measured from
  int max_level = 0;                  // RadialOptions::thinning_levels
  std::vector<float> inv_step;        // per line: 1 / step
  std::vector<float> inv_dv;          // per v index c: 1 / (c - eye_v), 0 where c == eye_v
};

inline double step_of(const Sector& s, int n) {
  return s.k0 + n;
}

// Floor of a / b for b > 0.
inline int floor_div(int a, int b) {
  return a >= 0 ? a / b : -((-a + b - 1) / b);
}

// `lines` is the geometry `s` was made from (sweep_sectors).
SectorPlan plan_sector(const Sector& s, const sweep::SectorLines& lines, const SweepConstants& c, double ray_spacing,
                       int thinning_levels) {
  SectorPlan p;
  const double k_far = step_of(s, s.lines - 1);
  // A multiple of 2^levels / 2, so that every task's first and last ray
  // survive thinning (tasks start kRaysPerTask apart from -ray_half).
  p.max_level = std::clamp(thinning_levels, 0, kMaxThinning);
  const int quantum = std::max(1, (1 << p.max_level) / 2);
  p.rays = sweep::ray_table(sweep::ray_half(k_far, ray_spacing, quantum), s.metres_u, s.metres_v, c.curvature);

  p.k0 = s.k0;
  p.level_far = k_far;
  p.inv_step = sweep::inv_steps(s.k0, s.lines);
  p.inv_dv = sweep::inv_dvs(s.eye_v, s.v_count);
  p.cell_lo.assign(s.lines, 0);
  p.cell_hi.assign(s.lines, -1);
  p.ray_lo.assign(s.lines, 0);
  p.ray_hi.assign(s.lines, -1);
  for (int n = 0; n < s.lines; ++n) {
    const double k = step_of(s, n);
    // Sector wedge: |j - v_eye| <= k (or < k), inside the window along v.
    const sweep::CellSpan wedge = sweep::owned_cells(*c.frame, lines, n);
    int jlo = std::max(wedge.lo, s.win_v0);
    int jhi = std::min(wedge.hi, s.win_v1 - 1);
    // Max-distance disc (exact test per cell happens in the kernel; this only bounds the loop).
    if (std::isfinite(c.max_distance)) {
      const double du = k * s.metres_u;
      const double rest = c.max_distance * c.max_distance - du * du;
      if (rest < 0) {
        jhi = jlo - 1;
      } else {
        // Compared as doubles first: a huge max_distance makes `rest` and
        // `reach` infinite, and casting those to int is undefined.
        const double reach = std::sqrt(rest) / s.metres_v;
        const double lo = std::floor(s.eye_v - reach), hi = std::ceil(s.eye_v + reach);
        if (lo > jlo) jlo = static_cast<int>(lo);
        if (hi < jhi) jhi = static_cast<int>(hi);
      }
    }
    p.cell_lo[n] = jlo;
    p.cell_hi[n] = jhi;
    if (jlo <= jhi) {
      // Rays bracketing the first and last cell: a cell at ray coordinate rho
      // blends rays floor(rho) and floor(rho) + 1 (even when rho is a whole
      // number); one ray of slack each side absorbs rounding differences.
      const double rl = std::floor((jlo - s.eye_v) / k / p.rays.step) - 1;
      const double rh = std::floor((jhi - s.eye_v) / k / p.rays.step) + 2;
      p.ray_lo[n] = std::clamp(static_cast<int>(rl), -p.rays.half, p.rays.half);
      p.ray_hi[n] = std::clamp(static_cast<int>(rh), -p.rays.half, p.rays.half);
    } else {
      p.ray_lo[n] = p.rays.half + 1;
      p.ray_hi[n] = -p.rays.half - 1;
    }
  }
  // A ray needed at line n must have been marched through every earlier line.
  for (int n = s.lines - 2; n >= 0; --n) {
    if (p.ray_lo[n + 1] <= p.ray_hi[n + 1]) {
      p.ray_lo[n] = std::min(p.ray_lo[n], p.ray_lo[n + 1]);
      p.ray_hi[n] = std::max(p.ray_hi[n], p.ray_hi[n + 1]);
    }
  }
  return p;
}

// Per-task scratch: one entry per ray of the task.
struct RayScratch {
  std::vector<float> horizon;      // running max slope up to the last line marched
  std::vector<float> cross_slope;  // slope at the v-line crossing inside the current step, kNoHorizon if none
  std::vector<int> cross_v;        // the v-line crossed in the current step, -1 if none
  std::vector<int> arg;            // where the horizon was found: line step n >= 0, or -2 - v for v-line v
  std::vector<float> slope, inv_slope, curv_k;  // the marching rays' constants (copied from the plan)
  std::vector<int> code;                        // per line: where each ray's horizon lies, this step's crossing counted
};

int level_of(const SectorPlan& p, int n) {
  if (p.max_level == 0 || p.level_far <= 0) return 0;
  const double ratio = p.level_far / (p.k0 + n);
  if (ratio < 2.0) return 0;
  return std::min(p.max_level, static_cast<int>(std::floor(std::log2(ratio))));
}

// The marching rays' constants at `stride` (every stride-th ray from ra).
void load_rays(RayScratch& s, const SectorPlan& p, int ra, int stride) {
  const int count = static_cast<int>(s.horizon.size());
  s.cross_slope.assign(count, kNoHorizon);
  s.cross_v.assign(count, -1);
  s.slope.resize(count);
  s.inv_slope.resize(count);
  s.curv_k.resize(count);
  s.code.resize(count);
  for (int i = 0; i < count; ++i) {
    const int q = ra + i * stride + p.rays.half;
    s.slope[i] = p.rays.slope[q];
    s.inv_slope[i] = p.rays.inv_slope[q];
    s.curv_k[i] = p.rays.curv_k[q];
  }
}

// Halves the spacing of the marching rays of a task: ray i becomes 2i and a
// new ray 2i + 1 starts between i and i + 1. It has not marched the terrain
// behind it, so it re-samples its own path where its two neighbours found
// their horizons (as a cell does, see sample_at) and keeps the higher sample:
// a real sample of its path, from which its own march continues. `L` is the
// line before the one about to be marched (L.k = its step).
void spawn_rays(RayScratch& s, const SectorPlan& p, int ra, int new_stride, const CellLine& L) {
  const int old_count = static_cast<int>(s.horizon.size());
  const int count = 2 * old_count - 1;
  std::vector<float>& h = s.horizon;
  std::vector<int>& arg = s.arg;
  h.resize(count);
  arg.resize(count);
  for (int i = old_count - 1; i >= 0; --i) {
    h[2 * i] = h[i];
    arg[2 * i] = arg[i];
  }
  load_rays(s, p, ra, new_stride);
  for (int i = 1; i < count; i += 2) {
    const CellRay ray{s.slope[i], s.inv_slope[i], s.curv_k[i]};
    // A void sample (NaN) is no horizon, as everywhere else.
    const float sa = sample_at(L, ray, arg[i - 1]);
    const float sb = arg[i + 1] == arg[i - 1] ? kNoHorizon : sample_at(L, ray, arg[i + 1]);
    const float a = sa > kNoHorizon ? sa : kNoHorizon, b = sb > kNoHorizon ? sb : kNoHorizon;
    h[i] = a >= b ? a : b;
    arg[i] = a >= b ? arg[i - 1] : arg[i + 1];
  }
}

// The level a task marches at on line n: level_of(), or 0 for a task whose
// width is not a multiple of that level's stride (a narrow last task).
int task_level(const SectorPlan& p, int n, int ra, int rb) {
  const int level = level_of(p, n);
  return (rb - ra) % (1 << level) == 0 ? level : 0;
}

// Prefetching. A task reads each line of the elevation for the first time
// when its rays reach it: along rows (north/south) a new row, a DEM width
// away from the last, every step; along columns (east/west) a new cache line
// of each row its rays cross every 16 steps. The hardware prefetchers do not
// foresee either, and the kernels then wait on their gathers. So a task asks
// for the part of the line kPrefetchLines ahead that its rays will read:
// along rows the whole run, along columns only the rows whose cache line
// changes there (one prefetch each, spread over the steps, rather than all
// rows every 16th step, which fills the line-fill buffers at once and was
// measured slower).
constexpr int kPrefetchLines = 4;

// The prefetch for a task's marching rays at line n, slopes slope_lo..slope_hi.
void prefetch_ahead(const Sector& s, int n, float slope_lo, float slope_hi) {
  const int ahead = n + kPrefetchLines;
  if (ahead >= s.lines) return;
  const double k = step_of(s, ahead);
  const int v0 = std::clamp(static_cast<int>(std::floor(s.eye_v + slope_lo * k)) - 1, 0, s.v_count - 1);
  const int v1 = std::clamp(static_cast<int>(std::ceil(s.eye_v + slope_hi * k)) + 1, 0, s.v_count - 1);
  const float* line = s.z + (s.line0 + s.dir * ahead) * s.z_line;
  if (s.z_v == 1) {
    for (int v = v0; v <= v1; v += 16) __builtin_prefetch(line + v);
    __builtin_prefetch(line + v1);
    return;
  }
  for (int v = v0; v <= v1; ++v) {
    const float* at = line + v * s.z_v;
    if ((reinterpret_cast<std::uintptr_t>(at) >> 6) != (reinterpret_cast<std::uintptr_t>(at - s.dir) >> 6))
      __builtin_prefetch(at);
  }
}

// What one task did, added up over the tasks.
struct SweepCounts {
  std::uint64_t steps = 0;      // ray steps
  std::uint64_t evaluated = 0;  // cells answered (non-void targets in range)
  std::uint64_t voids = 0;      // void targets in range (written as no answer)
  std::uint64_t visible = 0;    // cells coded visible (radial_mask)
};

// Marches rays [ra, rb] (inclusive, plan indices) of one sector through every
// line and writes the cells whose bracketing pair (r, r + 1) has r in [ra, rb),
// as heights, or as codes when the sector has a mask. Adds what it did to
// `counts`.
// The per-ray and per-cell loops are in ray_steps.cpp, resample_cells.cpp and
// (RadialBound::kLowerBound) resample_r3.cpp, each with AVX2 and AVX-512
// kernels.
void sweep_rays(const Sector& s, const SectorPlan& p, const SweepConstants& c, int ra, int rb, RayScratch& scratch,
                const RunControl* control, std::atomic<bool>& stop, SweepCounts& counts) {
  int level = task_level(p, 0, ra, rb);
  int stride = 1 << level;
  scratch.horizon.assign((rb - ra) / stride + 1, kNoHorizon);
  scratch.arg.assign(scratch.horizon.size(), -1);
  load_rays(scratch, p, ra, stride);
  int count = static_cast<int>(scratch.horizon.size());
  float* h = scratch.horizon.data();
  float* cross_slope = scratch.cross_slope.data();
  int* cross_v = scratch.cross_v.data();
  int* arg = scratch.arg.data();
  const float* slope = scratch.slope.data();
  const float* inv_slope = scratch.inv_slope.data();
  const float* curv_k = scratch.curv_k.data();
  const float eye = static_cast<float>(c.eye);
  const float eye_lo = static_cast<float>(c.eye - static_cast<double>(eye));
  const float eye_v = static_cast<float>(s.eye_v);
  // Rays read the terrain inside the window only (R3's sight lines never
  // leave it), so a result does not depend on how much of the file around
  // the window was read.
  const float v_min = static_cast<float>(s.win_v0), v_max = static_cast<float>(s.win_v1 - 1);
  const int j_max = std::max(0, std::min(std::max(s.win_v0, s.win_v1 - 2), s.v_count - 2));
  const double max_d2 = c.max_distance * c.max_distance;
  const int zv = static_cast<int>(s.z_v);  // offsets within a line fit in 32 bits (checked by the driver)
  // The re-sampling blend's cells need only where each ray's horizon lies, so
  // its rays cross and fold in one pass (step_rays) before the cells.
  const bool fused = c.blend == RayBlend::kResample;

  // The sampling geometry of the cells (or spawned rays) on the line at step k.
  auto cell_line = [&](float k) {
    return CellLine{&s,
                    p.inv_step.data(),
                    p.inv_dv.data(),
                    eye,
                    eye_lo,
                    eye_v,
                    v_min,
                    v_max,
                    static_cast<float>(s.k0),
                    k,
                    static_cast<float>(c.curvature),
                    static_cast<float>(s.metres_u * s.metres_u),
                    static_cast<float>(s.metres_v * s.metres_v),
                    j_max,
                    zv,
                    s.line0,
                    s.dir,
                    s.line_count,
                    s.z_line};
  };

  for (int n = 0; n < s.lines; ++n) {
    if ((n & 63) == 0 && (stop.load(std::memory_order_relaxed) || !check_control(control).ok())) {
      stop = true;
      return;
    }
    const int line = s.line0 + s.dir * n;
    const double k = step_of(s, n);
    const float* cur = s.z + line * s.z_line;
    for (const int target = task_level(p, n, ra, rb); level > target;) {
      stride = 1 << --level;
      const CellLine before = cell_line(static_cast<float>(k - 1.0));
      spawn_rays(scratch, p, ra, stride, before);
      count = static_cast<int>(scratch.horizon.size());
      h = scratch.horizon.data();
      arg = scratch.arg.data();
      cross_slope = scratch.cross_slope.data();
      cross_v = scratch.cross_v.data();
      slope = scratch.slope.data();
      inv_slope = scratch.inv_slope.data();
      curv_k = scratch.curv_k.data();
    }
    // The rays this line needs, as indices of the marching rays.
    const int lo = std::max(0, floor_div(p.ray_lo[n] - ra, stride));
    const int hi = std::min(count - 1, -floor_div(ra - p.ray_hi[n], stride));
    const float kf = static_cast<float>(k);
    const float kp = static_cast<float>(k - 1.0);  // step of the previous line (< 0 on a first line closer than 1)

    if (lo <= hi) prefetch_ahead(s, n, slope[lo], slope[hi]);

    // 1. Each active ray's crossing of a v grid line strictly inside
    //    (max(kp, 0), k), if any (|m| <= 1: at most one), and where its
    //    horizon lies with it (`code`). The re-sampling blend needs nothing
    //    else from the rays, so step 3 is done here in the same pass.
    const LineStep ls{
        eye, eye_lo, eye_v, v_min, v_max, kf, kp, std::max(kp, 0.0f), j_max, zv, s.fill, zv == 1 ? s.v_count - 1 : -1};
    if (lo <= hi) {
      const int prev_line = std::clamp(line - s.dir, 0, s.line_count - 1);
      const float* prev = s.z + prev_line * s.z_line;
      const int o = lo;
      if (fused) {
        sweep::step_rays(ls, hi - lo + 1, slope + o, inv_slope + o, curv_k + o, prev, cur, h + o, arg + o,
                         scratch.code.data() + o, n);
      } else {
        sweep::step_cross(ls, hi - lo + 1, slope + o, inv_slope + o, curv_k + o, prev, cur, h + o, arg + o,
                          cross_slope + o, cross_v + o, scratch.code.data() + o);
      }
    }

    // 2. Cells on this line. A cell's own segment crosses, in its last step, no
    //    v line; a bracketing ray's crossing in that step stands for one the
    //    segment makes a step earlier, unless it is the cell's own v line.
    if (p.cell_lo[n] <= p.cell_hi[n]) {
      const double inv_k = 1.0 / k;
      // This task's cells lie between its first and last ray; the exact owner
      // test below settles the borders.
      const int j_first = std::max(p.cell_lo[n], static_cast<int>(std::floor(s.eye_v + k * ra * p.rays.step)));
      const int j_last = std::min(p.cell_hi[n], static_cast<int>(std::ceil(s.eye_v + k * rb * p.rays.step)));
      const double du2 = (k * s.metres_u) * (k * s.metres_u);
      const CellLine cl = cell_line(kf);
      // The cells this task owns (bracketing pair r in [ra, rb)) inside max
      // distance: each condition holds on an interval of j, so trimming the
      // ends finds their intersection.
      auto answers = [&](int j) {
        const int r = sweep::lower_ray(sweep::ray_coordinate(j, s.eye_v, inv_k, p.rays.half), p.rays.half);
        const double dv = (j - s.eye_v) * s.metres_v;
        return r >= ra && r < rb && du2 + dv * dv <= max_d2;
      };
      int j_begin = j_first, j_end = j_last;
      while (j_begin <= j_end && !answers(j_begin)) ++j_begin;
      while (j_end >= j_begin && !answers(j_end)) --j_end;
      const std::ptrdiff_t out_at = (line - s.out_line0) * s.o_line - s.out_v0 * s.o_v;
      float* const out_line = s.out ? s.out + out_at : nullptr;
      if (c.blend == RayBlend::kResample && !c.precise) {
        // Where each ray's horizon lies, this step's crossing counted (step 1).
        const int* code = scratch.code.data();
        sweep::ResampleLine rl{&cl, code,  n,           ra,  level,      p.rays.half, s.eye_v,  inv_k,
                               k,   c.eye, c.curvature, du2, s.metres_v, cur,         out_line, s.o_v};
        if (s.mask) {
          rl.mask = s.mask + out_at;
          rl.target_height = c.target_height;
          rl.visible = &counts.visible;
        }
        if (j_begin <= j_end) {
          const std::uint64_t answered = sweep::resample_cells(rl, j_begin, j_end);
          counts.evaluated += answered;
          counts.voids += static_cast<std::uint64_t>(j_end - j_begin + 1) - answered;
        }
      } else if (c.precise) {
        // R3's own samples and OHF formula (the lower bound, resample_r3.hpp):
        // never above R3's value. The cells go to the kernel in batches.
        const int* code = scratch.code.data();  // where each ray's horizon lies (step 1)
        const sweep::R3CellLine r3_line{c.grid, c.frame, s.rows, line, n > 0 ? s.line0 + s.dir * (n - 1) : -1};
        const auto on = [&](int where) -> sweep::R3Line {
          if (where >= 0) return {s.line0 + s.dir * where, true};    // a u line, by step
          if (where <= -2) return {-2 - where + s.v_offset, false};  // a v line (codes carry window-based v)
          return {};
        };
        constexpr int kBatch = 64;
        int cell_j[kBatch], cell_v[kBatch];
        double total[kBatch];
        sweep::R3Line first[kBatch], second[kBatch];
        float value[kBatch];
        int batch = 0;
        const auto flush = [&] {
          sweep::resample_r3_cells(r3_line, batch, cell_v, total, first, second, value);
          for (int i = 0; i < batch; ++i) out_line[cell_j[i] * s.o_v] = value[i];
          batch = 0;
        };
        for (int j = j_begin; j <= j_end; ++j) {
          if (std::isnan(sweep::fill_void(cur[j * zv], s.fill))) {  // void target: no answer
            out_line[j * s.o_v] = std::numeric_limits<float>::quiet_NaN();
            continue;
          }
          ++counts.evaluated;
          const int r = sweep::lower_ray(sweep::ray_coordinate(j, s.eye_v, inv_k, p.rays.half), p.rays.half);
          const int i0 = (r - ra) >> level;  // the bracketing rays are i0 and i0 + 1
          const int a0 = code[i0], a1 = code[i0 + 1];
          const int jd = j + s.v_offset;  // DEM index
          cell_j[batch] = j;
          cell_v[batch] = jd;
          total[batch] = c.frame->distance(s.rows ? jd : line, s.rows ? line : jd);
          first[batch] = a0 != n - 1 ? on(a0) : sweep::R3Line{};
          second[batch] = a1 != a0 && a1 != n - 1 ? on(a1) : sweep::R3Line{};
          if (++batch == kBatch) flush();
        }
        if (batch > 0) flush();
      } else {
        for (int j = j_begin; j <= j_end; ++j) {
          const double rho = sweep::ray_coordinate(j, s.eye_v, inv_k, p.rays.half);
          const int r = sweep::lower_ray(rho, p.rays.half);
          const double dv = (j - s.eye_v) * s.metres_v;
          const double d2 = du2 + dv * dv;
          const float zc = sweep::fill_void(cur[j * zv], s.fill);
          if (std::isnan(zc)) {  // void target: no answer
            out_line[j * s.o_v] = std::numeric_limits<float>::quiet_NaN();
            continue;
          }
          ++counts.evaluated;
          const int i0 = (r - ra) >> level;  // the bracketing rays are i0 and i0 + 1
          float* out = out_line + j * s.o_v;
          // The value-only blends (kLinear, kMin) of the two rays' horizons.
          float h0 = h[i0], h1 = h[i0 + 1];
          if (cross_v[i0] != j && cross_slope[i0] > h0) h0 = cross_slope[i0];
          if (cross_v[i0 + 1] != j && cross_slope[i0 + 1] > h1) h1 = cross_slope[i0 + 1];
          const float f = std::clamp(static_cast<float>((rho - (ra + i0 * stride)) / stride), 0.0f, 1.0f);
          const double hz = c.blend == RayBlend::kMin ? std::min(h0, h1) : h0 + f * (h1 - h0);
          // OHF = eye + d * (slope per metre) + curvature d^2, and d * slope = k * sigma.
          if (!(hz > 0.5 * kNoHorizon)) {
            *out = -std::numeric_limits<float>::infinity();
          } else {
            *out = static_cast<float>(c.eye + k * hz + c.curvature * d2);
          }
        }
      }
    }

    // 3. Fold the step's crossings and line n's own one into the maxima
    //    (done in step 1 for the re-sampling blend).
    if (lo > hi) continue;
    const int o = lo;
    if (!fused)
      sweep::step_line(ls, hi - lo + 1, slope + o, curv_k + o, cur, cross_slope + o, cross_v + o, h + o, arg + o, n);
    counts.steps += static_cast<std::uint64_t>(hi - lo + 1);
  }
}

// Calls visit(row, begin, end) (window-based, end exclusive, on `threads`
// threads) for each run of a row's cells that the sweep does not write: the
// row's ends outside a disc a hair smaller than max distance (the sweep's
// own test, in its own rounding, keeps every cell inside it), the whole row
// when the disc misses it. Nothing without a max distance: the sweep writes
// every cell then but the eye's own (radial_ohf handles that one).
template <class Visit>
void for_each_unswept_run(const ViewFrame& f, unsigned threads, Visit&& visit) {
  const terrain::Window& win = f.window;
  const double reach2 = f.max_distance * f.max_distance * (1.0 - 1e-9);
  if (!std::isfinite(reach2)) return;
  const std::size_t rows = static_cast<std::size_t>(win.height()), width = static_cast<std::size_t>(win.width());
  // Bands of rows of at least 64 K cells each.
  const std::size_t band = std::max<std::size_t>(1, (std::size_t{1} << 16) / std::max<std::size_t>(1, width));
  parallel_for((rows + band - 1) / band, threads, [&](std::size_t b) {
    for (std::size_t i = b * band; i < std::min(rows, (b + 1) * band); ++i) {
      const double dy = (static_cast<double>(win.row0 + static_cast<int>(i)) - f.observer_row) * f.metres_per_row;
      const double rest = reach2 - dy * dy;
      // Columns [inside_lo, inside_hi] (window-based) lie inside the disc.
      double inside_lo = static_cast<double>(width), inside_hi = -1.0;
      if (rest >= 0) {
        const double half = std::sqrt(rest) / f.metres_per_col;
        inside_lo = std::max(0.0, std::ceil(f.observer_col - half) - win.col0);
        inside_hi = std::min(static_cast<double>(width) - 1.0, std::floor(f.observer_col + half) - win.col0);
      }
      if (inside_lo > inside_hi) {
        visit(i, std::size_t{0}, width);
        continue;
      }
      visit(i, std::size_t{0}, static_cast<std::size_t>(inside_lo));
      visit(i, static_cast<std::size_t>(inside_hi) + 1, width);
    }
  });
}

// Sizes `out` to the frame's window and sets the cells the sweep will not
// write (for_each_unswept_run) to `unswept`.
template <class T>
void prepare_output(terrain::Grid<T>& out, const ViewFrame& f, unsigned threads, T unswept) {
  size_output(out, f.window);
  const std::size_t width = static_cast<std::size_t>(f.window.width());
  for_each_unswept_run(f, threads, [&](std::size_t row, std::size_t begin, std::size_t end) {
    std::fill(out.data() + row * width + begin, out.data() + row * width + end, unswept);
  });
}

// radial_mask's cells that the sweep does not write get this first, a value
// no code has; finish_mask() then codes whichever of them the sweep left.
constexpr std::uint8_t kUnswept = 254;
static_assert(kUnswept != kVisible && kUnswept != kHidden && kUnswept != kNoAnswer);

// radial_mask's cells the sweep left (kUnswept): kNoAnswer, out of range or
// (a void target) no data. Adds them to `counts`.
void finish_mask(const terrain::HeightView& z, const ViewFrame& f, unsigned threads, terrain::Grid<std::uint8_t>& mask,
                 AnswerCounts& counts) {
  const terrain::Window& win = f.window;
  std::atomic<std::uint64_t> out_of_range{0}, nodata{0};
  for_each_unswept_run(f, threads, [&](std::size_t row, std::size_t begin, std::size_t end) {
    std::uint8_t* codes = mask.data() + row * static_cast<std::size_t>(win.width());
    std::uint64_t far = 0, gaps = 0;
    for (std::size_t c = begin; c < end; ++c) {
      if (codes[c] != kUnswept) continue;  // the sweep's own test took it in
      codes[c] = kNoAnswer;
      const bool gap = std::isnan(z.at(win.col0 + static_cast<int>(c), win.row0 + static_cast<int>(row)));
      far += !gap;
      gaps += gap;
    }
    out_of_range += far;
    nodata += gaps;
  });
  counts.out_of_range += out_of_range.load();
  counts.nodata += nodata.load();
}

// The sweep of every sector into `ohf` or `mask` (one of them null, the other
// sized to the frame's window and prepared), with the tasks' counts. With a
// `column_buffer` (and not the lower bound, whose samples are R3's own on the
// grid) the east and west sectors read their lines from a transposed copy
// in it (column_lines.hpp), numbered from the copy's first column.
Status sweep_sectors(const terrain::HeightView& z, const ViewFrame& f, const RadialOptions& options, unsigned threads,
                     const RunControl* control, const SweepConstants& c, float* ohf, std::uint8_t* mask,
                     terrain::Grid<float>* column_buffer, SweepCounts& total, std::uint64_t& rays) {
  const terrain::Window& win = f.window;
  if (z.cell_count() >= (std::size_t{1} << 31) || z.stride() * std::ptrdiff_t{z.height()} >= (std::ptrdiff_t{1} << 31))
    return make_error(ErrorCode::kResourceExhausted,
                      "dem: the radial sweep handles up to 2^31 cells; this DEM has " + std::to_string(z.cell_count()),
                      "dem");
  HORIZON_RETURN_IF_ERROR(sweep::check_ray_count(f, options.ray_spacing));
  const std::ptrdiff_t pitch = z.stride();
  std::optional<sweep::ColumnLines> columns;  // made for the first east or west sector that has lines

  // The four sectors. North/south step rows (v = column, contiguous); east/west
  // step columns (v = row, stride = pitch).
  std::vector<Sector> sectors;
  std::vector<sweep::SectorLines> geometry;  // each sector's, for its plan
  for (const sweep::SectorAxis axis : sweep::kSectorOrder) {
    const sweep::SectorLines g = sweep::sector_lines(f, axis);  // lines, k0 and eye_v (sweep_geometry.hpp)
    if (g.lines <= 0) continue;
    const bool rows = axis.rows;
    Sector s;
    s.z = z.data();
    s.fill = z.void_fill();
    s.out = ohf;
    s.mask = mask;
    s.z_line = rows ? pitch : 1;
    s.z_v = rows ? 1 : pitch;
    s.o_line = rows ? win.width() : 1;
    s.o_v = rows ? 1 : win.width();
    s.out_line0 = rows ? win.row0 : win.col0;
    s.out_v0 = rows ? win.col0 : win.row0;
    s.win_v0 = rows ? win.col0 : win.row0;
    s.win_v1 = rows ? win.col1 : win.row1;
    s.v_count = rows ? z.width() : z.height();
    s.line_count = rows ? z.height() : z.width();
    s.metres_u = g.metres_u;
    s.metres_v = g.metres_v;
    s.include_diagonal = g.include_diagonal;
    s.rows = rows;
    s.dir = axis.dir;
    s.line0 = g.line0;
    s.lines = g.lines;
    s.k0 = g.k0;
    // Re-base v on the window (see Sector::v_offset).
    s.v_offset = g.v0;
    s.eye_v = g.eye_v;
    s.z += s.v_offset * s.z_v;
    s.win_v1 -= s.v_offset;
    s.win_v0 = 0;
    s.out_v0 -= s.v_offset;
    s.v_count -= s.v_offset;
    if (!rows && column_buffer != nullptr && !c.precise) {
      if (!columns) {
        const sweep::ColumnWedge wedge{f.observer_col, f.observer_row};
        columns = sweep::transpose_columns(z, sweep::column_lines_extent(z, f), threads, *column_buffer, &wedge);
      }
      // Line i of the copy is DEM column columns->extent.col0 + i; the
      // outputs' line numbers move with it. v is still counted from v_offset.
      const terrain::Window& e = columns->extent;
      s.z = columns->lines + (s.v_offset - e.row0);
      s.z_line = columns->pitch;
      s.z_v = 1;
      s.v_count = e.row1 - s.v_offset;
      s.line_count = e.width();
      s.line0 -= e.col0;
      s.out_line0 -= e.col0;
    }
    sectors.push_back(s);
    geometry.push_back(g);
  }

  std::vector<SectorPlan> plans;
  struct Task {
    int sector, ra, rb;
  };
  std::vector<Task> tasks;
  for (std::size_t si = 0; si < sectors.size(); ++si) {
    // A sector's tables take time in proportion to its rays (plan.hpp bounds
    // them): a cancel or a deadline is heard between sectors, too.
    HORIZON_RETURN_IF_ERROR(check_control(control));
    plans.push_back(plan_sector(sectors[si], geometry[si], c, options.ray_spacing, options.thinning_levels));
    const int half = plans.back().rays.half;
    for (int ra = -half; ra < half; ra += kRaysPerTask)
      tasks.push_back({static_cast<int>(si), ra, std::min(ra + kRaysPerTask, half)});
  }

  std::atomic<bool> stop{false};
  std::atomic<std::uint64_t> steps{0}, evaluated{0}, voids{0}, visible{0};
  std::atomic<std::size_t> done{0};
  parallel_for(tasks.size(), threads, [&](std::size_t t) {
    if (stop.load(std::memory_order_relaxed)) return;
    thread_local RayScratch scratch;
    const Task& task = tasks[t];
    SweepCounts counts;
    sweep_rays(sectors[task.sector], plans[task.sector], c, task.ra, task.rb, scratch, control, stop, counts);
    steps += counts.steps;
    evaluated += counts.evaluated;
    voids += counts.voids;
    visible += counts.visible;
    report_progress(control, double(++done) / double(tasks.size()));
  });
  HORIZON_RETURN_IF_ERROR(check_control(control));
  total = {steps.load(), evaluated.load(), voids.load(), visible.load()};
  rays = 0;
  for (const SectorPlan& p : plans) rays += static_cast<std::uint64_t>(2 * p.rays.half + 1);
  return Status::Ok();
}

// The eye's own cell when the eye sits exactly on its centre (no sector owns
// it): its window-based position, or nothing.
std::optional<std::pair<int, int>> eye_cell(const ViewFrame& f) {
  const double oc = f.observer_col, orow = f.observer_row;
  if (oc != std::floor(oc) || orow != std::floor(orow) || !f.window.contains(int(oc), int(orow))) return std::nullopt;
  return std::pair{int(oc) - f.window.col0, int(orow) - f.window.row0};
}

void set_stats(const SweepCounts& counts, std::uint64_t rays, WorkStats& stats) {
  stats.cells_evaluated = counts.evaluated;
  stats.rays = rays;
  stats.terrain_samples = 2 * counts.steps;
}

}  // namespace

Status radial_ohf(const terrain::HeightView& z, const ViewFrame& f, const RadialOptions& options, unsigned threads,
                  const RunControl* control, terrain::Grid<float>& ohf, WorkStats& stats, RadialBound bound,
                  terrain::Grid<float>* column_buffer) {
  // NaN where the sweep will not write, so that a 12 M-cell OHF is not written twice.
  prepare_output(ohf, f, threads, std::numeric_limits<float>::quiet_NaN());
  const bool lower_bound = bound == RadialBound::kLowerBound;
  SweepConstants c{f.eye, f.curvature, f.max_distance, lower_bound ? RayBlend::kResample : options.blend, lower_bound};
  c.grid = &z;
  c.frame = &f;
  SweepCounts counts;
  std::uint64_t rays = 0;
  HORIZON_RETURN_IF_ERROR(
      sweep_sectors(z, f, options, threads, control, c, ohf.data(), nullptr, column_buffer, counts, rays));
  if (const auto eye = eye_cell(f)) {
    const bool void_target = std::isnan(z.at(eye->first + f.window.col0, eye->second + f.window.row0));
    ohf.at(eye->first, eye->second) =
        void_target ? std::numeric_limits<float>::quiet_NaN() : -std::numeric_limits<float>::infinity();
    counts.evaluated += !void_target;
  }
  set_stats(counts, rays, stats);
  return Status::Ok();
}

Status radial_mask(const terrain::HeightView& z, const ViewFrame& f, const RadialOptions& options, double target_height,
                   unsigned threads, const RunControl* control, terrain::Grid<std::uint8_t>& mask,
                   AnswerCounts& answers, WorkStats& stats, terrain::Grid<float>* column_buffer) {
  if (options.blend != RayBlend::kResample)
    return make_error(ErrorCode::kInvalidArgument,
                      "ray_blend: the visibility mask is made in the sweep by the re-sampling blend only; the other "
                      "blends make occlusion heights (radial_ohf)",
                      "ray_blend");
  prepare_output(mask, f, threads, kUnswept);
  SweepConstants c{f.eye, f.curvature, f.max_distance, RayBlend::kResample, false};
  c.target_height = static_cast<float>(target_height);
  c.grid = &z;
  c.frame = &f;
  SweepCounts counts;
  std::uint64_t rays = 0;
  HORIZON_RETURN_IF_ERROR(
      sweep_sectors(z, f, options, threads, control, c, nullptr, mask.data(), column_buffer, counts, rays));
  answers = {};
  answers.visible = counts.visible;
  answers.hidden = counts.evaluated - counts.visible;
  answers.nodata = counts.voids;
  // The eye's own cell, as radial_ohf answers it (-infinity: nothing can block it).
  if (const auto eye = eye_cell(f)) {
    const float ground = z.at(eye->first + f.window.col0, eye->second + f.window.row0);
    std::uint8_t& code = mask.at(eye->first, eye->second);
    if (std::isnan(ground)) {
      code = kNoAnswer;
      ++answers.nodata;
    } else {
      const bool seen =
          static_cast<float>(target_height) >= min_target_height_at(-std::numeric_limits<float>::infinity(), ground);
      code = seen ? kVisible : kHidden;
      ++(seen ? answers.visible : answers.hidden);
      ++counts.evaluated;
    }
  }
  finish_mask(z, f, threads, mask, answers);
  set_stats(counts, rays, stats);
  return Status::Ok();
}

}  // namespace horizon::visibility
