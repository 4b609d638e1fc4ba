// stress.cpp — the numerical-stability checks of stress.hpp.
//
// Every check is a function that runs cases through a Checker, which counts
// cases and failures and keeps the worst deviation and the first failure
// described precisely enough to reproduce (DEM, observer, options, cell).
// Synthetic DEMs are built here with fixed seeds; real DEMs are read through
// window reads around each observer.
#include "horizon/evaluation/stress.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <functional>
#include <limits>
#include <numbers>
#include <random>
#include <sstream>

#include "horizon/geodesy/observer.hpp"
#include "horizon/terrain/dem_reader.hpp"
#include "horizon/visibility/agreement.hpp"
#include "horizon/visibility/r3.hpp"
#include "horizon/visibility/viewshed.hpp"

namespace horizon::evaluation {
namespace {

using terrain::Dem;
using terrain::Grid;
using visibility::Algorithm;
using visibility::ViewshedOptions;
using visibility::ViewshedResult;

constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();

std::string fmt(const char* f, double a) {
  char buf[128];
  std::snprintf(buf, sizeof buf, f, a);
  return buf;
}
std::string fmt2(const char* f, double a, double b) {
  char buf[160];
  std::snprintf(buf, sizeof buf, f, a, b);
  return buf;
}

struct Checker {
  CheckResult r;
  void ohf(double metres) {
    if (std::isfinite(metres)) r.worst_ohf = std::max(r.worst_ohf, metres);
  }
  // One case: `deviation` in the check's unit; failed when `bad`.
  void record(bool bad, double deviation, const std::string& what) {
    ++r.cases;
    if (std::isfinite(deviation)) r.worst = std::max(r.worst, deviation);
    if (bad) {
      ++r.failed;
      if (r.first_failure.empty()) r.first_failure = what;
    }
  }
  // Cells that broke the property as the algorithm's own error explains (stress.hpp).
  void explain(std::uint64_t cells, const std::string& what) {
    if (cells == 0) return;
    r.explained += cells;
    if (r.first_explained.empty()) r.first_explained = what;
  }
};

struct Context {
  const StressConfig& config;
  Algorithm algorithm;
  const RunControl* control;
  gpu::ContextPool* gpu = nullptr;  // set for the fast-gpu pass: fast runs there (backend gpu)
};

// --- Synthetic terrain -------------------------------------------------------

// A fixed-seed rough surface: Gaussian hills and pits over value noise,
// heights in about [0, relief] metres. Plain metres (no CRS) unless set.
Dem rough_dem(int width, int height, std::uint32_t seed, double relief, double cell) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> ux(0, width), uy(0, height), amp(-0.5, 1.0), rad(2.0, 0.25 * width),
      noise(0.0, 1.0);
  struct Hill {
    double x, y, a, r;
  };
  std::vector<Hill> hills(24);
  for (Hill& h : hills) h = {ux(rng), uy(rng), amp(rng), rad(rng)};
  Dem dem;
  dem.elevation = Grid<float>(width, height);
  for (int r = 0; r < height; ++r)
    for (int c = 0; c < width; ++c) {
      double z = 0.5;
      for (const Hill& h : hills) z += h.a * std::exp(-((c - h.x) * (c - h.x) + (r - h.y) * (r - h.y)) / (h.r * h.r));
      z += 0.05 * noise(rng);
      // Multiples of 1/64 m: exact in float32 up to 262 km, so adding a
      // constant height or scaling by a power of two changes no input bit.
      dem.elevation.at(c, r) = static_cast<float>(std::round(std::max(0.0, z) * relief * 0.5 * 64.0) / 64.0);
    }
  dem.georef.transform = {500000.0, cell, 5000000.0, -cell};
  dem.georef.epsg = 0;
  dem.source = "synthetic rough " + std::to_string(width) + "x" + std::to_string(height) + " seed " +
               std::to_string(seed) + " cell " + fmt("%g", cell) + " m";
  dem.format = "synthetic";
  return dem;
}

Dem flat_dem(int width, int height, double z, double cell) {
  Dem dem;
  dem.elevation = Grid<float>(width, height, static_cast<float>(z));
  dem.georef.transform = {500000.0, cell, 5000000.0, -cell};
  dem.source = "synthetic flat " + std::to_string(width) + "x" + std::to_string(height) + " at " + fmt("%g", z) + " m";
  dem.format = "synthetic";
  return dem;
}

ViewshedOptions base_options(const Context& ctx) {
  ViewshedOptions o;
  o.algorithm = ctx.algorithm;
  o.threads = ctx.config.threads;
  o.backend = ctx.gpu ? visibility::Backend::kGpu : visibility::Backend::kCpu;
  return o;
}

geodesy::PointSpec at_cell(const Dem& dem, double col, double row, double height,
                           geodesy::HeightMode mode = geodesy::HeightMode::kAboveGround) {
  geodesy::PointSpec s;
  s.x = dem.georef.transform.x_at(col);
  s.y = dem.georef.transform.y_at(row);
  s.height = height;
  s.height_mode = mode;
  return s;
}

// The check's viewshed, on the GPU pool when the pass is fast-gpu.
Result<ViewshedResult> viewshed(const Context& ctx, const Dem& dem, const geodesy::PointSpec& spec,
                                const ViewshedOptions& options) {
  auto eye = geodesy::resolve_point(dem, spec, "observer");
  if (!eye.ok()) return eye.error();
  return visibility::compute_viewshed(dem, *eye, options, nullptr, ctx.gpu);
}

std::string where(const Dem& dem, const geodesy::PointSpec& s, const ViewshedOptions& o) {
  std::ostringstream w;
  w << dem.source << ", observer x " << fmt("%.6f", s.x) << " y " << fmt("%.6f", s.y) << " height "
    << fmt("%g", s.height) << (s.height_mode == geodesy::HeightMode::kAbsolute ? " (absolute)" : "") << ", curvature "
    << fmt("%g", o.curvature_coefficient)
    << (std::isfinite(o.max_distance) ? ", max distance " + fmt("%g", o.max_distance) : std::string());
  return w.str();
}

// Cells whose visibility differs between two results, and the first such
// cell. A cell is excused when `a`'s margin (OHF - terrain) lies within
// `tolerance` (plus float32 rounding of the OHF) of the engine's 1 mm tie
// threshold (viewshed.hpp): accepting OHF differences of `tolerance` means
// accepting that such a near-tie may fall either way.
struct MaskDiff {
  std::uint64_t cells = 0;
  int col = -1, row = -1;
  std::uint8_t a = 0, b = 0;
};
MaskDiff diff_masks(const ViewshedResult& ra, const ViewshedResult& rb, double tolerance) {
  const auto a = visibility::visibility_mask(ra, ra.target_height);
  const auto b = visibility::visibility_mask(rb, rb.target_height);
  MaskDiff d;
  if (a.width() != b.width() || a.height() != b.height()) {
    d.cells = std::max(a.size(), b.size());
    return d;
  }
  for (int r = 0; r < a.height(); ++r)
    for (int c = 0; c < a.width(); ++c) {
      if (a.at(c, r) == b.at(c, r)) continue;
      const double ohf = ra.ohf.at(c, r), z = ra.terrain.at(c, r);
      const double slack = tolerance + 4.0 * std::abs(ohf) * 1.1920929e-7;
      const double threshold = std::max(double(visibility::kTieTolerance), ra.target_height);
      if (a.at(c, r) != visibility::kNoAnswer && b.at(c, r) != visibility::kNoAnswer && std::isfinite(ohf) &&
          std::abs((ohf - z) - threshold) <= slack)
        continue;
      if (d.cells++ == 0) d.col = c, d.row = r, d.a = a.at(c, r), d.b = b.at(c, r);
    }
  return d;
}

// Largest |(a - b) - offset| over cells answered in both OHF rasters, less
// two float32 units in the last place of the larger value (the OHF is stored
// as float32: 0.5 mm near 4 km, 0.06 m for the million-metre OHFs that
// curvature gives a thousand kilometres out).
double ohf_gap(const ViewshedResult& a, const ViewshedResult& b, double offset) {
  const Grid<float> oa = visibility::ohf_raster(a), ob = visibility::ohf_raster(b);
  if (oa.width() != ob.width() || oa.height() != ob.height()) return std::numeric_limits<double>::infinity();
  double worst = 0;
  for (std::size_t i = 0; i < oa.size(); ++i) {
    const float x = oa.data()[i], y = ob.data()[i];
    if (std::isnan(x) != std::isnan(y)) return std::numeric_limits<double>::infinity();
    if (std::isnan(x)) continue;
    const double ulps = 2.0 * std::max(std::abs(double(x)), std::abs(double(y))) * 1.1920929e-7;
    worst = std::max(worst, std::abs(double(x) - double(y) - offset) - ulps);
  }
  return worst;
}

std::string cell_text(const ViewshedResult& r, int c, int row) {
  return "cell (col " + std::to_string(c + r.frame.window.col0) + ", row " + std::to_string(row + r.frame.window.row0) +
         ")";
}

// Compares two results that must be the same viewshed: masks equal, OHF equal
// up to `offset` within `tolerance` metres. Deviation: differing cells.
void expect_same(Checker& ck, const Result<ViewshedResult>& a, const Result<ViewshedResult>& b, double offset,
                 double tolerance, const std::string& what) {
  if (!a.ok() || !b.ok()) {
    ck.record(true, std::numeric_limits<double>::infinity(),
              what + ": failed to compute: " + (!a.ok() ? a.error().message : b.error().message));
    return;
  }
  const MaskDiff d = diff_masks(*a, *b, tolerance);
  const double gap = ohf_gap(*a, *b, offset);
  ck.ohf(gap);
  std::string detail;
  if (d.cells)
    detail = what + ": " + std::to_string(d.cells) + " cells differ, first " + cell_text(*a, d.col, d.row) + " " +
             std::to_string(d.a) + " vs " + std::to_string(d.b);
  else if (gap > tolerance)
    detail = what + ": OHF differs by " + fmt("%.6g", gap) + " m (tolerance " + fmt("%g", tolerance) + ")";
  ck.record(d.cells > 0 || gap > tolerance, double(d.cells), detail);
}

// One case: the viewshed from `s`, and the answered cells for which
// `bad(col, row, mask)` holds (DEM coordinates). Records a failure to compute,
// or "<where><label>: N <what>, first cell (...)" when any cell is bad.
void expect_cells(Checker& ck, const Context& ctx, const Dem& dem, const geodesy::PointSpec& s,
                  const ViewshedOptions& o, const std::string& label, const std::string& what,
                  const std::function<bool(int, int, std::uint8_t)>& bad) {
  const auto v = viewshed(ctx, dem, s, o);
  if (!v.ok()) {
    ck.record(true, 1, where(dem, s, o) + label + ": " + v.error().message);
    return;
  }
  const auto mask = visibility::visibility_mask(*v, v->target_height);
  const int col0 = v->frame.window.col0, row0 = v->frame.window.row0;
  std::uint64_t n = 0;
  int first_c = -1, first_r = -1;
  for (int r = 0; r < mask.height(); ++r)
    for (int c = 0; c < mask.width(); ++c)
      if (bad(c + col0, r + row0, mask.at(c, r)) && n++ == 0) first_c = c, first_r = r;
  ck.record(n > 0, double(n),
            n ? where(dem, s, o) + label + ": " + std::to_string(n) + " " + what + ", first " +
                    cell_text(*v, first_c, first_r)
              : std::string());
}

// --- Synthetic checks ---------------------------------------------------------

void far_from_origin(Checker& ck, const Context& ctx) {
  const int n = ctx.config.synthetic_size;
  for (std::uint32_t seed : {1u, 2u}) {
    const Dem near = rough_dem(n, n, seed, 300, 10);
    for (auto [dx, dy] : {std::pair{1e6, 1e6}, std::pair{-499000.0, 5e6}, std::pair{3e6, -4.99e6}}) {
      Dem far = near;
      far.georef.transform.origin_x += dx;
      far.georef.transform.origin_y += dy;
      far.source = near.source + " shifted by (" + fmt("%g", dx) + ", " + fmt("%g", dy) + ") m";
      const ViewshedOptions o = base_options(ctx);
      const auto s = at_cell(near, n * 0.37, n * 0.55, 2), t = at_cell(far, n * 0.37, n * 0.55, 2);
      // A double at 5e6 m resolves ~1e-9 m: the observer's grid position
      // moves by that much, the OHF by micrometres. Visibility must not move.
      expect_same(ck, viewshed(ctx, near, s, o), viewshed(ctx, far, t, o), 0.0, 1e-3, where(far, t, o));
    }
  }
}

// UTM northings near 1e7 (southern hemisphere, EPSG:32733) against the same
// DEM near the equator: the grid geometry is the same, only the point scale
// (from the easting) enters; both DEMs share the easting, so both viewsheds
// must agree.
void utm_large_northing(Checker& ck, const Context& ctx) {
  const int n = ctx.config.synthetic_size;
  Dem a = rough_dem(n, n, 3, 300, 30);
  a.georef.epsg = 32733;
  a.georef.transform.origin_y = 9999000.0;  // 1 km below the false northing: ~0.009 degrees south
  a.source += " in EPSG:32733 at northing 9999000";
  Dem b = a;
  b.georef.transform.origin_y = 6000000.0;  // ~36 degrees south
  b.source = a.source + " moved to northing 6000000";
  const ViewshedOptions o = base_options(ctx);
  // Point scales differ by a few ppm between the two latitudes at this easting:
  // allow a few millimetres of OHF, no visibility change.
  const auto s = at_cell(a, n * 0.5, n * 0.5, 2), t = at_cell(b, n * 0.5, n * 0.5, 2);
  expect_same(ck, viewshed(ctx, a, s, o), viewshed(ctx, b, t, o), 0.0, 0.05, where(a, s, o));
}

// Geographic DEMs at the equator, 30, 60 and 80 degrees: the frame's metric
// cell size is the WGS84 length of the cell at the observer, and the viewshed
// equals the one of the same heights on a plain-metre grid of those sizes.
void geographic_latitudes(Checker& ck, const Context& ctx) {
  const int n = ctx.config.synthetic_size;
  for (double lat : {0.0, 30.0, 60.0, 80.0}) {
    Dem geo = rough_dem(n, n, 4, 300, 1);
    const double step = 1.0 / 1200.0;  // 3 arc-seconds
    geo.georef.epsg = 4326;
    geo.georef.transform = {10.0, step, lat + n * step / 2, -step};
    geo.source += ", EPSG:4326 3\" cells centred on latitude " + fmt("%g", lat);
    const ViewshedOptions o = base_options(ctx);
    const auto s = at_cell(geo, n / 2, n / 2, 2);
    auto g = viewshed(ctx, geo, s, o);
    if (!g.ok()) {
      ck.record(true, std::numeric_limits<double>::infinity(), where(geo, s, o) + ": " + g.error().message);
      continue;
    }
    // WGS84 degree lengths (Torge): 111132.954 - 559.822 cos 2phi + 1.175 cos 4phi (north-south),
    // east-west pi a cos(phi) / (180 sqrt(1 - e^2 sin^2 phi)).
    const double pi = std::numbers::pi;
    const double phi = geo.georef.transform.y_at(n / 2) * pi / 180.0;
    const double a = 6378137.0, e2 = 0.00669437999014;
    const double ew = pi * a * std::cos(phi) / (180.0 * std::sqrt(1 - e2 * std::sin(phi) * std::sin(phi))) * step;
    const double ns = (111132.954 - 559.822 * std::cos(2 * phi) + 1.175 * std::cos(4 * phi)) * step;
    const double err = std::max(std::abs(g->frame.metres_per_col / ew - 1), std::abs(g->frame.metres_per_row / ns - 1));
    ck.record(err > 1e-3, 0.0,
              err > 1e-3 ? where(geo, s, o) + ": metric cell " +
                               fmt2("%.4f x %.4f m", g->frame.metres_per_col, g->frame.metres_per_row) + ", expected " +
                               fmt2("%.4f x %.4f m", ew, ns)
                         : std::string());
    Dem metric = geo;
    metric.georef.epsg = 0;
    metric.georef.crs.clear();
    metric.georef.transform = {0.0, g->frame.metres_per_col, 0.0, -g->frame.metres_per_row};
    metric.source = geo.source + " as plain metres";
    expect_same(ck, g, viewshed(ctx, metric, at_cell(metric, n / 2, n / 2, 2), o), 0.0, 1e-3, where(geo, s, o));
  }
}

// A geographic DEM across the antimeridian (179.9..180.1 E): an observer
// given as WGS84 longitude -179.95 is the same place as x = 180.05.
void antimeridian(Checker& ck, const Context& ctx) {
  const int n = ctx.config.synthetic_size;
  Dem geo = rough_dem(n, n, 5, 300, 1);
  const double step = 0.2 / n;
  geo.georef.epsg = 4326;
  geo.georef.transform = {179.9, step, -16.9, -step};  // Fiji's latitude
  geo.source += ", EPSG:4326 spanning lon 179.9..180.1";
  const ViewshedOptions o = base_options(ctx);
  for (double lon : {-179.95, -179.99, 179.95}) {
    geodesy::PointSpec wgs;
    wgs.frame = geodesy::PointFrame::kWgs84;
    wgs.x = lon;
    wgs.y = -16.95;
    wgs.height = 2;
    geodesy::PointSpec native = wgs;
    native.frame = geodesy::PointFrame::kDatasetCrs;
    native.x = lon < 0 ? lon + 360.0 : lon;
    const std::string what = geo.source + ", observer lon " + fmt("%g", lon) + " lat -16.95 (WGS84)";
    expect_same(ck, viewshed(ctx, geo, wgs, o), viewshed(ctx, geo, native, o), 0.0, 0.0, what);
  }
}

// Heights from -430 m (the Dead Sea shore) to 8848 m (Everest): adding a
// constant to every height and to the eye changes nothing but the OHF, by
// the same constant. Curvature on (it depends on distance only).
void height_extremes(Checker& ck, const Context& ctx) {
  const int n = ctx.config.synthetic_size;
  const Dem base = rough_dem(n, n, 6, 400, 30);
  for (double dz : {-430.0, 8848.0 - 400.0}) {
    Dem shifted = base;
    for (float& z : shifted.elevation.values()) z = static_cast<float>(z + dz);
    shifted.source = base.source + " raised by " + fmt("%g", dz) + " m";
    const ViewshedOptions o = base_options(ctx);
    const auto s = at_cell(base, n * 0.4, n * 0.6, 2), t = at_cell(shifted, n * 0.4, n * 0.6, 2);
    // The heights are exact before and after (multiples of 1/64 m); the OHF
    // is float32 (1 mm steps near 8.8 km, allowed for in ohf_gap). Allow 1 cm more.
    expect_same(ck, viewshed(ctx, base, s, o), viewshed(ctx, shifted, t, o), -dz, 0.01, where(shifted, t, o));
  }
}

// Cell sizes from 0.25 m to 1 km (1024 m): scaling cell size and heights by the same
// factor is a similarity, the viewshed must not change (curvature off: it
// is not scale-free).
void cell_sizes(Checker& ck, const Context& ctx) {
  const int n = ctx.config.synthetic_size;
  const Dem unit = rough_dem(n, n, 7, 100, 1.0);
  for (double cell : {0.25, 8.0, 1024.0}) {  // powers of two: the scaled inputs are exact
    Dem scaled = unit;
    for (float& z : scaled.elevation.values()) z = static_cast<float>(z * cell);
    scaled.georef.transform = {500000.0, cell, 5000000.0, -cell};
    scaled.source = unit.source + " scaled to " + fmt("%g", cell) + " m cells";
    ViewshedOptions o = base_options(ctx);
    o.curvature_coefficient = 0;
    // A binary fraction of a cell, so that the observer's grid position is exact at every scale.
    const double at = std::floor(n * 0.3) + 0.25;
    const auto s = at_cell(unit, at, at, 2), t = at_cell(scaled, at, at, 2 * cell);
    auto a = viewshed(ctx, unit, s, o), b = viewshed(ctx, scaled, t, o);
    if (!a.ok() || !b.ok()) {
      ck.record(true, 1, where(scaled, t, o) + ": failed to compute");
      continue;
    }
    // The OHF scales exactly (inputs and distances scale by a power of two).
    // Visibility must match except where the target is within the engine's
    // absolute 1 mm tie tolerance (viewshed.hpp) at either scale: 1 mm at 1 m
    // cells is 0.25 mm at 0.25 m cells, so a near-tie may legitimately flip.
    const auto ma = visibility::visibility_mask(*a, 0), mb = visibility::visibility_mask(*b, 0);
    std::uint64_t differ = 0;
    double worst_ohf = 0;
    int fc = -1, fr = -1;
    const double tie = std::max(double(visibility::kTieTolerance), double(visibility::kTieTolerance) / cell);
    for (int r = 0; r < ma.height(); ++r)
      for (int c = 0; c < ma.width(); ++c) {
        const float oa = a->ohf.at(c, r), ob = b->ohf.at(c, r), za = a->terrain.at(c, r);
        if (std::isnan(oa) != std::isnan(ob)) {
          if (differ++ == 0) fc = c, fr = r;
          continue;
        }
        if (std::isnan(oa)) continue;
        if (std::isfinite(oa) && std::isfinite(ob))
          worst_ohf =
              std::max(worst_ohf, std::abs(double(ob) - cell * double(oa)) - 2.0 * std::abs(double(ob)) * 1.1920929e-7);
        const bool near_tie = std::abs(double(oa) - double(za)) <= tie;
        if (ma.at(c, r) != mb.at(c, r) && !near_tie && differ++ == 0) fc = c, fr = r;
      }
    ck.ohf(worst_ohf);
    const bool bad = differ > 0 || worst_ohf > 1e-6 * cell;
    ck.record(bad, double(differ),
              bad ? where(scaled, t, o) + ": " + std::to_string(differ) + " cells differ from 1 m cells" +
                        (fc >= 0 ? ", first " + cell_text(*a, fc, fr) : std::string()) + ", OHF off scale by " +
                        fmt("%.3g", worst_ohf) + " m"
                  : std::string());
  }
}

// A 1000 m wall across flat ground at 0 m: the wall's own cells are seen,
// nothing behind it is (the shadow of a 1000 m wall seen from 2 m never ends
// inside the DEM), everything in front of it is.
void wall_1000m(Checker& ck, const Context& ctx) {
  const int n = ctx.config.synthetic_size;
  const int wall = n / 2;
  for (double cell : {1.0, 30.0}) {
    Dem dem = flat_dem(n, n, 0, cell);
    for (int r = 0; r < n; ++r) dem.elevation.at(wall, r) = 1000.0f;
    dem.source = "synthetic flat " + std::to_string(n) + "x" + std::to_string(n) + " with a 1000 m wall at col " +
                 std::to_string(wall) + ", " + fmt("%g", cell) + " m cells";
    ViewshedOptions o = base_options(ctx);
    o.curvature_coefficient = 0;
    expect_cells(ck, ctx, dem, at_cell(dem, wall / 3, n / 2, 2), o, "", "cells wrong", [&](int c, int, std::uint8_t m) {
      if (c < wall) return m != visibility::kVisible;
      if (c == wall) return false;  // wall face cells at a grazing angle: either answer
      return m != visibility::kHidden;
    });
  }
}

// Perfectly flat terrain, curvature off: every cell is visible, from 2 m and
// from the ground itself (eye height 0: every sight line is a tie).
void flat_all_visible(Checker& ck, const Context& ctx) {
  const int n = ctx.config.synthetic_size;
  for (double z : {0.0, -430.0, 8848.0})
    for (double h : {2.0, 0.0}) {
      const Dem dem = flat_dem(n + 7, n - 5, z, 30);
      ViewshedOptions o = base_options(ctx);
      o.curvature_coefficient = 0;
      for (auto [c, r] : {std::pair{0.37 * n, 0.61 * n}, std::pair{0.0, 0.0}, std::pair{n * 0.5 + 0.5, n * 0.25}})
        expect_cells(ck, ctx, dem, at_cell(dem, c, r, h), o, "", "cells not visible",
                     [](int, int, std::uint8_t m) { return m != visibility::kVisible; });
    }
}

// A 100 m plateau (a square of half-side P cells) on flat ground, eye 2 m
// above its centre: the whole top is seen; ground cells just past an edge,
// on the axes, within 50 P cells of the edge, are hidden (the sight line over
// the edge from 102 m drops 2 m per P cells).
void plateau(Checker& ck, const Context& ctx) {
  const int n = ctx.config.synthetic_size;
  const int half = std::max(2, n / 12), mid = n / 2;
  Dem dem = flat_dem(n, n, 0, 10);
  for (int r = mid - half; r <= mid + half; ++r)
    for (int c = mid - half; c <= mid + half; ++c) dem.elevation.at(c, r) = 100.0f;
  dem.source = "synthetic " + std::to_string(n) + "x" + std::to_string(n) + " 100 m plateau, half-side " +
               std::to_string(half) + " cells, 10 m cells";
  ViewshedOptions o = base_options(ctx);
  o.curvature_coefficient = 0;
  expect_cells(ck, ctx, dem, at_cell(dem, mid, mid, 2), o, "", "cells wrong", [&](int c, int r, std::uint8_t m) {
    const int dc = std::abs(c - mid), dr = std::abs(r - mid);
    if (dc <= half && dr <= half) return m != visibility::kVisible;                                 // the top
    if ((dr == 0 && dc > half + 1) || (dc == 0 && dr > half + 1)) return m != visibility::kHidden;  // axes below
    return false;
  });
}

// The observer on a cell centre, a cell edge, a cell corner, on the border
// cells, just inside the outer edge: the viewshed computes, flat terrain is
// all visible; just outside the outer edge: a clean kOutOfRange error.
void observer_positions(Checker& ck, const Context& ctx) {
  const int n = ctx.config.synthetic_size;
  const Dem flat = flat_dem(n, n, 50, 10);
  const Dem rough = rough_dem(n, n, 8, 300, 10);
  ViewshedOptions o = base_options(ctx);
  o.curvature_coefficient = 0;
  const double e = 0.5 - 1e-6;  // just inside the outer edge
  const std::pair<double, double> inside[] = {{n / 2.0, n / 2.0},
                                              {n / 2.0 + 0.5, n / 2.0},
                                              {n / 2.0 + 0.5, n / 2.0 + 0.5},
                                              {0, 0},
                                              {n - 1.0, n - 1.0},
                                              {0, n / 2.0},
                                              {-e, -e},
                                              {n - 1 + e, n / 2.0},
                                              {n / 3.0, n - 1 + e},
                                              {n - 1.0 + 0.5, n - 1.0 + 0.5}};
  for (auto [c, r] : inside) {
    const auto s = at_cell(flat, c, r, 2);
    expect_cells(ck, ctx, flat, s, o, "", "cells not visible on flat terrain",
                 [](int, int, std::uint8_t m) { return m != visibility::kVisible; });
    auto w = viewshed(ctx, rough, at_cell(rough, c, r, 2), o);
    ck.record(!w.ok(), w.ok() ? 0 : 1, w.ok() ? std::string() : where(rough, s, o) + ": " + w.error().message);
  }
  for (auto [c, r] : {std::pair{-0.5 - 1e-6, n / 2.0}, std::pair{n / 2.0, n - 0.5 + 1e-6}, std::pair{-3.0, -3.0}}) {
    const auto s = at_cell(flat, c, r, 2);
    auto v = viewshed(ctx, flat, s, o);
    const bool clean = !v.ok() && v.error().code == ErrorCode::kOutOfRange && v.error().field == "observer";
    ck.record(!clean, clean ? 0 : 1,
              clean ? std::string()
                    : where(flat, s, o) + ": expected an out-of-range error naming the observer, got " +
                          (v.ok() ? std::string("a viewshed") : v.error().message));
  }
}

// Eye heights 0 and 10 km: both compute; from 10 km everything seen from 2 m
// is still seen (monotonic), and from 0 m on flat ground all is seen.
void observer_heights(Checker& ck, const Context& ctx) {
  const int n = ctx.config.synthetic_size;
  const Dem rough = rough_dem(n, n, 9, 300, 30);
  const ViewshedOptions o = base_options(ctx);
  const auto s2 = at_cell(rough, n * 0.45, n * 0.55, 2);
  auto low = viewshed(ctx, rough, s2, o);
  for (double h : {0.0, 10000.0}) {
    const auto s = at_cell(rough, n * 0.45, n * 0.55, h);
    auto v = viewshed(ctx, rough, s, o);
    if (!v.ok() || !low.ok()) {
      ck.record(true, 1, where(rough, s, o) + ": failed to compute");
      continue;
    }
    const auto a = visibility::visibility_mask(*low, 0), b = visibility::visibility_mask(*v, 0);
    std::uint64_t bad = 0;
    int first = -1;
    for (std::size_t i = 0; i < a.size(); ++i) {
      const bool violates = h > 2 ? (a.data()[i] == visibility::kVisible && b.data()[i] != visibility::kVisible)
                                  : (b.data()[i] == visibility::kVisible && a.data()[i] != visibility::kVisible);
      if (violates && bad++ == 0) first = static_cast<int>(i);
    }
    ck.record(bad > 0, double(bad),
              bad ? where(rough, s, o) + ": " + std::to_string(bad) + " cells break monotonicity against 2 m, first " +
                        cell_text(*v, first % a.width(), first / a.width())
                  : std::string());
  }
}

// Targets at distance 0 and 1 cell: with the eye on a cell centre no grid
// line lies strictly between it and its own cell or a neighbour, so those 9
// cells are always visible, whatever the terrain and however low the eye.
void near_targets(Checker& ck, const Context& ctx) {
  const int n = ctx.config.synthetic_size;
  const Dem rough = rough_dem(n, n, 10, 600, 5);
  const ViewshedOptions o = base_options(ctx);
  std::mt19937 rng(ctx.config.seed);
  std::uniform_int_distribution<int> cell(1, n - 2);
  for (int k = 0; k < 12; ++k) {
    const int c = cell(rng), r = cell(rng);
    const auto s = at_cell(rough, c, r, k % 2 ? 0.0 : 1.0);
    auto v = viewshed(ctx, rough, s, o);
    if (!v.ok()) {
      ck.record(true, 1, where(rough, s, o) + ": " + v.error().message);
      continue;
    }
    const auto m = visibility::visibility_mask(*v, 0);
    std::uint64_t bad = 0;
    std::string first;
    for (int dr = -1; dr <= 1; ++dr)
      for (int dc = -1; dc <= 1; ++dc) {
        const int wc = c + dc - v->frame.window.col0, wr = r + dr - v->frame.window.row0;
        if (m.at(wc, wr) != visibility::kVisible && bad++ == 0)
          first = "cell (col " + std::to_string(c + dc) + ", row " + std::to_string(r + dr) +
                  ") = " + std::to_string(m.at(wc, wr));
      }
    ck.record(bad > 0, double(bad), bad ? where(rough, s, o) + ": " + first : std::string());
  }
}

// Voids on the sight line never block (transparent policy): a NaN column
// standing in for a 1000 m wall leaves flat terrain all visible beyond it,
// and the void cells themselves get no answer. Filled at 1000 m they block.
void nodata_on_sight_line(Checker& ck, const Context& ctx) {
  const int n = ctx.config.synthetic_size;
  Dem dem = flat_dem(n, n, 0, 30);
  const int hole = n / 2;
  for (int r = 0; r < n; ++r) dem.elevation.at(hole, r) = kNaN;
  dem.source = "synthetic flat " + std::to_string(n) + "x" + std::to_string(n) + " with a void column at col " +
               std::to_string(hole);
  ViewshedOptions o = base_options(ctx);
  o.curvature_coefficient = 0;
  const auto s = at_cell(dem, hole / 3, n / 2, 2);
  expect_cells(ck, ctx, dem, s, o, ", voids transparent", "cells wrong", [&](int c, int, std::uint8_t m) {
    return c == hole ? m != visibility::kNoAnswer : m != visibility::kVisible;
  });
  o.nodata = visibility::NodataPolicy::kFill;
  o.nodata_fill_height = 1000;
  expect_cells(ck, ctx, dem, s, o, ", voids filled at 1000 m", "cells behind not hidden",
               [&](int c, int, std::uint8_t m) { return c > hole ? m != visibility::kHidden : false; });
}

// The observer on a void: height above ground is a clean kDataError naming
// the observer; an absolute altitude computes.
void nodata_at_observer(Checker& ck, const Context& ctx) {
  const int n = ctx.config.synthetic_size;
  Dem dem = rough_dem(n, n, 11, 300, 30);
  const int c = n / 2, r = n / 3;
  for (int dr = -1; dr <= 1; ++dr)
    for (int dc = -1; dc <= 1; ++dc) dem.elevation.at(c + dc, r + dr) = kNaN;
  dem.source += " with a 3x3 void around the observer";
  const ViewshedOptions o = base_options(ctx);
  const auto s = at_cell(dem, c, r, 2);
  auto v = viewshed(ctx, dem, s, o);
  const bool clean = !v.ok() && v.error().code == ErrorCode::kDataError && v.error().field == "observer";
  ck.record(!clean, clean ? 0 : 1,
            clean ? std::string()
                  : where(dem, s, o) + ": expected a data error naming the observer, got " +
                        (v.ok() ? std::string("a viewshed") : v.error().message));
  const auto a = at_cell(dem, c, r, 500, geodesy::HeightMode::kAbsolute);
  auto w = viewshed(ctx, dem, a, o);
  ck.record(!w.ok(), w.ok() ? 0 : 1, w.ok() ? std::string() : where(dem, a, o) + ": " + w.error().message);
}

// What each algorithm promises against R3 on rough synthetic terrain:
// exact and r3 agree on every cell, conservative misses none, fast keeps IoU
// >= 97 % (the per-observer floor of test_accuracy_bundled).
void matches_r3(Checker& ck, const Context& ctx) {
  const int n = ctx.config.synthetic_size;
  for (std::uint32_t seed : {12u, 13u, 14u}) {
    const Dem dem = rough_dem(n, n, seed, 250, 30);
    ViewshedOptions o = base_options(ctx);
    ViewshedOptions ref = o;
    ref.algorithm = Algorithm::kR3;
    ref.backend = visibility::Backend::kCpu;
    const auto s = at_cell(dem, n * 0.31 + seed % 3, n * 0.47, 2);
    auto v = viewshed(ctx, dem, s, o), r = viewshed(ctx, dem, s, ref);
    if (!v.ok() || !r.ok()) {
      ck.record(true, 1, where(dem, s, o) + ": failed to compute");
      continue;
    }
    const visibility::Agreement a = visibility::compare_viewsheds(*v, *r, 0);
    bool bad = false;
    double dev = 0;
    switch (ctx.algorithm) {
      case Algorithm::kR3:
      case Algorithm::kExact:
        dev = double(a.missed_visible + a.extra_visible);
        bad = dev > 0;
        break;
      case Algorithm::kConservative:
        dev = double(a.missed_visible);
        bad = dev > 0;
        break;
      case Algorithm::kRadial:
        dev = double(a.missed_visible + a.extra_visible);
        bad = a.iou < 0.97;
        break;
    }
    ck.record(bad, dev,
              bad ? where(dem, s, o) + ": " + std::to_string(a.missed_visible) + " missed, " +
                        std::to_string(a.extra_visible) + " extra visible against R3 (IoU " + fmt("%.4f", a.iou) + ")"
                  : std::string());
  }
}

// --- Properties on real DEMs ---------------------------------------------------

struct DemChecks {
  Checker raise_observer, raise_target, min_height, shift_xyz, window_crop;
};

void dem_properties(DemChecks& out, const Context& ctx, const std::string& path, std::uint32_t seed) {
  auto header = terrain::read_dem_header(path);
  if (!header.ok()) {
    out.raise_observer.record(true, 1, header.error().message);
    return;
  }
  std::mt19937 rng(seed);
  std::uniform_int_distribution<int> uc(0, header->width - 1), ur(0, header->height - 1);
  const int radius = ctx.config.radius_cells;
  int found = 0;
  for (int tries = 0; found < ctx.config.observers_per_dem && tries < 200; ++tries) {
    if (ctx.control && !ctx.control->check().ok()) return;
    const int col = uc(rng), row = ur(rng);
    // Read the window the viewshed needs (plus 8 cells for the crop check), or the whole file.
    terrain::ReadOptions ro;
    terrain::Window win{0, 0, header->width, header->height};
    if (radius > 0)
      win = {std::max(0, col - radius - 8), std::max(0, row - radius - 8), std::min(header->width, col + radius + 9),
             std::min(header->height, row + radius + 9)};
    ro.window = win;
    auto dem = terrain::read_dem(path, ro);
    if (!dem.ok()) {
      out.raise_observer.record(true, 1, dem.error().message);
      return;
    }
    const int c = col - win.col0, r = row - win.row0;
    if (std::isnan(dem->elevation.at(c, r))) continue;
    ++found;
    ViewshedOptions o = base_options(ctx);
    if (radius > 0) {
      // `radius` cells along the DEM's finer metric axis, so the disc stays inside the window read.
      auto eye = geodesy::resolve_point(*dem, at_cell(*dem, c, r, 2), "observer");
      if (eye.ok())
        if (auto probe = visibility::make_view_frame(*dem, *eye, o); probe.ok())
          o.max_distance = radius * std::min(probe->metres_per_col, probe->metres_per_row);
    }
    const std::string label = std::filesystem::path(path).filename().string();
    const auto s = at_cell(*dem, c, r, 2);
    const std::string what =
        label + " observer cell (col " + std::to_string(col) + ", row " + std::to_string(row) + "), height 2 m" +
        (std::isfinite(o.max_distance) ? ", max distance " + fmt("%.1f", o.max_distance) + " m" : std::string());
    auto base = viewshed(ctx, *dem, s, o);
    if (!base.ok()) {
      out.raise_observer.record(true, 1, what + ": " + base.error().message);
      continue;
    }
    const auto mask0 = visibility::visibility_mask(*base, 0);

    // Raising the observer by 10 m and 100 m never hides a visible cell, but
    // for an error of fast's or conservative's own at the lower eye (stress.hpp).
    const bool exact_answers = ctx.algorithm == Algorithm::kR3 || ctx.algorithm == Algorithm::kExact;
    for (double up : {10.0, 100.0}) {
      auto higher = viewshed(ctx, *dem, at_cell(*dem, c, r, 2 + up), o);
      if (!higher.ok()) {
        out.raise_observer.record(true, 1, what + ": " + higher.error().message);
        continue;
      }
      const auto m = visibility::visibility_mask(*higher, 0);
      const terrain::Window& w = base->frame.window;
      std::uint64_t bad = 0, explained = 0;
      int first_bad = -1, first_explained = -1;
      for (std::size_t i = 0; i < m.size(); ++i) {
        if (mask0.data()[i] != visibility::kVisible || m.data()[i] != visibility::kHidden) continue;
        // The target cell, in the DEM as read.
        const int tc = w.col0 + static_cast<int>(i % m.width()), tr = w.row0 + static_cast<int>(i / m.width());
        // R3 from the lower eye, at this cell only (the default transparent voids: the DEM as read).
        const bool r3_sees = !exact_answers && 0.0f >= visibility::min_target_height_at(
                                                           visibility::r3_ohf_at(dem->elevation, base->frame, tc, tr),
                                                           dem->elevation.at(tc, tr));
        if (exact_answers || r3_sees) {
          if (bad++ == 0) first_bad = static_cast<int>(i);
        } else if (explained++ == 0) {
          first_explained = static_cast<int>(i);
        }
      }
      const auto text = [&](std::uint64_t n, int at, const char* tail) {
        return what + ": raised by " + fmt("%g", up) + " m hides " + std::to_string(n) + " cells" + tail + ", first " +
               cell_text(*base, at % m.width(), at / m.width());
      };
      out.raise_observer.record(bad > 0, double(bad), bad ? text(bad, first_bad, "") : std::string());
      out.raise_observer.explain(
          explained, explained ? text(explained, first_explained, " that R3 hides from the lower eye") : std::string());
    }

    // Raising the target (1 m, 10 m) never hides; min height is >= 0 and
    // reproduces the mask at any target height, also when the target height
    // is given to the engine.
    const Grid<float> mth = visibility::min_target_height(*base);
    std::uint64_t negative = 0, inconsistent = 0, hidden_by_target = 0;
    double worst_negative = 0;
    for (double th : {0.0, 1.0, 10.0}) {
      ViewshedOptions ot = o;
      ot.target_height = th;
      auto t = viewshed(ctx, *dem, s, ot);
      if (!t.ok()) {
        out.raise_target.record(true, 1, what + ": " + t.error().message);
        continue;
      }
      const auto m = visibility::visibility_mask(*t, th);
      for (std::size_t i = 0; i < m.size(); ++i) {
        const float h = mth.data()[i];
        if (th == 0.0 && !std::isnan(h) && h < 0) ++negative, worst_negative = std::max(worst_negative, double(-h));
        const std::uint8_t expect =
            std::isnan(h) ? visibility::kNoAnswer : (th >= h ? visibility::kVisible : visibility::kHidden);
        if (m.data()[i] != expect) ++inconsistent;
        if (mask0.data()[i] == visibility::kVisible && m.data()[i] == visibility::kHidden) ++hidden_by_target;
      }
    }
    out.raise_target.record(hidden_by_target > 0, double(hidden_by_target),
                            hidden_by_target
                                ? what + ": raising the target hides " + std::to_string(hidden_by_target) + " cells"
                                : std::string());
    out.min_height.record(negative > 0 || inconsistent > 0, double(negative + inconsistent),
                          negative || inconsistent
                              ? what + ": " + std::to_string(negative) + " negative minimum heights (worst " +
                                    fmt("%g", worst_negative) + " m), " + std::to_string(inconsistent) +
                                    " cells where the mask disagrees with the minimum height"
                              : std::string());

    // Shifting the DEM by (1e6 m, -2e6 m) in x/y and +1000 m in z shifts the
    // OHF by 1000 m and changes nothing else. Plain metres (no CRS), so the
    // same metric cell sizes apply before and after.
    {
      auto eye = geodesy::resolve_point(*dem, s, "observer");
      auto frame = eye.ok() ? visibility::make_view_frame(*dem, *eye, o) : Result<visibility::ViewFrame>(eye.error());
      if (!frame.ok()) {
        out.shift_xyz.record(true, 1, what + ": " + frame.error().message);
      } else {
        Dem plain = *dem;
        // Heights to multiples of 1/256 m first, so that adding 1000 m is
        // exact in float32 (a Float32 DEM's fractions would otherwise round).
        for (float& z : plain.elevation.values())
          if (!std::isnan(z)) z = static_cast<float>(std::round(double(z) * 256.0) / 256.0);
        plain.georef.epsg = 0;
        plain.georef.crs.clear();
        plain.georef.transform = {0.0, frame->metres_per_col, 0.0, -frame->metres_per_row};
        Dem moved = plain;
        moved.georef.transform.origin_x += 1e6;
        moved.georef.transform.origin_y -= 2e6;
        for (float& z : moved.elevation.values())
          if (!std::isnan(z)) z = static_cast<float>(z + 1000.0);
        const Result<ViewshedResult> a = viewshed(ctx, plain, at_cell(plain, c, r, 2), o);
        const Result<ViewshedResult> b = viewshed(ctx, moved, at_cell(moved, c, r, 2), o);
        // 1 cm beyond float32 rounding of the OHF itself: float32 algorithms
        // round the heights relative to the eye too.
        expect_same(out.shift_xyz, a, b, -1000.0, 0.01, what + ", moved by (1e6, -2e6, +1000) m");
      }
    }

    // Cropping cells the viewshed never reaches (8 columns and rows on the
    // west and north, when the window allows) changes nothing: the window
    // read of a tiled file depends on this.
    if (radius > 0 && c - radius - 8 >= 0 && r - radius - 8 >= 0) {
      const terrain::Window keep{8, 8, dem->width(), dem->height()};
      Dem cropped = *dem;
      cropped.elevation = Grid<float>(keep.width(), keep.height());
      for (int y = keep.row0; y < keep.row1; ++y)
        for (int x = keep.col0; x < keep.col1; ++x) cropped.elevation.at(x - 8, y - 8) = dem->elevation.at(x, y);
      cropped.georef.transform = dem->georef.transform.shifted(8, 8);
      auto eye = geodesy::resolve_point(*dem, s, "observer");
      if (eye.ok()) {
        geodesy::GridPoint e2 = *eye;
        e2.col -= 8;  // exact, as the CLI's window read does
        e2.row -= 8;
        auto a = visibility::compute_viewshed(*dem, *eye, o, nullptr, ctx.gpu);
        auto b = visibility::compute_viewshed(cropped, e2, o, nullptr, ctx.gpu);
        expect_same(out.window_crop, a, b, 0.0, 0.0, what + ", the DEM cropped by 8 cells west and north");
      }
    }
  }
}

using SyntheticCheck = void (*)(Checker&, const Context&);

struct CheckSpec {
  const char* name;
  const char* description;
  const char* unit;
  SyntheticCheck run;  // null: a dem_* check
};

constexpr CheckSpec kChecks[] = {
    {"far_from_origin", "moving the DEM by up to 5e6 m in x/y gives the same viewshed", "cells", far_from_origin},
    {"utm_large_northing", "UTM northings near 1e7 m give the viewshed they give at 6e6 m", "cells",
     utm_large_northing},
    {"geographic_latitudes", "at 0/30/60/80 deg the metric cell is WGS84's and the viewshed that of those metres",
     "cells", geographic_latitudes},
    {"antimeridian", "an observer at lon -179.95 on a DEM across 180 deg is the same as x = 180.05", "cells",
     antimeridian},
    {"height_extremes", "adding -430 m or +8448 m to every height only shifts the OHF", "cells", height_extremes},
    {"cell_sizes", "0.25 m, 8 m and 1024 m cells with heights scaled alike give the 1 m viewshed", "cells", cell_sizes},
    {"wall_1000m", "a 1000 m wall: all before it seen, nothing behind it", "cells", wall_1000m},
    {"flat_all_visible", "flat terrain is all visible, from 2 m and from 0 m", "cells", flat_all_visible},
    {"plateau", "a plateau's top is all seen, the ground below its edges hidden", "cells", plateau},
    {"observer_positions", "centre/edge/corner/border/just inside compute; just outside is a clean error", "cases",
     observer_positions},
    {"observer_heights", "eye at 0 m and 10 km: monotonic against 2 m", "cells", observer_heights},
    {"near_targets", "the observer's cell and its 8 neighbours are always visible", "cells", near_targets},
    {"nodata_on_sight_line", "voids never block (transparent) and block when filled high", "cells",
     nodata_on_sight_line},
    {"nodata_at_observer", "an observer on a void is a clean error unless its altitude is absolute", "cases",
     nodata_at_observer},
    {"matches_r3", "exact = R3, conservative misses nothing, fast IoU >= 97 %", "cells", matches_r3},
    {"dem_raise_observer",
     "real DEMs: raising the eye 10/100 m never hides a cell R3 sees (exact, r3: no visible cell at all)", "cells",
     nullptr},
    {"dem_raise_target", "real DEMs: raising the target 1/10 m never hides a visible cell", "cells", nullptr},
    {"dem_min_height", "real DEMs: minimum visible height >= 0 and it reproduces the mask", "cells", nullptr},
    {"dem_shift_xyz", "real DEMs: moving the DEM by (1e6, -2e6, +1000) m only shifts the OHF", "cells", nullptr},
    {"dem_window_crop", "real DEMs: cropping cells out of reach changes nothing (window reads)", "cells", nullptr},
};

}  // namespace

