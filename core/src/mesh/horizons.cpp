// Per-vertex sector horizons: the tree sweep of Edmondson's thesis (§4.5.3,
// after Stewart 1998) and its brute-force reference. See horizons.hpp.
#include "horizon/mesh/horizons.hpp"

#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <numeric>
#include <string>

#include "horizon/common/parallel.hpp"

namespace horizon::mesh {
namespace {

using Kernel = CGAL::Exact_predicates_inexact_constructions_kernel;

// A point as one wedge sees it: its edge coordinates and its projection
// (t, z) onto the wedge's centre plane.
struct Projected {
  double a, b, t, z;
};

std::vector<Projected> project(std::span<const TinVertex> points, const Wedge& w) {
  std::vector<Projected> out(points.size());
  for (std::size_t i = 0; i < points.size(); ++i) out[i] = {w.a(points[i]), w.b(points[i]), w.t(points[i]), points[i].z};
  return out;
}

// A point projected on the wedge's centre plane, with its vertex index.
struct Planar {
  double t, z;
  std::uint32_t index;
};

// The orientation of (u, v, w) in the (t, z) plane, exactly: the double
// determinant where Shewchuk's error bound for it ("Adaptive precision
// floating-point arithmetic and fast robust geometric predicates", 1997,
// orient2d's first stage) proves its sign, CGAL's exact predicate where not.
CGAL::Orientation turn(const Planar& u, const Planar& v, const Planar& w) {
  const double left = (u.t - w.t) * (v.z - w.z), right = (u.z - w.z) * (v.t - w.t), det = left - right;
  constexpr double kBound = (3.0 + 16.0 * 0x1p-53) * 0x1p-53;  // Shewchuk's ccwerrboundA
  const double bound = kBound * (std::fabs(left) + std::fabs(right));
  if (det > bound) return CGAL::LEFT_TURN;
  if (-det > bound) return CGAL::RIGHT_TURN;
  return CGAL::orientation(Kernel::Point_2(u.t, u.z), Kernel::Point_2(v.t, v.z), Kernel::Point_2(w.t, w.z));
}

// Whether q1 is a better horizon for p than q2: the steeper from p
// (exactly), then the nearer (smaller t), then the smaller index. Both have
// t > p's t.
bool steeper(const Planar& p, const Planar& q1, const Planar& q2) {
  switch (turn(p, q2, q1)) {
    case CGAL::LEFT_TURN:  // q1 above the line from p through q2
      return true;
    case CGAL::RIGHT_TURN:
      return false;
    default:
      return q1.t < q2.t || (q1.t == q2.t && q1.index < q2.index);
  }
}

// The upper convex hull of the points inserted into one tree node, sorted by
// t, holding only the points that can be some query's answer: extreme
// points; of equal t the highest (then the smaller index); none strictly
// inside a hull edge. The points are held by value: a query's binary search
// reads one contiguous array.
class UpperHull {
 public:
  void clear() { h_.clear(); }

  void insert(const Planar& q) {
    auto at = std::lower_bound(h_.begin(), h_.end(), q.t, [](const Planar& u, double t) { return u.t < t; });
    if (at != h_.end() && at->t == q.t) {
      if (at->z > q.z || (at->z == q.z && at->index < q.index)) return;  // q is never the better answer
      at = h_.erase(at);
    }
    // Below or on the hull between its neighbours: never the unique answer.
    if (at != h_.begin() && at != h_.end() && turn(*(at - 1), *at, q) != CGAL::LEFT_TURN) return;
    at = h_.insert(at, q);
    // Neighbours no longer extreme: on or under the new edges.
    auto left = at;
    while (left - h_.begin() >= 2 && turn(*(left - 2), *(left - 1), q) != CGAL::RIGHT_TURN) left = h_.erase(left - 1);
    auto right = left + 1;
    while (h_.end() - right >= 2 && turn(q, *right, *(right + 1)) != CGAL::RIGHT_TURN) right = h_.erase(right);
  }

