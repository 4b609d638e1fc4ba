#include "horizon/mesh/tin.hpp"

#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <utility>

namespace horizon::mesh {
namespace {

using Kernel = CGAL::Exact_predicates_inexact_constructions_kernel;
using Point = Kernel::Point_2;

Point xy(const TinVertex& v) { return {v.x, v.y}; }

std::string number(double v) {
  char text[32];
  std::snprintf(text, sizeof text, "%.9g", v);
  return text;
}

std::string named(const Tin& tin, std::size_t t) {
  const TinTriangle& c = tin.triangles[t];
  return "triangle " + std::to_string(t) + " (vertices " + std::to_string(c[0]) + ", " + std::to_string(c[1]) + ", " +
         std::to_string(c[2]) + ")";
}

Error invalid(const std::string& label, const std::string& what) {
  return make_error(ErrorCode::kInvalidArgument, label + ": " + what, "mesh");
}

// Whether every corner of `b` lies on or to the right of one of `a`'s
// (counter-clockwise) edges: a line through that edge then separates them.
bool separated_by_an_edge_of(const Tin& tin, const TinTriangle& a, const TinTriangle& b) {
  for (int e = 0; e < 3; ++e) {
    const Point p = xy(tin.vertices[a[e]]), q = xy(tin.vertices[a[(e + 1) % 3]]);
    bool all_outside = true;
    for (std::uint32_t v : b)
      if (CGAL::orientation(p, q, xy(tin.vertices[v])) == CGAL::LEFT_TURN) {
        all_outside = false;
        break;
      }
    if (all_outside) return true;
  }
  return false;
}

// Two convex polygons' interiors are disjoint exactly when a line through
// an edge of one of them separates them (the separating axis theorem).
bool overlap(const Tin& tin, const TinTriangle& a, const TinTriangle& b) {
  return !separated_by_an_edge_of(tin, a, b) && !separated_by_an_edge_of(tin, b, a);
}

Status check_vertices(const Tin& tin, const std::string& label) {
  for (std::size_t i = 0; i < tin.vertices.size(); ++i) {
    const TinVertex& v = tin.vertices[i];
    if (!std::isfinite(v.x) || !std::isfinite(v.y) || !std::isfinite(v.z))
      return invalid(label, "vertex " + std::to_string(i) + " has a coordinate that is not a finite number (x " +
                                number(v.x) + ", y " + number(v.y) + ", z " + number(v.z) + ")");
  }
  std::vector<std::uint32_t> order(tin.vertices.size());
  for (std::size_t i = 0; i < order.size(); ++i) order[i] = static_cast<std::uint32_t>(i);
  auto key = [&](std::uint32_t i) { return std::pair(tin.vertices[i].x, tin.vertices[i].y); };
  std::sort(order.begin(), order.end(), [&](std::uint32_t a, std::uint32_t b) {
    return key(a) < key(b) || (key(a) == key(b) && a < b);
  });
  for (std::size_t i = 1; i < order.size(); ++i)
    if (key(order[i - 1]) == key(order[i])) {
      const TinVertex& v = tin.vertices[order[i]];
      return invalid(label, "vertices " + std::to_string(order[i - 1]) + " and " + std::to_string(order[i]) +
                                " are both at (x, y) = (" + number(v.x) + ", " + number(v.y) +
                                "): a height field has one height at each place");
    }
  return Status::Ok();
}

Status check_triangles(Tin& tin, const std::string& label) {
  std::vector<bool> used(tin.vertices.size(), false);
  for (std::size_t t = 0; t < tin.triangles.size(); ++t) {
    TinTriangle& c = tin.triangles[t];
    for (std::uint32_t v : c)
      if (v >= tin.vertices.size())
        return invalid(label, "triangle " + std::to_string(t) + " names vertex " + std::to_string(v) + ", but there are " +
                                  std::to_string(tin.vertices.size()) + " vertices");
    if (c[0] == c[1] || c[1] == c[2] || c[0] == c[2])
      return invalid(label, named(tin, t) + " names one vertex twice");
    switch (CGAL::orientation(xy(tin.vertices[c[0]]), xy(tin.vertices[c[1]]), xy(tin.vertices[c[2]]))) {
      case CGAL::COLLINEAR:
        return invalid(label, named(tin, t) + " has no area seen from above: its corners lie on one line");
      case CGAL::CLOCKWISE:
        std::swap(c[1], c[2]);
        break;
      default:
        break;
    }
    for (std::uint32_t v : c) used[v] = true;
  }
  for (std::size_t v = 0; v < used.size(); ++v)
    if (!used[v]) return invalid(label, "vertex " + std::to_string(v) + " belongs to no triangle");
  return Status::Ok();
}

// Each edge of at most two triangles, which lie on its two sides.
Status check_edges(const Tin& tin, const std::string& label) {
  struct Edge {
    std::uint32_t lo, hi, triangle;
    bool forward;  // the triangle runs lo -> hi
  };
  std::vector<Edge> edges;
  edges.reserve(tin.triangles.size() * 3);
  for (std::size_t t = 0; t < tin.triangles.size(); ++t)
    for (int e = 0; e < 3; ++e) {
      const std::uint32_t a = tin.triangles[t][e], b = tin.triangles[t][(e + 1) % 3];
      edges.push_back({std::min(a, b), std::max(a, b), static_cast<std::uint32_t>(t), a < b});
    }
  std::sort(edges.begin(), edges.end(), [](const Edge& a, const Edge& b) {
    return std::tie(a.lo, a.hi, a.triangle) < std::tie(b.lo, b.hi, b.triangle);
  });
  for (std::size_t i = 0; i < edges.size();) {
    std::size_t j = i;
    while (j < edges.size() && edges[j].lo == edges[i].lo && edges[j].hi == edges[i].hi) ++j;
    const std::string edge = "the edge between vertices " + std::to_string(edges[i].lo) + " and " +
                             std::to_string(edges[i].hi);
    if (j - i > 2) {
      std::string which;
      for (std::size_t k = i; k < j; ++k) which += (k > i ? ", " : "") + std::to_string(edges[k].triangle);
      return invalid(label, edge + " belongs to " + std::to_string(j - i) + " triangles (" + which +
                                "): a height field's edge joins two at most");
    }
    if (j - i == 2 && edges[i].forward == edges[i + 1].forward)
      return invalid(label, named(tin, edges[i].triangle) + " and " + named(tin, edges[i + 1].triangle) +
                                " lie on the same side of " + edge + ": they overlap seen from above (a fold)");
    i = j;
  }
  return Status::Ok();
}

constexpr std::uint64_t kMaxOverlapPairs = 64'000'000;

// Triangles that do not share an edge: bucketed by their bounding boxes on
// a grid of about one triangle per bucket, each pair in a bucket tested.
Status check_overlaps(const Tin& tin, const std::string& label) {
  double x0 = INFINITY, y0 = INFINITY, x1 = -INFINITY, y1 = -INFINITY;
  for (const TinVertex& v : tin.vertices) {
    x0 = std::min(x0, v.x), y0 = std::min(y0, v.y), x1 = std::max(x1, v.x), y1 = std::max(y1, v.y);
  }
  const std::size_t n = tin.triangles.size();
  const int side = std::clamp(static_cast<int>(std::sqrt(static_cast<double>(n))), 1, 4096);
  const double sx = (x1 - x0) / side, sy = (y1 - y0) / side;
  auto bucket = [&](double v, double lo, double size) {
    return size > 0.0 ? std::clamp(static_cast<int>((v - lo) / size), 0, side - 1) : 0;
  };
  std::vector<std::vector<std::uint32_t>> buckets(static_cast<std::size_t>(side) * static_cast<std::size_t>(side));
  for (std::size_t t = 0; t < n; ++t) {
    double tx0 = INFINITY, ty0 = INFINITY, tx1 = -INFINITY, ty1 = -INFINITY;
    for (std::uint32_t v : tin.triangles[t]) {
      const TinVertex& p = tin.vertices[v];
      tx0 = std::min(tx0, p.x), ty0 = std::min(ty0, p.y), tx1 = std::max(tx1, p.x), ty1 = std::max(ty1, p.y);
    }
    for (int by = bucket(ty0, y0, sy); by <= bucket(ty1, y0, sy); ++by)
      for (int bx = bucket(tx0, x0, sx); bx <= bucket(tx1, x0, sx); ++bx)
        buckets[static_cast<std::size_t>(by) * static_cast<std::size_t>(side) + static_cast<std::size_t>(bx)]
            .push_back(static_cast<std::uint32_t>(t));
  }
  // Bounded before the pairs are made: a mesh whose triangles crowd into a
  // few buckets (sizes many orders apart) would make the test quadratic.
  std::uint64_t candidates = 0;
  for (const auto& b : buckets) candidates += b.size() * (b.size() - (b.empty() ? 0 : 1)) / 2;
  if (candidates > kMaxOverlapPairs)
    return make_error(ErrorCode::kResourceExhausted,
                      label + ": checking that its triangles do not overlap would take " + std::to_string(candidates) +
                          " triangle pairs (at most " + std::to_string(kMaxOverlapPairs) +
                          "): its triangles are too uneven in size; split the mesh into pieces",
                      "mesh");
  std::vector<std::pair<std::uint32_t, std::uint32_t>> pairs;
  pairs.reserve(candidates);
  for (const auto& b : buckets)
    for (std::size_t i = 0; i < b.size(); ++i)
      for (std::size_t j = i + 1; j < b.size(); ++j) pairs.emplace_back(b[i], b[j]);
  std::sort(pairs.begin(), pairs.end());
  pairs.erase(std::unique(pairs.begin(), pairs.end()), pairs.end());
  for (const auto& [a, b] : pairs) {
    const TinTriangle &ta = tin.triangles[a], &tb = tin.triangles[b];
    int shared = 0;
    for (std::uint32_t u : ta) shared += static_cast<int>(std::count(tb.begin(), tb.end(), u));
    if (shared >= 2) continue;  // an edge's two sides: check_edges judged them
    if (overlap(tin, ta, tb))
      return invalid(label, named(tin, a) + " and " + named(tin, b) + " overlap seen from above");
  }
  return Status::Ok();
}

}  // namespace

double signed_area(const Tin& tin, const TinTriangle& t) {
  const TinVertex &a = tin.vertices[t[0]], &b = tin.vertices[t[1]], &c = tin.vertices[t[2]];
  return 0.5 * ((b.x - a.x) * (c.y - a.y) - (c.x - a.x) * (b.y - a.y));
}

Status check_height_field(Tin& tin, const std::string& label) {
  if (tin.triangles.empty()) return invalid(label, "the mesh has no triangle");
  HORIZON_RETURN_IF_ERROR(check_vertices(tin, label));
  HORIZON_RETURN_IF_ERROR(check_triangles(tin, label));
  HORIZON_RETURN_IF_ERROR(check_edges(tin, label));
  return check_overlaps(tin, label);
}

}  // namespace horizon::mesh