std::vector<std::string> stress_check_names() {
  std::vector<std::string> names;
  for (const CheckSpec& c : kChecks) names.emplace_back(c.name);
  return names;
}

Result<std::vector<CheckResult>> run_stress(const StressConfig& config, const std::vector<std::string>& checks,
                                            const RunControl* control) {
  for (const std::string& name : checks)
    if (std::none_of(std::begin(kChecks), std::end(kChecks), [&](const CheckSpec& c) { return name == c.name; }))
      return make_error(ErrorCode::kInvalidArgument, "stress: no check named '" + name + "'", "checks");
  if (config.synthetic_size < 64)
    return make_error(ErrorCode::kInvalidArgument, "stress: synthetic_size must be >= 64", "synthetic_size");
  auto wanted = [&](const char* name) {
    return checks.empty() || std::find(checks.begin(), checks.end(), name) != checks.end();
  };
  const bool dem_checks =
      std::any_of(std::begin(kChecks), std::end(kChecks), [&](const CheckSpec& c) { return !c.run && wanted(c.name); });
  // Each algorithm on the CPU, then fast once more on the GPU ("fast-gpu") when a pool is given.
  struct Pass {
    Algorithm algorithm;
    gpu::ContextPool* gpu;
    std::string label;
  };
  std::vector<Pass> passes;
  for (Algorithm algorithm : config.algorithms)
    passes.push_back({algorithm, nullptr, std::string(visibility::algorithm_name(algorithm))});
  if (config.gpu) passes.push_back({Algorithm::kRadial, config.gpu, "fast-gpu"});
  const double units =
      double(passes.size()) * (double(std::size(kChecks)) + (dem_checks ? double(config.dems.size()) : 0.0));
  double done = 0;
  std::vector<CheckResult> results;
  for (const Pass& pass : passes) {
    const Context ctx{config, pass.algorithm, control, pass.gpu};
    const std::string& alg = pass.label;
    auto label = [&](Checker& ck, const CheckSpec& spec) {
      ck.r.check = spec.name;
      ck.r.algorithm = alg;
      ck.r.description = spec.description;
      ck.r.unit = spec.unit;
    };
    for (const CheckSpec& spec : kChecks) {
      report_progress(control, done / units);
      done += 1;
      if (!spec.run || !wanted(spec.name)) continue;
      HORIZON_RETURN_IF_ERROR(check_control(control));
      Checker ck;
      label(ck, spec);
      spec.run(ck, ctx);
      results.push_back(ck.r);
    }
    if (dem_checks) {
      DemChecks dc;
      Checker* all[] = {&dc.raise_observer, &dc.raise_target, &dc.min_height, &dc.shift_xyz, &dc.window_crop};
      std::size_t k = 0;
      for (const CheckSpec& spec : kChecks)
        if (!spec.run) label(*all[k++], spec);
      for (std::size_t i = 0; i < config.dems.size(); ++i) {
        HORIZON_RETURN_IF_ERROR(check_control(control));
        dem_properties(dc, ctx, config.dems[i], config.seed + static_cast<std::uint32_t>(i));
        report_progress(control, ++done / units);
      }
      k = 0;
      for (const CheckSpec& spec : kChecks)
        if (!spec.run) {
          if (wanted(spec.name)) results.push_back(all[k]->r);
          ++k;
        }
    }
  }
  report_progress(control, 1.0);
  return results;
}

std::string stress_markdown(const std::vector<CheckResult>& results) {
  std::ostringstream md;
  md << "| check | algorithm | cases | result | worst deviation | worst OHF deviation | explained by its own error | "
        "first failure |\n"
     << "|---|---|---:|---|---:|---:|---|---|\n";
  const auto cell = [](std::string text) {
    for (char& ch : text)
      if (ch == '|') ch = '/';  // a '|' would break the table
    return text;
  };
  for (const CheckResult& r : results) {
    const std::string failure = cell(r.first_failure);
    const std::string explained =
        r.explained ? std::to_string(r.explained) + " cells (first: " + cell(r.first_explained) + ")" : std::string();
    md << "| " << r.check << " | " << r.algorithm << " | " << r.cases << " | "
       << (r.cases == 0 ? "no cases"
           : r.passed() ? "pass"
                        : "**FAIL** (" + std::to_string(r.failed) + ")")
       << " | " << fmt("%g", r.worst) << " " << r.unit << " | " << (r.worst_ohf > 0 ? fmt("%.4g m", r.worst_ohf) : "")
       << " | " << explained << " | " << failure << " |\n";
  }
  return md.str();
}

}  // namespace horizon::evaluation