  // The steepest point of the hull from p (null when empty): slopes from a
  // point left of the hull rise, then fall, along it.
  const Planar* steepest(const Planar& p) const {
    if (h_.empty()) return nullptr;
    std::size_t lo = 0, hi = h_.size() - 1;
    while (lo < hi) {
      const std::size_t mid = (lo + hi) / 2;
      if (steeper(p, h_[mid + 1], h_[mid]))
        lo = mid + 1;
      else
        hi = mid;
    }
    return &h_[lo];
  }

 private:
  std::vector<Planar> h_;
};

// One wedge's horizons for every point, by the sweep over the tree.
//
// The thesis walks the points in processing order, each querying the hulls
// of the tree nodes left of its leaf and inserting itself into those on its
// path. The same pairs meet node by node instead: the points under a left
// child (inserted) and under its right sibling (querying) met in processing
// order, one hull at a time. Each point still meets every node it would
// have, in the same order, so the answers are the same; but a node's hull
// is built and read in one go, in cache, and the tree's levels are the
// passes of a bottom-up merge sort of the leaves by processing rank.
std::vector<std::uint32_t> sweep(const std::vector<Projected>& pts, const std::vector<std::uint32_t>& order,
                                 const std::vector<std::uint32_t>& leaves) {
  const std::size_t n = pts.size();
  std::vector<std::uint32_t> rank(n);
  for (std::size_t i = 0; i < n; ++i) rank[order[i]] = static_cast<std::uint32_t>(i);
  // `run` holds the leaves, each block of `width` sorted by processing rank;
  // each carries its best answer so far, so the merge reads only in order.
  struct Leaf {
    Planar at, best;  // best.index == kNoHorizon: none yet
    std::uint32_t rank;
  };
  std::vector<Leaf> run(n), merged(n);
  for (std::size_t i = 0; i < n; ++i) {
    const std::uint32_t v = leaves[i];
    run[i] = {{pts[v].t, pts[v].z, v}, {0.0, 0.0, kNoHorizon}, rank[v]};
  }
  UpperHull hull;
  for (std::size_t width = 1; width < n; width *= 2) {
    for (std::size_t lo = 0; lo < n; lo += 2 * width) {
      const std::size_t mid = std::min(lo + width, n), hi = std::min(lo + 2 * width, n);
      hull.clear();
      std::size_t i = lo, j = mid, k = lo;
      while (i < mid || j < hi) {
        if (j >= hi || (i < mid && run[i].rank < run[j].rank)) {
          hull.insert(run[i].at);  // left block: a candidate for what follows
          merged[k++] = run[i++];
          continue;
        }
        Leaf& p = run[j];  // right block: asks the left block's points before it
        if (const Planar* q = hull.steepest(p.at); q && (p.best.index == kNoHorizon || steeper(p.at, *q, p.best)))
          p.best = *q;
        merged[k++] = run[j++];
      }
    }
    std::swap(run, merged);
  }
  std::vector<std::uint32_t> best(n);
  for (const Leaf& leaf : run) best[leaf.at.index] = leaf.best.index;
  return best;
}

std::vector<std::uint32_t> brute_force(const std::vector<Projected>& pts) {
  const std::size_t n = pts.size();
  std::vector<std::uint32_t> horizon(n, kNoHorizon);
  auto planar = [&](std::uint32_t i) { return Planar{pts[i].t, pts[i].z, i}; };
  for (std::uint32_t p = 0; p < n; ++p)
    for (std::uint32_t q = 0; q < n; ++q) {
      const Projected &a = pts[p], &b = pts[q];
      // Wedge::contains on the same doubles; two points whose A and B both
      // round equal are ordered by index, as the sweep orders them.
      const bool in = b.a >= a.a && b.b <= a.b && (b.a != a.a || b.b != a.b || q < p) && q != p;
      if (in && (horizon[p] == kNoHorizon || steeper(planar(p), planar(q), planar(horizon[p])))) horizon[p] = q;
    }
  return horizon;
}

Status check_options(std::span<const TinVertex> points, const HorizonOptions& o) {
  if (o.sectors < 3 || o.sectors > 256)
    return make_error(ErrorCode::kInvalidArgument,
                      "sectors is " + std::to_string(o.sectors) + "; it must be 3 to 256 (a wedge narrower than π)",
                      "sectors");
  if (o.subsectors < 1 || o.subsectors > 64 || o.sectors * o.subsectors > 1024)
    return make_error(ErrorCode::kInvalidArgument,
                      "subsectors is " + std::to_string(o.subsectors) + "; it must be 1 to 64, and sectors x subsectors "
                      "at most 1024 (here " + std::to_string(o.sectors * o.subsectors) + ")",
                      "subsectors");
  if (points.size() >= kNoHorizon)
    return make_error(ErrorCode::kResourceExhausted, "too many vertices for 32-bit indices", "mesh");
  return Status::Ok();
}

// A vertex keyed for sorting by its dot product with one edge's normal.
struct Keyed {
  double key;
  std::uint32_t index;
};

// The vertices ascending by (n · v, index) for edge m's normal n.
std::vector<Keyed> sorted_along(std::span<const TinVertex> points, const Wedge& edge_lo) {
  std::vector<Keyed> out(points.size());
  for (std::uint32_t i = 0; i < points.size(); ++i) out[i] = {edge_lo.a(points[i]), i};
  std::sort(out.begin(), out.end(),
            [](const Keyed& u, const Keyed& v) { return u.key < v.key || (u.key == v.key && u.index < v.index); });
  return out;
}

// The indices of `sorted` by its key ascending, or descending, each run of
// equal keys put in `tie`'s order.
template <class Tie>
std::vector<std::uint32_t> in_order(const std::vector<Keyed>& sorted, bool descending, Tie tie) {
  const std::size_t n = sorted.size();
  auto at = [&](std::size_t i) -> const Keyed& { return sorted[descending ? n - 1 - i : i]; };
  std::vector<std::uint32_t> out(n);
  for (std::size_t i = 0; i < n; ++i) out[i] = at(i).index;
  for (std::size_t i = 0; i < n;) {
    std::size_t j = i + 1;
    while (j < n && at(j).key == at(i).key) ++j;
    if (j - i > 1) std::sort(out.begin() + static_cast<std::ptrdiff_t>(i), out.begin() + static_cast<std::ptrdiff_t>(j), tie);
    i = j;
  }
  return out;
}

// Each vertex's lowest subsector horizon of one sector, by that horizon's
// slope in its own subsector's plane; none once any subsector has none.
class LowestOfSubsectors {
 public:
  explicit LowestOfSubsectors(std::size_t n) : chosen_(n, kNoHorizon), lowest_(n, 0.0) {}

