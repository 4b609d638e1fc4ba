// Radial sweep occlusion height field.
//
// After US patent 7,027,046 (Benton et al., "Occlusion height field"):
// perspective modulation divides heights relative to the eye by distance, which
// turns "is this point above every sight line from the eye?" into a running
// maximum of slopes along radial lines; multiplying the maximum back by the
// distance gives the occlusion height field. Here the radial lines are exact
// rays marched grid line by grid line, sampling the terrain exactly where R3
// does (see r3.hpp), so the only approximation is the angular blend between
// the two rays that bracket a cell centre.
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
// state that segment would have, up to the angular blend.
//
// Horizons are kept per unit step rather than per metre: a ray sample at step
// k contributes sigma = (z - eye - curvature d^2) / k. Along one ray that is the
// slope times a constant, so the running maximum is the same; across rays it
// is linear in the ray slope on any planar terrain, so blending sigma between
// two rays is exact on planes (per-metre slopes carry the convex 1/|ray|).
//
// The kernel is a plain loop over rays (structure of arrays, no allocation,
// invariants hoisted per line and per ray); GCC vectorises the ray update.
#include "horizon/visibility/radial_sweep.hpp"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstddef>
#include <limits>
#include <string>
#include <vector>

#include "horizon/common/parallel.hpp"

