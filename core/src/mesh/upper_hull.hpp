// mesh/upper_hull.hpp (private) — the exact slope predicate of the horizon
// sweep and the upper convex hull it queries (horizons.hpp, "Cost").
//
// Points are projections (t, z) onto one wedge's centre plane. Every
// decision is exact: turn() is the orientation of three points, its double
// determinant trusted only where Shewchuk's error bound proves the sign
// ("Adaptive precision floating-point arithmetic and fast robust geometric
// predicates", 1997, orient2d's first stage), CGAL's exact predicate
// deciding the rest. So the sweep and the brute force agree vertex for
// vertex, ties included.
#pragma once

#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <vector>

namespace horizon::mesh::hull {

// A point projected on the wedge's centre plane, with its vertex index.
struct Planar {
  double t, z;
  std::uint32_t index;
};

// Shewchuk's ccwerrboundA: |det| above it times the terms' magnitudes
// proves det's sign.
inline constexpr double kOrientBound = (3.0 + 16.0 * 0x1p-53) * 0x1p-53;

// The exact orientation where the filter could not decide (rare: ties and
// near-ties), out of line to keep the hot loops small.
[[gnu::noinline, gnu::cold]] inline CGAL::Orientation exact_turn(const Planar& u, const Planar& v, const Planar& w) {
  using Point = CGAL::Exact_predicates_inexact_constructions_kernel::Point_2;
  return CGAL::orientation(Point(u.t, u.z), Point(v.t, v.z), Point(w.t, w.z));
}

// The orientation of (u, v, w) in the (t, z) plane, exactly.
[[gnu::always_inline]] inline CGAL::Orientation turn(const Planar& u, const Planar& v, const Planar& w) {
  const double left = (u.t - w.t) * (v.z - w.z), right = (u.z - w.z) * (v.t - w.t), det = left - right;
  const double bound = kOrientBound * (std::fabs(left) + std::fabs(right));
  if (det > bound) return CGAL::LEFT_TURN;
  if (-det > bound) return CGAL::RIGHT_TURN;
  return exact_turn(u, v, w);
}

// Whether q1 is a better horizon for p than q2: the steeper from p
// (exactly), then the nearer (smaller t), then the smaller index. Both have
// t > p's t.
[[gnu::always_inline]] inline bool steeper(const Planar& p, const Planar& q1, const Planar& q2) {
  switch (turn(p, q2, q1)) {
    case CGAL::LEFT_TURN:  // q1 above the line from p through q2
      return true;
    case CGAL::RIGHT_TURN:
      return false;
    default:
      return q1.t < q2.t || (q1.t == q2.t && q1.index < q2.index);
  }
}

// The upper convex hull of the points inserted so far, holding only the
// points that can be some query's answer: extreme points; of equal t the
// highest (then the smaller index); none strictly inside a hull edge.
//
// It is kept by value in one array, by DEcreasing t: the sweep inserts
// its points roughly in that order (by decreasing A, and t grows with
// A - B while a node's points span a narrow band of B), so most insertions
// land at the array's end and cost what a step of Andrew's monotone chain
// costs, not a move of the whole array.
class UpperHull {
 public:
  // Room for `capacity` points: no hull holds more than the points
  // inserted into it, and no insertion allocates.
  explicit UpperHull(std::size_t capacity) : h_(std::max<std::size_t>(capacity, 1)) {}

  void clear() { m_ = 0; }
  std::size_t size() const { return m_; }

  [[gnu::always_inline]] void insert(const Planar& q) {
    // The usual case: q left of every point (smaller t). It is then
    // extreme, and the points it hides are at the array's end.
    if (m_ == 0 || q.t < h_[m_ - 1].t) {
      std::size_t m = m_;
      while (m >= 2 && turn(q, h_[m - 1], h_[m - 2]) != CGAL::RIGHT_TURN) --m;
      h_[m] = q;
      m_ = m + 1;
      return;
    }
    insert_inside(q);
  }