  void add(std::span<const TinVertex> points, int j, const Wedge& w, const std::vector<std::uint32_t>& h) {
    for (std::size_t v = 0; v < h.size(); ++v) {
      if (j > 0 && chosen_[v] == kNoHorizon) continue;  // a subsector before had none
      if (h[v] == kNoHorizon) {
        chosen_[v] = kNoHorizon;
        continue;
      }
      const double slope = (points[h[v]].z - points[v].z) / (w.t(points[h[v]]) - w.t(points[v]));
      if (j == 0 || slope < lowest_[v]) {
        chosen_[v] = h[v];
        lowest_[v] = slope;
      }
    }
  }

  void store(int sector, VertexHorizons& out) const {
    for (std::size_t v = 0; v < chosen_.size(); ++v)
      out.horizon[v * static_cast<std::size_t>(out.sectors) + static_cast<std::size_t>(sector)] = chosen_[v];
  }

 private:
  std::vector<std::uint32_t> chosen_;
  std::vector<double> lowest_;
};

Result<VertexHorizons> prepared(std::span<const TinVertex> points, const HorizonOptions& o) {
  HORIZON_RETURN_IF_ERROR(check_options(points, o));
  VertexHorizons out;
  out.sectors = o.sectors;
  out.horizon.assign(points.size() * static_cast<std::size_t>(o.sectors), kNoHorizon);
  return out;
}

}  // namespace

Result<VertexHorizons> compute_horizons(std::span<const TinVertex> points, const HorizonOptions& options,
                                        const RunControl* control) {
  auto out = prepared(points, options);
  if (!out.ok()) return out;
  const int s = options.sectors, k = options.subsectors;
  // Sector i and its opposite i + s/2 (s even) share their edges' sorts: the
  // opposite edge's normal is the exact negation (Wedge::sector), so its
  // order is this one reversed, ties apart. k + 1 sorts serve 2k wedges.
  const int groups = s % 2 == 0 ? s / 2 : s;
  HORIZON_RETURN_IF_ERROR(parallel_for(static_cast<std::size_t>(groups), options.threads, control, [&](std::size_t g) {
    const int sector = static_cast<int>(g);
    std::vector<std::vector<Keyed>> edges;  // edge j of the sector: its lo edge of subsector j
    for (int j = 0; j <= k; ++j)
      edges.push_back(sorted_along(points, j < k ? Wedge::sector(sector, s, j, k) : Wedge::sector(sector + 1, s, 0, k)));
    for (int opposite = 0; opposite <= (s % 2 == 0 ? 1 : 0); ++opposite) {
      const int i = sector + opposite * s / 2;
      LowestOfSubsectors lowest(points.size());
      for (int j = 0; j < k; ++j) {
        const Wedge w = Wedge::sector(i, s, j, k);
        const std::vector<Projected> pts = project(points, w);
        // Processing: decreasing A (ties: increasing B, then index). Leaves:
        // increasing B (ties: decreasing A, then index). Then q is p's
        // candidate exactly when it comes before p in both orders (the test
        // of horizons.hpp). For the opposite sector A and B are the shared
        // keys negated.
        const auto order = in_order(edges[static_cast<std::size_t>(j)], !opposite, [&](std::uint32_t u, std::uint32_t v) {
          return pts[u].b < pts[v].b || (pts[u].b == pts[v].b && u < v);
        });
        const auto leaves = in_order(edges[static_cast<std::size_t>(j) + 1], opposite, [&](std::uint32_t u, std::uint32_t v) {
          return pts[u].a > pts[v].a || (pts[u].a == pts[v].a && u < v);
        });
        lowest.add(points, j, w, sweep(pts, order, leaves));
      }
      lowest.store(i, *out);
    }
  }));
  return out;
}

Result<VertexHorizons> brute_force_horizons(std::span<const TinVertex> points, const HorizonOptions& options) {
  auto out = prepared(points, options);
  if (!out.ok()) return out;
  const int s = options.sectors, k = options.subsectors;
  parallel_for(static_cast<std::size_t>(s), options.threads, [&](std::size_t i) {
    LowestOfSubsectors lowest(points.size());
    for (int j = 0; j < k; ++j) {
      const Wedge w = Wedge::sector(static_cast<int>(i), s, j, k);
      lowest.add(points, j, w, brute_force(project(points, w)));
    }
    lowest.store(static_cast<int>(i), *out);
  });
  return out;
}

namespace {

// The normal (-sin, cos) of edge m of n (angle 2πm/n), edge n being edge 0
// and, for even n, edge m + n/2 exactly edge m's negation: opposite wedges
// then see one order reversed, and the last wedge closes on the first.
std::pair<double, double> edge_normal(int m, int n) {
  m %= n;
  if (n % 2 == 0 && m >= n / 2) {
    const auto [x, y] = edge_normal(m - n / 2, n);
    return {-x, -y};
  }
  const double angle = 2.0 * std::numbers::pi * m / n;
  return {-std::sin(angle), std::cos(angle)};
}

}  // namespace

Wedge Wedge::sector(int index, int count, int sub, int subs) {
  const int n = count * subs, m = index * subs + sub;
  const auto [ax, ay] = edge_normal(m, n);
  const auto [bx, by] = edge_normal(m + 1, n);
  const double mid = 2.0 * std::numbers::pi * (m + 0.5) / n;
  return {ax, ay, bx, by, std::cos(mid), std::sin(mid)};
}

}  // namespace horizon::mesh
