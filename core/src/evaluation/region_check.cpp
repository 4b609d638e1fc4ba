#include "horizon/evaluation/region_check.hpp"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <random>

#include "horizon/common/parallel.hpp"
#include "horizon/visibility/r3.hpp"
#include "horizon/visibility/view_frame.hpp"

namespace horizon::evaluation {
namespace {

struct Oracle {
  terrain::HeightView terrain;
  std::vector<visibility::ViewFrame> frames;
};

Oracle make_oracle(const terrain::Dem& dem, const region::RegionOptions& options,
                   const std::vector<geodesy::GridPoint>& viewpoints) {
  Oracle o;
  o.terrain = terrain::HeightView(dem.elevation);
  if (options.nodata == visibility::NodataPolicy::kFill)
    o.terrain = o.terrain.with_void_fill(static_cast<float>(options.nodata_fill_height));
  visibility::ViewshedOptions vs;
  vs.curvature_coefficient = options.curvature_coefficient;
  vs.nodata = options.nodata;
  vs.nodata_fill_height = options.nodata_fill_height;
  for (const geodesy::GridPoint& v : viewpoints) {
    auto f = visibility::make_view_frame(dem, v, vs);
    if (f.ok()) o.frames.push_back(*f);
  }
  return o;
}

// R3: the point z over cell (c, r) is seen from frame's eye.
bool seen(const Oracle& o, const visibility::ViewFrame& f, int c, int r, double z) {
  return z >= static_cast<double>(visibility::r3_ohf_at(o.terrain, f, c, r));
}

void tally(region::Verdict v, std::uint64_t seen_count, std::uint64_t total, RegionCheck& out) {
  if (v == region::Verdict::kAlwaysHidden) {
    ++out.hidden_checked;
    out.wrong_hidden += seen_count;
  } else if (v == region::Verdict::kAlwaysVisible) {
    ++out.visible_checked;
    out.wrong_visible += total - seen_count;
  }
  if (seen_count == 0) ++out.sampled_hidden;
  if (seen_count == total) ++out.sampled_visible;
  ++out.items_checked;
}

double seconds_since(std::chrono::steady_clock::time_point t) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t).count();
}

}  // namespace

std::vector<geodesy::GridPoint> sample_region(const terrain::Dem& dem, const region::RegionSpec& region,
                                              const region::RegionFrame& f, const RegionSampling& sampling) {
  const bool above_ground = region.height_mode == geodesy::HeightMode::kAboveGround;
  std::vector<geodesy::GridPoint> out;
  const auto add = [&](double tc, double tr, double tz) {
    geodesy::GridPoint p;
    p.col = f.col_min + tc * (f.col_max - f.col_min);
    p.row = f.row_min + tr * (f.row_max - f.row_min);
    p.x = dem.georef.transform.x_at(p.col);
    p.y = dem.georef.transform.y_at(p.row);
    p.ground = terrain::sample_bilinear(dem.elevation, p.col, p.row);
    p.elevation = above_ground ? p.ground + region.z_min + tz * (region.z_max - region.z_min)
                               : f.z_min + tz * (f.z_max - f.z_min);
    if (p.elevation == p.elevation) out.push_back(p);
  };
  for (int k = 0; k < 8; ++k) add(k & 1, (k >> 1) & 1, (k >> 2) & 1);
  // Edge midpoints: one coordinate at 1/2, the other two at 0 or 1.
  for (int axis = 0; axis < 3; ++axis)
    for (int k = 0; k < 4; ++k) {
      double t[3];
      t[axis] = 0.5;
      t[(axis + 1) % 3] = k & 1;
      t[(axis + 2) % 3] = (k >> 1) & 1;
      add(t[0], t[1], t[2]);
    }
  std::mt19937 rng(sampling.seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  for (int face = 0; face < 6; ++face)
    for (int k = 0; k < sampling.face_points; ++k) {
      double t[3] = {u(rng), u(rng), u(rng)};
      t[face / 2] = face % 2;
      add(t[0], t[1], t[2]);
    }
  for (int k = 0; k < sampling.interior_points; ++k) {
    const double a = u(rng), b = u(rng), c = u(rng);
    add(a, b, c);
  }
  return out;
}

RegionCheck check_cells(const terrain::Dem& dem, const region::RegionCellsResult& result,
                        const region::RegionOptions& options, const std::vector<geodesy::GridPoint>& viewpoints,
                        std::size_t max_cells, unsigned threads) {
  const auto started = std::chrono::steady_clock::now();
  const Oracle oracle = make_oracle(dem, options, viewpoints);
  const terrain::Window& w = result.window;
  std::vector<std::pair<int, int>> cells;
  for (int r = w.row0; r < w.row1; ++r)
    for (int c = w.col0; c < w.col1; ++c)
      if (result.codes.at(c - w.col0, r - w.row0) != region::kNoAnswer) cells.emplace_back(c, r);
  const std::size_t stride =
      std::max<std::size_t>(1, (cells.size() + max_cells - 1) / std::max<std::size_t>(1, max_cells));
  std::vector<std::pair<int, int>> picked;
  for (std::size_t i = 0; i < cells.size(); i += stride) picked.push_back(cells[i]);

  std::vector<std::uint64_t> seen_count(picked.size(), 0);
  parallel_for(picked.size(), threads, [&](std::size_t i) {
    const auto [c, r] = picked[i];
    const double z = oracle.terrain.at(c, r) + options.target_height;
    std::uint64_t n = 0;
    for (const visibility::ViewFrame& f : oracle.frames) n += seen(oracle, f, c, r, z) ? 1 : 0;
    seen_count[i] = n;
  });
  RegionCheck out;
  out.viewpoints = oracle.frames.size();
  for (std::size_t i = 0; i < picked.size(); ++i) {
    const auto [c, r] = picked[i];
    tally(static_cast<region::Verdict>(result.codes.at(c - w.col0, r - w.row0)), seen_count[i], out.viewpoints, out);
  }
  out.seconds = seconds_since(started);
  return out;
}

RegionCheck check_boxes(const terrain::Dem& dem, const region::RegionBoxesResult& result,
                        std::span<const visibility::BoxSpec> boxes, const region::RegionOptions& options,
                        const std::vector<geodesy::GridPoint>& viewpoints, unsigned threads) {
  const auto started = std::chrono::steady_clock::now();
  const Oracle oracle = make_oracle(dem, options, viewpoints);
  auto footprints = visibility::resolve_boxes(dem, boxes);
  RegionCheck out;
  out.viewpoints = oracle.frames.size();
  if (!footprints.ok()) return out;
  std::vector<std::uint64_t> seen_count(boxes.size(), 0);
  std::vector<char> has_target(boxes.size(), 0);
  parallel_for(boxes.size(), threads, [&](std::size_t b) {
    const terrain::Window& cells = (*footprints)[b].cells;
    const double z = (*footprints)[b].z_max;
    std::uint64_t n = 0;
    for (const visibility::ViewFrame& f : oracle.frames) {
      bool any = false;
      for (int r = cells.row0; r < cells.row1 && !any; ++r)
        for (int c = cells.col0; c < cells.col1 && !any; ++c) {
          const float g = oracle.terrain.at(c, r);
          if (!(g == g)) continue;
          has_target[b] = 1;
          any = seen(oracle, f, c, r, z);
        }
      n += any ? 1 : 0;
    }
    seen_count[b] = n;
  });
  for (std::size_t b = 0; b < boxes.size(); ++b)
    if (has_target[b]) tally(result.verdicts[b], seen_count[b], out.viewpoints, out);
  out.seconds = seconds_since(started);
  return out;
}

}  // namespace horizon::evaluation
