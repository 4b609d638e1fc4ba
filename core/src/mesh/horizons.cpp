// Per-vertex sector horizons: the tree sweep of Edmondson's thesis (§4.5.3,
// after Stewart 1998) and its brute-force reference. See horizons.hpp.
#include "horizon/mesh/horizons.hpp"

#include <algorithm>
#include <bit>
#include <cmath>
#include <numbers>
#include <numeric>
#include <string>
#include <utility>

#include "horizon/common/parallel.hpp"
#include "mesh/upper_hull.hpp"

namespace horizon::mesh {
namespace {

using hull::Planar;
using hull::steeper;
using hull::UpperHull;

// A point as one wedge sees it: its edge coordinates and its projection
// (t, z) onto the wedge's centre plane.
struct Projected {
  double a, b, t, z;
};

void project(std::span<const TinVertex> points, const Wedge& w, std::vector<Projected>& out) {
  out.resize(points.size());
  for (std::size_t i = 0; i < points.size(); ++i) out[i] = {w.a(points[i]), w.b(points[i]), w.t(points[i]), points[i].z};
}

std::vector<Projected> project(std::span<const TinVertex> points, const Wedge& w) {
  std::vector<Projected> out;
  project(points, w, out);
  return out;
}

// A leaf of the tree: a point, its processing rank, and the best answer
// found for it so far (best == kNoHorizon: none yet). 48 bytes, moved at
// every level.
struct Leaf {
  double t, z, best_t, best_z;
  std::uint32_t index, rank, best;