namespace horizon::visibility {
namespace {

// "No horizon yet": a finite value below any real one, so that blending two
// rays never produces NaN from -inf arithmetic.
constexpr float kNoHorizon = -1.0e30f;
constexpr int kRaysPerTask = 192;

// One sector, in (u, v) terms, addressing the elevation and output grids.
struct Sector {
  // Elevation: value at (line i, v index j) = z[i * z_line + j * z_v].
  const float* z = nullptr;
  std::ptrdiff_t z_line = 0, z_v = 0;
  int v_count = 0;            // positions along v in the DEM
  // Output (window-relative): ohf[(i - out_line0) * o_line + (j - out_v0) * o_v].
  float* out = nullptr;
  std::ptrdiff_t o_line = 0, o_v = 0;
  int out_line0 = 0, out_v0 = 0;
  int win_v0 = 0, win_v1 = 0;  // window range along v, half-open
  // Lines: first line index, direction (+1 / -1), count; step of line n is k0 + n.
  int line0 = 0, dir = 1, lines = 0, line_count = 0;  // line_count = lines in the whole DEM along u
  double k0 = 1.0;
  double eye_v = 0.0;
  double metres_u = 1.0, metres_v = 1.0;
  bool include_diagonal = true;  // north/south own |dv| == k, east/west do not
};

struct SweepConstants {
  float eye = 0.0f;
  double curvature = 0.0;
  double max_distance = 0.0;
  RayBlend blend = RayBlend::kLinear;
};

// Per-sector ray set and the nested per-line ranges of rays and cells.
struct SectorPlan {
  int ray_half = 0;                 // rays r in [-ray_half, ray_half]
  double ray_step = 0.0;            // slope spacing between neighbouring rays
  std::vector<float> slope;         // m_r, index r + ray_half
  std::vector<float> inv_slope;     // 1 / m_r, 0 for m_r == 0
  std::vector<float> curv_k;        // curvature * (ground metres per unit step along ray r)^2
  std::vector<int> cell_lo, cell_hi;  // per line: target cells j in [lo, hi], empty if lo > hi
  std::vector<int> ray_lo, ray_hi;    // per line: rays to update (nested: shrinking outward)
};

inline double step_of(const Sector& s, int n) { return s.k0 + n; }

SectorPlan plan_sector(const Sector& s, const SweepConstants& c, double ray_spacing) {
  SectorPlan p;
  const double k_far = step_of(s, s.lines - 1);
  p.ray_half = std::max(1, static_cast<int>(std::ceil(k_far / ray_spacing)));
  p.ray_step = 1.0 / p.ray_half;
  const int rays = 2 * p.ray_half + 1;
  p.slope.resize(rays);
  p.inv_slope.resize(rays);
  p.curv_k.resize(rays);
  for (int r = -p.ray_half; r <= p.ray_half; ++r) {
    const double m = std::clamp(r * p.ray_step, -1.0, 1.0);
    p.slope[r + p.ray_half] = static_cast<float>(m);
    p.inv_slope[r + p.ray_half] = m == 0 ? 0.0f : static_cast<float>(1.0 / m);
    const double metres_per_k = std::hypot(s.metres_u, m * s.metres_v);
    p.curv_k[r + p.ray_half] = static_cast<float>(c.curvature * metres_per_k * metres_per_k);
  }

  p.cell_lo.assign(s.lines, 0);
  p.cell_hi.assign(s.lines, -1);
  p.ray_lo.assign(s.lines, 0);
  p.ray_hi.assign(s.lines, -1);
  for (int n = 0; n < s.lines; ++n) {
    const double k = step_of(s, n);
    // Sector wedge: |j - v_eye| <= k (or < k), inside the window along v.
    double lo = s.eye_v - k, hi = s.eye_v + k;
    int jlo = static_cast<int>(std::ceil(lo)), jhi = static_cast<int>(std::floor(hi));
    if (!s.include_diagonal) {
      if (jlo == lo) ++jlo;
      if (jhi == hi) --jhi;
    }
    jlo = std::max(jlo, s.win_v0);
    jhi = std::min(jhi, s.win_v1 - 1);
    // Max-distance disc (exact test per cell happens in the kernel; this only bounds the loop).
    if (std::isfinite(c.max_distance)) {
      const double du = k * s.metres_u;
      const double rest = c.max_distance * c.max_distance - du * du;
      if (rest < 0) {
        jhi = jlo - 1;
      } else {
        const double reach = std::sqrt(rest) / s.metres_v;
        jlo = std::max(jlo, static_cast<int>(std::floor(s.eye_v - reach)));
        jhi = std::min(jhi, static_cast<int>(std::ceil(s.eye_v + reach)));
      }
    }
    p.cell_lo[n] = jlo;
    p.cell_hi[n] = jhi;
    if (jlo <= jhi) {
      // Rays bracketing the first and last cell: a cell at ray coordinate rho
      // blends rays floor(rho) and floor(rho) + 1 (even when rho is a whole
      // number); one ray of slack each side absorbs rounding differences.
      const double rl = std::floor((jlo - s.eye_v) / k / p.ray_step) - 1;
      const double rh = std::floor((jhi - s.eye_v) / k / p.ray_step) + 2;
      p.ray_lo[n] = std::clamp(static_cast<int>(rl), -p.ray_half, p.ray_half);
      p.ray_hi[n] = std::clamp(static_cast<int>(rh), -p.ray_half, p.ray_half);
    } else {
      p.ray_lo[n] = p.ray_half + 1;
      p.ray_hi[n] = -p.ray_half - 1;
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

// The two per-line ray loops, as free functions over restrict-qualified
// arrays so the compiler can prove they do not alias and vectorise them
// (gathers for the terrain reads, maxps for the running maximum).
struct LineStep {
  float eye, eye_v, v_max, kf, kp, k_start;
  int j_max, zv;
};

// Crossing of a v grid line strictly inside (k_start, k) for rays [0, count).
inline void step_cross(const LineStep& ls, int count, const float* __restrict slope,
                       const float* __restrict inv_slope, const float* __restrict curv_k,
                       const float* __restrict prev, const float* __restrict cur, float* __restrict cross_slope,
                       int* __restrict cross_v) {
  for (int i = 0; i < count; ++i) {
    const float m = slope[i];
    const float v_start = ls.eye_v + m * ls.k_start, v_end = ls.eye_v + m * ls.kf;
    const float up = std::floor(v_start) + 1.0f, down = std::ceil(v_start) - 1.0f;
    const float cv = m > 0.0f ? up : down;
    // Integer masks rather than && / ||, which would become branches.
    const int crosses = (int(m > 0.0f) & int(up < v_end)) | (int(m < 0.0f) & int(down > v_end));
    const int valid = crosses & int(cv >= 0.0f) & int(cv <= ls.v_max);
    const float cv_safe = valid ? cv : 0.0f;
    const int jc = static_cast<int>(cv_safe);
    const float kc_any = (cv_safe - ls.eye_v) * inv_slope[i];  // computed for every ray, then selected
    const float kc = valid ? kc_any : 1.0f;
    const float tc = kc - ls.kp;
    const float pa = prev[jc * ls.zv], pb = cur[jc * ls.zv];
    const float z_cross = pa + tc * (pb - pa);
    const float s_cross = (z_cross - ls.eye) / kc - curv_k[i] * kc;
    cross_slope[i] = valid ? s_cross : kNoHorizon;
    cross_v[i] = valid ? jc : -1;
  }
}

// Folds the step's v-line crossing and the line's own crossing into the
// running maxima. NaN slopes (voids) never win: `x > best ? x : best` keeps
// best when x is NaN (and compiles to maxps).
inline void step_line(const LineStep& ls, int count, const float* __restrict slope, const float* __restrict curv_k,
                      const float* __restrict cur, const float* __restrict cross_slope, float* __restrict h) {
  const float inv_kf = 1.0f / ls.kf;
  for (int i = 0; i < count; ++i) {
    const float v = std::min(std::max(ls.eye_v + slope[i] * ls.kf, 0.0f), ls.v_max);
    const int j0 = std::min(static_cast<int>(v), ls.j_max);
    const float t = v - static_cast<float>(j0);
    const float a = cur[j0 * ls.zv], b = cur[(j0 + 1) * ls.zv];
    const float s_line = (a + t * (b - a) - ls.eye) * inv_kf - curv_k[i] * ls.kf;
    float best = h[i];
    best = cross_slope[i] > best ? cross_slope[i] : best;
    best = s_line > best ? s_line : best;
    h[i] = best;
  }
}

// Per-task scratch: one entry per ray of the task.
struct RayScratch {
  std::vector<float> horizon;     // running max slope up to the last line marched
  std::vector<float> cross_slope; // slope at the v-line crossing inside the current step, kNoHorizon if none
  std::vector<int> cross_v;       // the v-line crossed in the current step, -1 if none
};

// Marches rays [ra, rb] (inclusive, plan indices) of one sector through every
// line and writes the cells whose bracketing pair (r, r + 1) has r in [ra, rb).
// Adds the ray steps taken and the cells answered to `steps` / `evaluated`.
// Compiled twice (AVX2 and baseline x86-64); the loader picks one at start-up.
#if defined(__x86_64__) && !defined(__SANITIZE_ADDRESS__)
__attribute__((target_clones("avx2", "default")))
#endif
void sweep_rays(const Sector& s, const SectorPlan& p, const SweepConstants& c, int ra, int rb, RayScratch& scratch,
                const RunControl* control, std::atomic<bool>& stop, std::uint64_t& steps, std::uint64_t& evaluated) {
  const int count = rb - ra + 1;
  scratch.horizon.assign(count, kNoHorizon);
  scratch.cross_slope.assign(count, kNoHorizon);
  scratch.cross_v.assign(count, -1);
  const int base = ra + p.ray_half;  // plan index of ray ra
  const float* slope = p.slope.data() + base;
  const float* inv_slope = p.inv_slope.data() + base;
  const float* curv_k = p.curv_k.data() + base;
  float* h = scratch.horizon.data();
  float* cross_slope = scratch.cross_slope.data();
  int* cross_v = scratch.cross_v.data();
  const float eye = c.eye;
  const float eye_v = static_cast<float>(s.eye_v);
  const float v_max = static_cast<float>(s.v_count - 1);
  const int j_max = s.v_count - 2;
  const double max_d2 = c.max_distance * c.max_distance;
  const int zv = static_cast<int>(s.z_v);  // offsets within a line fit in 32 bits (checked by the driver)

  for (int n = 0; n < s.lines; ++n) {
    if ((n & 63) == 0 && (stop.load(std::memory_order_relaxed) || !check_control(control).ok())) {
      stop = true;
      return;
    }
    const int line = s.line0 + s.dir * n;
    const double k = step_of(s, n);
    const float* cur = s.z + line * s.z_line;
    const int lo = std::max(p.ray_lo[n], ra), hi = std::min(p.ray_hi[n], rb);
    const float kf = static_cast<float>(k);
    const float kp = static_cast<float>(k - 1.0);  // step of the previous line (< 0 on a first line closer than 1)

    // 1. Each active ray's crossing of a v grid line strictly inside
    //    (max(kp, 0), k), if any (|m| <= 1: at most one).
    const LineStep ls{eye, eye_v, v_max, kf, kp, std::max(kp, 0.0f), j_max, zv};
    if (lo <= hi) {
      const int prev_line = std::clamp(line - s.dir, 0, s.line_count - 1);
      const int o = lo - ra;
      step_cross(ls, hi - lo + 1, slope + o, inv_slope + o, curv_k + o, s.z + prev_line * s.z_line, cur,
                 cross_slope + o, cross_v + o);
    }

    // 2. Cells on this line. A cell's own segment crosses, in its last step, no
    //    v line; a bracketing ray's crossing in that step stands for one the
    //    segment makes a step earlier, unless it is the cell's own v line.
    if (p.cell_lo[n] <= p.cell_hi[n]) {
      const double inv_k = 1.0 / k;
      // This task's cells lie between its first and last ray; the exact owner
      // test below settles the borders.
      const int j_first = std::max(p.cell_lo[n], static_cast<int>(std::floor(s.eye_v + k * ra * p.ray_step)));
      const int j_last = std::min(p.cell_hi[n], static_cast<int>(std::ceil(s.eye_v + k * rb * p.ray_step)));
      const double du2 = (k * s.metres_u) * (k * s.metres_u);
      for (int j = j_first; j <= j_last; ++j) {
        // Rays are evenly spaced: ray r has slope r / ray_half, so the cell's
        // own slope m sits at ray coordinate rho = m * ray_half.
        const double rho = (j - s.eye_v) * inv_k * p.ray_half;
        const int r = std::clamp(static_cast<int>(std::floor(rho)), -p.ray_half, p.ray_half - 1);
        if (r < ra || r >= rb) continue;  // another task's cell
        const double dv = (j - s.eye_v) * s.metres_v;
        const double d2 = du2 + dv * dv;
        if (d2 > max_d2) continue;
        const float zc = cur[j * zv];
        if (std::isnan(zc)) continue;  // void target: no answer (stays NaN)
        ++evaluated;
        const int i0 = r - ra;
        const float f = std::clamp(static_cast<float>(rho - r), 0.0f, 1.0f);
        float h0 = h[i0], h1 = h[i0 + 1];
        if (cross_v[i0] != j && cross_slope[i0] > h0) h0 = cross_slope[i0];
        if (cross_v[i0 + 1] != j && cross_slope[i0 + 1] > h1) h1 = cross_slope[i0 + 1];
        const float hz = c.blend == RayBlend::kMin ? std::min(h0, h1) : h0 + f * (h1 - h0);
        float* out = s.out + (line - s.out_line0) * s.o_line + (j - s.out_v0) * s.o_v;
        // OHF = eye + d * (slope per metre) + curvature d^2, and d * slope = k * sigma.
        if (hz <= 0.5f * kNoHorizon)
          *out = -std::numeric_limits<float>::infinity();
        else
          *out = static_cast<float>(c.eye + k * hz + c.curvature * d2);
      }
    }

    // 3. Fold the step's crossings and line n's own one into the maxima.
    if (lo > hi) continue;
    const int o = lo - ra;
    step_line(ls, hi - lo + 1, slope + o, curv_k + o, cur, cross_slope + o, h + o);
    steps += static_cast<std::uint64_t>(hi - lo + 1);
  }
}

}  // namespace

Status radial_ohf(const terrain::Grid<float>& z, const ViewFrame& f, const RadialOptions& options,
                  unsigned threads, const RunControl* control, terrain::Grid<float>& ohf, WorkStats& stats) {
  const terrain::Window& win = f.window;
  if (z.size() >= (std::size_t{1} << 31))
    return make_error(ErrorCode::kResourceExhausted,
                      "dem: the radial sweep handles up to 2^31 cells; this DEM has " + std::to_string(z.size()),
                      "dem");
  reset_output(ohf, win);
  const SweepConstants c{static_cast<float>(f.eye), f.curvature, f.max_distance,
                         options.blend};
  const std::ptrdiff_t pitch = z.width();

  // The four sectors. North/south step rows (v = column, contiguous); east/west
  // step columns (v = row, stride = pitch).
  std::vector<Sector> sectors;
  auto add = [&](bool rows, int dir) {
    Sector s;
    s.z = z.data();
    s.out = ohf.data();
    const double eye_u = rows ? f.observer_row : f.observer_col;
    s.eye_v = rows ? f.observer_col : f.observer_row;
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
    s.metres_u = rows ? f.metres_per_row : f.metres_per_col;
    s.metres_v = rows ? f.metres_per_col : f.metres_per_row;
    s.include_diagonal = rows;
    s.dir = dir;
    const int u0 = rows ? win.row0 : win.col0, u1 = rows ? win.row1 : win.col1;  // window along u
    if (dir > 0) {
      s.line0 = std::max(static_cast<int>(std::floor(eye_u)) + 1, u0);
      s.lines = u1 - s.line0;
      s.k0 = s.line0 - eye_u;
    } else {
      s.line0 = std::min(static_cast<int>(std::ceil(eye_u)) - 1, u1 - 1);
      s.lines = s.line0 - u0 + 1;
      s.k0 = eye_u - s.line0;
    }
    if (s.lines > 0) sectors.push_back(s);
  };
  add(true, -1);   // north
  add(true, +1);   // south
  add(false, +1);  // east
  add(false, -1);  // west

  std::vector<SectorPlan> plans;
  struct Task {
    int sector, ra, rb;
  };
  std::vector<Task> tasks;
  for (std::size_t si = 0; si < sectors.size(); ++si) {
    plans.push_back(plan_sector(sectors[si], c, options.ray_spacing));
    const int half = plans.back().ray_half;
    for (int ra = -half; ra < half; ra += kRaysPerTask)
      tasks.push_back({static_cast<int>(si), ra, std::min(ra + kRaysPerTask, half)});
  }

  std::atomic<bool> stop{false};
  std::atomic<std::uint64_t> steps{0}, evaluated{0};
  std::atomic<std::size_t> done{0};
  parallel_for(tasks.size(), threads, [&](std::size_t t) {
    if (stop.load(std::memory_order_relaxed)) return;
    thread_local RayScratch scratch;
    const Task& task = tasks[t];
    std::uint64_t task_steps = 0, task_evaluated = 0;
    sweep_rays(sectors[task.sector], plans[task.sector], c, task.ra, task.rb, scratch, control, stop, task_steps,
               task_evaluated);
    steps += task_steps;
    evaluated += task_evaluated;
    report_progress(control, double(++done) / double(tasks.size()));
  });
  HORIZON_RETURN_IF_ERROR(check_control(control));

  // The observer's own cell when the eye sits exactly on its centre: no sector owns it.
  const double oc = f.observer_col, orow = f.observer_row;
  if (oc == std::floor(oc) && orow == std::floor(orow) && win.contains(int(oc), int(orow)) &&
      !std::isnan(z.at(int(oc), int(orow)))) {
    ohf.at(int(oc) - win.col0, int(orow) - win.row0) = -std::numeric_limits<float>::infinity();
    ++evaluated;
  }
  stats.cells_evaluated = evaluated;
  stats.rays = 0;
  for (const SectorPlan& p : plans) stats.rays += static_cast<std::uint64_t>(2 * p.ray_half + 1);
  stats.terrain_samples = 2 * steps.load();
  return Status::Ok();
}

}  // namespace horizon::visibility
