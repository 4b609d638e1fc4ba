#include "horizon/mesh/occlusion_region.hpp"

#include <algorithm>
#include <cassert>
#include <cmath>

namespace horizon::mesh {

OcclusionChain OcclusionChain::from_horizon(ChainPoint p, ChainPoint h) {
  assert(h.t > p.t);
  OcclusionChain chain;
  chain.corners_.push_back(h);
  chain.final_slope_ = (h.z - p.z) / (h.t - p.t);
  return chain;
}

std::optional<OcclusionChain> OcclusionChain::from_parts(std::vector<ChainPoint> corners, double final_slope) {
  if (!std::isfinite(final_slope)) return std::nullopt;
  for (std::size_t j = 0; j < corners.size(); ++j) {
    if (!std::isfinite(corners[j].t) || !std::isfinite(corners[j].z)) return std::nullopt;
    if (j > 0 && !(corners[j].t > corners[j - 1].t)) return std::nullopt;
  }
  OcclusionChain chain;
  chain.corners_ = std::move(corners);
  chain.final_slope_ = chain.corners_.empty() ? 0.0 : final_slope;
  return chain;
}

double OcclusionChain::height_at(double t) const {
  assert(!empty());
  // Corners are few (simplified chains hold a handful): a scan is fastest.
  std::size_t j = 0;
  while (j + 1 < corners_.size() && corners_[j + 1].t <= t) ++j;
  const ChainPoint& a = corners_[j];
  if (j + 1 == corners_.size()) return a.z + final_slope_ * (t - a.t);
  const ChainPoint& b = corners_[j + 1];
  return a.z + (b.z - a.z) * ((t - a.t) / (b.t - a.t));
}

bool OcclusionChain::contains(double t, double z) const {
  if (empty() || t < corners_.front().t) return false;
  return z <= height_at(t);
}

namespace {

// The slope of a chain just after corner j.
double slope_after(const std::vector<ChainPoint>& c, std::size_t j, double final_slope) {
  if (j + 1 == c.size()) return final_slope;
  return (c[j + 1].z - c[j].z) / (c[j + 1].t - c[j].t);
}

// Drops corners where the chain does not bend (equal slopes either side,
// to a relative 1e-12) and corners closer than 1e-9 m to the previous.
void drop_straight_corners(std::vector<ChainPoint>& c, double final_slope) {
  std::vector<ChainPoint> kept;
  kept.reserve(c.size());
  for (std::size_t j = 0; j < c.size(); ++j) {
    if (!kept.empty() && c[j].t - kept.back().t <= 1e-9) continue;
    if (!kept.empty()) {
      const double before = (c[j].z - kept.back().z) / (c[j].t - kept.back().t);
      const double after = slope_after(c, j, final_slope);
      if (std::abs(before - after) <= 1e-12 * std::max(1.0, std::abs(before))) continue;
    }
    kept.push_back(c[j]);
  }
  c = std::move(kept);
}

}  // namespace

OcclusionChain OcclusionChain::intersect(const OcclusionChain& a, const OcclusionChain& b) {
  if (a.empty() || b.empty()) return {};
  const double t0 = std::max(a.corners_.front().t, b.corners_.front().t);
  // Where either chain bends past t0; the lower envelope bends there or
  // where the two cross between them.
  std::vector<double> ts{t0};
  for (const auto* chain : {&a, &b})
    for (const ChainPoint& p : chain->corners_)
      if (p.t > t0) ts.push_back(p.t);
  std::sort(ts.begin(), ts.end());
  ts.erase(std::unique(ts.begin(), ts.end()), ts.end());

  OcclusionChain out;
  auto lower = [&](double t) { return ChainPoint{t, std::min(a.height_at(t), b.height_at(t))}; };
  for (std::size_t k = 0; k < ts.size(); ++k) {
    out.corners_.push_back(lower(ts[k]));
    const double gap_here = a.height_at(ts[k]) - b.height_at(ts[k]);
    if (k + 1 < ts.size()) {
      const double gap_next = a.height_at(ts[k + 1]) - b.height_at(ts[k + 1]);
      if ((gap_here < 0 && gap_next > 0) || (gap_here > 0 && gap_next < 0)) {
        const double t = ts[k] + (ts[k + 1] - ts[k]) * (gap_here / (gap_here - gap_next));
        out.corners_.push_back(lower(t));
      }
    } else {
      // Past the last bend both are rays: they may cross once more.
      const double sa = a.final_slope_, sb = b.final_slope_;
      if ((gap_here < 0 && sa > sb) || (gap_here > 0 && sa < sb)) {
        const double t = ts[k] + gap_here / (sb - sa);
        out.corners_.push_back(lower(t));
      }
      out.final_slope_ = std::min(sa, sb);
    }
  }
  drop_straight_corners(out.corners_, out.final_slope_);
  return out;
}

OcclusionChain OcclusionChain::lower_envelope(std::span<const Ray> rays) {
  if (rays.empty()) return {};
  double t0 = -INFINITY;
  for (const Ray& r : rays) t0 = std::max(t0, r.h.t);
  // Each ray's line as its height at t0 and its slope.
  struct Line {
    double z0, slope;
  };
  std::vector<Line> lines;
  lines.reserve(rays.size());
  for (const Ray& r : rays) lines.push_back({r.h.z + r.slope * (t0 - r.h.t), r.slope});
  // Steepest first; of equal slopes only the lowest matters.
  std::sort(lines.begin(), lines.end(), [](const Line& a, const Line& b) {
    return a.slope != b.slope ? a.slope > b.slope : a.z0 < b.z0;
  });
  // The lower envelope for u = t - t0 >= 0: start with the lowest at u = 0
  // (ties: the shallowest), then lines of ever smaller slope take over.
  std::vector<Line> hull;
  std::vector<double> from;  // u where each hull line starts
  for (const Line& l : lines) {
    if (!hull.empty() && l.slope == hull.back().slope) continue;  // a higher line of the same slope
    while (!hull.empty()) {
      const Line& top = hull.back();
      // Where l meets top (l is shallower, so it is lower past it).
      const double u = (l.z0 - top.z0) / (top.slope - l.slope);
      if (u <= from.back()) {
        hull.pop_back();  // top is never the lowest past its start
        from.pop_back();
        continue;
      }
      hull.push_back(l);
      from.push_back(u);
      break;
    }
    if (hull.empty()) {
      hull.push_back(l);
      from.push_back(0.0);
    }
  }
  // At u = 0 the lowest line must start the envelope: pop starts <= 0.
  std::size_t first = 0;
  while (first + 1 < hull.size() && from[first + 1] <= 0.0) ++first;
  OcclusionChain out;
  for (std::size_t j = first; j < hull.size(); ++j) {
    const double u = j == first ? 0.0 : from[j];
    out.corners_.push_back({t0 + u, hull[j].z0 + hull[j].slope * u});
  }
  out.final_slope_ = hull.back().slope;
  drop_straight_corners(out.corners_, out.final_slope_);
  return out;
}

OcclusionChain OcclusionChain::simplified(std::size_t max_corners) const {
  assert(max_corners >= 2);
  OcclusionChain out = *this;
  auto& c = out.corners_;
  while (c.size() > max_corners) {
    // Drop the corner (never the first) whose removal lowers the chain
    // least there: its height above the chord (or above the final ray
    // drawn back from the corner before it, for the last).
    std::size_t best = 1;
    double best_drop = INFINITY;
    for (std::size_t j = 1; j < c.size(); ++j) {
      const ChainPoint& a = c[j - 1];
      const double slope = j + 1 < c.size() ? (c[j + 1].z - a.z) / (c[j + 1].t - a.t) : out.final_slope_;
      const double drop = c[j].z - (a.z + slope * (c[j].t - a.t));
      if (drop < best_drop) best_drop = drop, best = j;
    }
    c.erase(c.begin() + static_cast<std::ptrdiff_t>(best));
  }
  return out;
}

}  // namespace horizon::mesh