  Planar at() const { return {t, z, index}; }
  Planar best_at() const { return {best_t, best_z, best}; }
};

// Leaves merged bottom-up within blocks of this many before the levels
// above run over the whole array: a block's run and merged copies (48
// bytes a leaf each, 384 KiB) stay in a core's L2 for its lowest levels.
constexpr std::size_t kCacheBlock = 4096;
// The levels below runs of this many leaves are done pair by pair.
constexpr std::size_t kBottom = 4;

// p's best answer with the steepest point of `hull` from it.
[[gnu::always_inline]] inline void answer(Leaf& p, const UpperHull& hull) {
  const Planar here = p.at();
  const Planar* q = hull.steepest(here);
  if (p.best == kNoHorizon || steeper(here, *q, p.best_at())) p.best_t = q->t, p.best_z = q->z, p.best = q->index;
}

// One level: blocks of `width` in run[from, to) merged pairwise by rank
// into merged[from, to), each right block's points asking the hull of the
// left block's points before them.
void merge_level(std::vector<Leaf>& run, std::vector<Leaf>& merged, std::size_t from, std::size_t to,
                 std::size_t width, UpperHull& hull) {
  for (std::size_t lo = from; lo < to; lo += 2 * width) {
    const std::size_t mid = std::min(lo + width, to), hi = std::min(lo + 2 * width, to);
    hull.clear();
    std::size_t i = lo, j = mid, k = lo;
    while (i < mid && j < hi) {
      if (run[i].rank < run[j].rank) {
        hull.insert(run[i].at());  // left block: a candidate for what follows
        merged[k++] = run[i++];
        continue;
      }
      Leaf& p = run[j];  // right block: asks the left block's points before it
      if (hull.size() > 0) answer(p, hull);
      merged[k++] = p;
      ++j;
    }
    // What is left of either block meets nothing more at this node.
    k = static_cast<std::size_t>(std::copy(run.begin() + static_cast<std::ptrdiff_t>(i), run.begin() + static_cast<std::ptrdiff_t>(mid),
                                           merged.begin() + static_cast<std::ptrdiff_t>(k)) - merged.begin());
    while (j < hi) {
      Leaf& p = run[j++];
      if (hull.size() > 0) answer(p, hull);
      merged[k++] = p;
    }
  }
}

// One wedge's horizons for every point, by the sweep over the tree.
//
// The thesis walks the points in processing order, each querying the hulls
// of the tree nodes left of its leaf and inserting itself into those on its
// path. The same pairs meet node by node instead: the points under a left
// child (inserted) and under its right sibling (querying) met in processing
// order, one hull at a time. Each point still meets every node it would
// have, in the same order, so the answers are the same; but a node's hull
// is built and read in one go, in cache, and the tree's levels are the
// passes of a bottom-up merge sort of the leaves by processing rank. The
// lowest levels run block by block (kCacheBlock), the rest over the whole
// array; every node is merged exactly as before, only the nodes' order
// changes, and each node's answers depend on its own points alone.
//
// A sweep's buffers, kept from one wedge to the next (a thread's wedges
// are all of one size): fresh pages would cost a fault each.
struct SweepBuffers {
  explicit SweepBuffers(std::size_t n) : rank(n), best(n), slope(n), run(n), merged(n), hull(n) {}
  std::vector<std::uint32_t> rank, best;
  std::vector<double> slope;
  std::vector<Leaf> run, merged;
  UpperHull hull;
};

void sweep(const std::vector<Projected>& pts, const std::vector<std::uint32_t>& order,
                                        const std::vector<std::uint32_t>& leaves, SweepBuffers& buffers) {
  const std::size_t n = pts.size();
  std::vector<std::uint32_t>& rank = buffers.rank;
  for (std::size_t i = 0; i < n; ++i) rank[order[i]] = static_cast<std::uint32_t>(i);
  std::vector<Leaf>&run = buffers.run, &merged = buffers.merged;
  for (std::size_t i = 0; i < n; ++i) {
    const std::uint32_t v = leaves[i];
    run[i] = {pts[v].t, pts[v].z, 0.0, 0.0, v, rank[v], kNoHorizon};
  }
  // The lowest levels, pair by pair: in a run of kBottom leaves every
  // point is a candidate for each one after it of higher rank (the pairs
  // the nodes within the run would meet), and the run is then sorted by
  // rank, as those levels' merges would leave it.
  for (std::size_t lo = 0; lo < n; lo += kBottom) {
    const std::size_t hi = std::min(lo + kBottom, n);
    for (std::size_t i = lo + 1; i < hi; ++i) {
      Leaf& p = run[i];
      const Planar here = p.at();
      for (std::size_t j = lo; j < i; ++j)
        if (run[j].rank < p.rank && (p.best == kNoHorizon || steeper(here, run[j].at(), p.best_at())))
          p.best_t = run[j].t, p.best_z = run[j].z, p.best = run[j].index;
    }
    for (std::size_t i = lo + 1; i < hi; ++i)
      for (std::size_t j = i; j > lo && run[j - 1].rank > run[j].rank; --j) std::swap(run[j - 1], run[j]);
  }
  UpperHull& hull = buffers.hull;
  std::size_t width = kBottom;
  if (n > kBottom) {
    const std::size_t block = std::min(kCacheBlock, std::bit_ceil(n));
    for (std::size_t from = 0; from < n; from += block) {
      const std::size_t to = std::min(from + block, n);
      bool in_run = true;  // which array holds this block's leaves now
      for (std::size_t w = kBottom; w < block; w *= 2, in_run = !in_run)
        in_run ? merge_level(run, merged, from, to, w, hull) : merge_level(merged, run, from, to, w, hull);
    }
    // Every block ran the same number of levels, so they all end in the same array.
    for (std::size_t w = kBottom; w < block; w *= 2) std::swap(run, merged);
    width = std::max(block, kBottom);
  }
  for (; width < n; width *= 2) {
    merge_level(run, merged, 0, n, width, hull);
    std::swap(run, merged);
  }
  // Each answer and its slope from p in this wedge's plane (what the
  // subsectors compare), written by vertex.
  for (const Leaf& leaf : run) {
    buffers.best[leaf.index] = leaf.best;
    buffers.slope[leaf.index] = leaf.best == kNoHorizon ? 0.0 : (leaf.best_z - leaf.z) / (leaf.best_t - leaf.t);
  }
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

// The vertices ascending by (n · v, index) for edge m's normal n: a stable
// least-significant-digit radix sort (11 bits a pass, passes whose digit
// is the same for every key skipped) of the keys' bits mapped to unsigned
// integers of the same order; the input is in index order, so equal keys
// stay in it. -0.0 is first made +0.0, the two being equal keys.
std::vector<Keyed> sorted_along(std::span<const TinVertex> points, const Wedge& edge_lo) {
  const std::size_t n = points.size();
  constexpr int kBits = 11, kPasses = 6;
  constexpr std::size_t kBuckets = std::size_t{1} << kBits;
  auto digits = [](double key) {  // the key's bits, in the keys' order
    const auto u = std::bit_cast<std::uint64_t>(key + 0.0);
    return u >> 63 ? ~u : u | (std::uint64_t{1} << 63);
  };
  std::vector<Keyed> out(n), other(n);
  std::vector<std::uint32_t> count(kPasses * kBuckets, 0);
  for (std::uint32_t i = 0; i < n; ++i) {
    out[i] = {edge_lo.a(points[i]), i};
    const std::uint64_t d = digits(out[i].key);
    for (int pass = 0; pass < kPasses; ++pass) ++count[pass * kBuckets + ((d >> (pass * kBits)) & (kBuckets - 1))];
  }
  for (int pass = 0; pass < kPasses; ++pass) {
    std::uint32_t* c = count.data() + pass * kBuckets;
    if (n == 0 || c[(digits(out[0].key) >> (pass * kBits)) & (kBuckets - 1)] == n) continue;  // one digit: nothing moves
    std::uint32_t sum = 0;
    for (std::size_t b = 0; b < kBuckets; ++b) sum += std::exchange(c[b], sum);
    for (std::size_t i = 0; i < n; ++i) other[c[(digits(out[i].key) >> (pass * kBits)) & (kBuckets - 1)]++] = out[i];
    out.swap(other);
  }
  return out;
}

// The indices of `sorted` by its key ascending, or descending, each run of
// equal keys put in `tie`'s order.
template <class Tie>
void in_order(const std::vector<Keyed>& sorted, bool descending, Tie tie, std::vector<std::uint32_t>& out) {
  const std::size_t n = sorted.size();
  auto at = [&](std::size_t i) -> const Keyed& { return sorted[descending ? n - 1 - i : i]; };
  out.resize(n);
  for (std::size_t i = 0; i < n; ++i) out[i] = at(i).index;
  for (std::size_t i = 0; i < n;) {
    std::size_t j = i + 1;
    while (j < n && at(j).key == at(i).key) ++j;
    if (j - i > 1) std::sort(out.begin() + static_cast<std::ptrdiff_t>(i), out.begin() + static_cast<std::ptrdiff_t>(j), tie);
    i = j;
  }
}

// Each vertex's lowest subsector horizon of one sector, by that horizon's
// slope in its own subsector's plane; none once any subsector has none.
class LowestOfSubsectors {
 public:
  explicit LowestOfSubsectors(std::size_t n) : chosen_(n, kNoHorizon), lowest_(n, 0.0) {}

  // Subsector j's horizons h and their slopes (z_h - z_v) / (t_h - t_v)
  // in its plane.
  void add(int j, const std::vector<std::uint32_t>& h, const std::vector<double>& slope) {
    for (std::size_t v = 0; v < h.size(); ++v) {
      if (j > 0 && chosen_[v] == kNoHorizon) continue;  // a subsector before had none
      if (h[v] == kNoHorizon) {
        chosen_[v] = kNoHorizon;
        continue;
      }
      if (j == 0 || slope[v] < lowest_[v]) {
        chosen_[v] = h[v];
        lowest_[v] = slope[v];
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
    std::vector<Projected> pts;
    std::vector<std::uint32_t> order, leaves;
    SweepBuffers buffers(points.size());
    for (int opposite = 0; opposite <= (s % 2 == 0 ? 1 : 0); ++opposite) {
      const int i = sector + opposite * s / 2;
      LowestOfSubsectors lowest(points.size());
      for (int j = 0; j < k; ++j) {
        const Wedge w = Wedge::sector(i, s, j, k);
        project(points, w, pts);
        // Processing: decreasing A (ties: increasing B, then index). Leaves:
        // increasing B (ties: decreasing A, then index). Then q is p's
        // candidate exactly when it comes before p in both orders (the test
        // of horizons.hpp). For the opposite sector A and B are the shared
        // keys negated.
        in_order(edges[static_cast<std::size_t>(j)], !opposite, [&](std::uint32_t u, std::uint32_t v) {
          return pts[u].b < pts[v].b || (pts[u].b == pts[v].b && u < v);
        }, order);
        in_order(edges[static_cast<std::size_t>(j) + 1], opposite, [&](std::uint32_t u, std::uint32_t v) {
          return pts[u].a > pts[v].a || (pts[u].a == pts[v].a && u < v);
        }, leaves);
        sweep(pts, order, leaves, buffers);
        lowest.add(j, buffers.best, buffers.slope);
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
      const std::vector<Projected> pts = project(points, w);
      const std::vector<std::uint32_t> h = brute_force(pts);
      std::vector<double> slope(h.size(), 0.0);
      for (std::size_t v = 0; v < h.size(); ++v)
        if (h[v] != kNoHorizon) slope[v] = (pts[h[v]].z - pts[v].z) / (pts[h[v]].t - pts[v].t);
      lowest.add(j, h, slope);
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