  // The steepest point of the hull from p (null when empty); every hull
  // point lies right of p (larger t). Slopes from p rise, then fall, along
  // the hull by ascending t; in storage order (descending t) the answer is
  // the last point s whose successor s - 1 is not steeper, i.e. the count
  // of s in [1, m) with turn(p, h_[s], h_[s - 1]) not a left turn.
  //
  // The search runs without branches on the filtered determinant (its
  // mispredictions cost more than its arithmetic), on a short hull as a
  // count over all its edges; were any of its signs unproven it is run
  // again with the exact predicate.
  const Planar* steepest(const Planar& p) const {
    const std::size_t m = m_;
    if (m <= 1) return m ? &h_[0] : nullptr;
    const Planar* h = h_.data();
    std::size_t base = 0, n = m - 1;
    bool unsure = false;
    // not_left(j): turn(p, h[j + 1], h[j]) is not a left turn; true for a
    // prefix of j in [0, n).
    auto not_left = [&](std::size_t j) {
      const Planar &v = h[j + 1], &w = h[j];
      const double left = (p.t - w.t) * (v.z - w.z), right = (p.z - w.z) * (v.t - w.t), det = left - right;
      unsure |= std::fabs(det) <= kOrientBound * (std::fabs(left) + std::fabs(right));
      return !(det > 0);
    };
    if (n <= kLinear) {
      // Short hulls (the usual ones): every pair at once, no chain of
      // dependent loads; the prefix's length is the count.
      for (std::size_t j = 0; j < n; ++j) base += not_left(j) ? 1 : 0;
    } else {
      while (n > 1) {
        const std::size_t half = n / 2;
        base = not_left(base + half) ? base + half : base;
        n -= half;
      }
      base += not_left(base) ? 1 : 0;
    }
    if (!unsure) return &h[base];
    // The exact search, branching.
    std::size_t lo = 0, hi = m - 1;
    while (lo < hi) {
      const std::size_t mid = (lo + hi) / 2;
      if (turn(p, h[mid + 1], h[mid]) != CGAL::LEFT_TURN)
        lo = mid + 1;
      else
        hi = mid;
    }
    return &h[lo];
  }

 private:
  // Hulls of up to this many edges are searched by testing every edge.
  static constexpr std::size_t kLinear = 8;

  // q with some point of t no greater: found by binary search.
  [[gnu::noinline]] void insert_inside(const Planar& q) {
    Planar* const h = h_.data();
    std::size_t m = m_;
    // Below (ascending) counts the points of smaller t: q's place is
    // storage index m - below, after those of larger t.
    Planar* const first_below = std::lower_bound(h, h + m, q.t, [](const Planar& u, double t) { return u.t >= t; });
    const std::size_t below = static_cast<std::size_t>(h + m - first_below);
    if (first_below != h && (first_below - 1)->t == q.t) {  // a point of equal t
      const Planar& same = *(first_below - 1);
      if (same.z > q.z || (same.z == q.z && same.index < q.index)) return;  // q is never the better answer
      std::copy(first_below, h + m, first_below - 1);
      m_ = --m;
    }
    // Ascending view: a(i) = h[m - 1 - i]; q goes between a(below - 1)
    // and a(below). Below or on the hull between them: never the unique
    // answer.
    auto a = [&](std::size_t i) -> const Planar& { return h[m - 1 - i]; };
    if (below > 0 && below < m && turn(a(below - 1), a(below), q) != CGAL::LEFT_TURN) return;
    // Neighbours no longer extreme (on or under q's new edges) are the
    // ascending run [lo, hi): a(below - 1), a(below - 2), ... to the left,
    // a(below), a(below + 1), ... to the right.
    std::size_t lo = below, hi = below;
    while (lo >= 2 && turn(a(lo - 2), a(lo - 1), q) != CGAL::RIGHT_TURN) --lo;
    while (m - hi >= 2 && turn(q, a(hi), a(hi + 1)) != CGAL::RIGHT_TURN) ++hi;
    // That run is storage [m - hi, m - lo); q takes its place, the points
    // of smaller t after it moving to close the gap or open one.
    Planar* const at = h + (m - hi);
    Planar* const rest = h + (m - lo);  // the first point kept after the run
    Planar* const end = h + m;
    if (hi == lo)
      std::copy_backward(at, end, end + 1);
    else
      std::copy(rest, end, at + 1);
    *at = q;
    m_ = m + 1 - (hi - lo);
  }

  std::vector<Planar> h_;
  std::size_t m_ = 0;
};

}  // namespace horizon::mesh::hull
