// seed_fuzzy.cpp — WO 93/00650's fuzzy projection on DEM triangles
// (seed_fuzzy.hpp): patches, front-facing sub-surfaces, boundary extents,
// the umbra from one viewpoint, farthest depths, and the item test.
#include "horizon/evaluation/seed_fuzzy.hpp"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <limits>
#include <numeric>
#include <string>
#include <vector>

namespace horizon::evaluation {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kSpanA = 2.0, kSpanB = 1.0;  // a in [-2, 2], b in [-1, 1]
// Patches are lowered by this much (metres): a sight line below a lowered
// patch is this far below R3's terrain at a crossing, more than R3's
// float32 answer can round (half an ulp is 0.49 mm at 8 848 m).
constexpr double kLowering = 0.002;

struct Point3 {
  double p = 0.0, l = 0.0, z = 0.0;  // face axis, lateral, up; metres
};

// One face's frame: metric (x east, y south as rows run) to (p, l).
struct FaceFrame {
  double sp = 1.0;  // p = sp * (x or y)
  bool along_x = true;
  Point3 at(double x, double y, double z) const { return along_x ? Point3{sp * x, y, z} : Point3{sp * y, x, z}; }
};

struct Extent {
  double a0 = kInf, a1 = -kInf, b0 = kInf, b1 = -kInf;
  void add(double a, double b) {
    a0 = std::min(a0, a);
    a1 = std::max(a1, a);
    b0 = std::min(b0, b);
    b1 = std::max(b1, b);
  }
};

// Elements [i0, i1] x [j0, j1] of an array (possibly outside it).
struct Rect {
  long i0 = 0, i1 = -1, j0 = 0, j1 = -1;
};

// The fuzzy array of one face and its element arithmetic.
struct Array {
  int columns = 0, rows = 0;
  double wa = 0.0, wb = 0.0;
  std::vector<std::int32_t> id;    // sub-surface (a triangle index, its root) or -1
  std::vector<float> depth;        // p of the nearest patch through the centre, from v0
  std::vector<std::uint8_t> mask;  // 1: in some boundary edge's extent
  std::vector<double> far;         // D(e): the farthest p the element's sub-surface reaches in it

  void reset(int c, int r) {
    columns = c;
    rows = r;
    wa = 2.0 * kSpanA / c;
    wb = 2.0 * kSpanB / r;
    const std::size_t n = static_cast<std::size_t>(c) * static_cast<std::size_t>(r);
    id.assign(n, -1);
    depth.assign(n, std::numeric_limits<float>::infinity());
    mask.assign(n, 0);
    far.assign(n, -kInf);
  }
  std::size_t at(int i, int j) const { return static_cast<std::size_t>(j) * static_cast<std::size_t>(columns) + i; }
  // The elements holding an extent, snapped outward (a value on a grid
  // line takes both neighbours); unclipped.
  Rect rect_of(const Extent& e) const {
    const auto lo = [](double v, double span, double w) {
      return static_cast<long>(std::floor((v + span) / w - 1e-9));
    };
    const auto hi = [](double v, double span, double w) {
      return static_cast<long>(std::floor((v + span) / w + 1e-9));
    };
    return {lo(e.a0, kSpanA, wa), hi(e.a1, kSpanA, wa), lo(e.b0, kSpanB, wb), hi(e.b1, kSpanB, wb)};
  }
  bool holds(const Rect& r) const { return r.i0 >= 0 && r.j0 >= 0 && r.i1 < columns && r.j1 < rows; }
  Rect clip(Rect r) const {
    r.i0 = std::max(r.i0, 0L), r.j0 = std::max(r.j0, 0L);
    r.i1 = std::min(r.i1, static_cast<long>(columns) - 1), r.j1 = std::min(r.j1, static_cast<long>(rows) - 1);
    return r;
  }
};

// The projections of `points` from every corner (all beyond the corners on p).
template <std::size_t N>
Extent extent_of(const std::array<Point3, N>& points, const std::array<Point3, 4>& corners) {
  Extent e;
  for (const Point3& v : corners)
    for (const Point3& q : points) {
      const double d = q.p - v.p;
      e.add((q.l - v.l) / d, (q.z - v.z) / d);
    }
  return e;
}

int find(std::vector<std::int32_t>& parent, std::int32_t x) {
  while (parent[static_cast<std::size_t>(x)] != x) {
    parent[static_cast<std::size_t>(x)] = parent[static_cast<std::size_t>(parent[static_cast<std::size_t>(x)])];
    x = parent[static_cast<std::size_t>(x)];
  }
  return x;
}

enum : std::uint8_t { kOut = 0, kBack = 1, kFront = 2 };

}  // namespace

Result<SeedFuzzyResult> seed_fuzzy_hidden(const terrain::Dem& dem, const region::RegionCellsResult& walls,
                                          const SeedFuzzyOptions& options, const RunControl* control) {
  for (const auto& [name, v] : {std::pair{"columns", options.columns}, std::pair{"rows", options.rows}})
    if (v < 8 || v > 4096)
      return make_error(ErrorCode::kInvalidArgument,
                        std::string(name) + ": must be an integer in [8, 4096], got " + std::to_string(v), name);
  const auto start = std::chrono::steady_clock::now();
  const region::RegionFrame& f = walls.frame;
  const terrain::Window& win = walls.window;
  SeedFuzzyResult out;
  out.window = win;
  out.codes = terrain::Grid<std::uint8_t>(win.width(), win.height(), std::uint8_t{2});
  for (int j = 0; j < win.height(); ++j)
    for (int i = 0; i < win.width(); ++i)
      if (walls.codes.at(i, j) == region::kNoAnswer)
        out.codes.at(i, j) = region::kNoAnswer;
      else
        ++out.stats.items;

  const double mx = f.metres_per_col, my = f.metres_per_row, zt = f.z_max;
  // Quads between window nodes: (c, r) .. (c + 1, r + 1).
  const int qw = win.width() - 1, qh = win.height() - 1;
  if (qw < 1 || qh < 1) return out;
  const std::size_t quads = static_cast<std::size_t>(qw) * static_cast<std::size_t>(qh);
  // Node heights (lowered) and each quad's diagonal: 0 joins (c, r)-(c+1, r+1).
  const auto node = [&](int c, int r) { return static_cast<double>(dem.elevation.at(c, r)) - kLowering; };
  std::vector<std::uint8_t> diagonal(quads), valid(quads);
  for (int r = 0; r < qh; ++r)
    for (int c = 0; c < qw; ++c) {
      const int gc = win.col0 + c, gr = win.row0 + r;
      const double z00 = node(gc, gr), z10 = node(gc + 1, gr), z01 = node(gc, gr + 1), z11 = node(gc + 1, gr + 1);
      const std::size_t q = static_cast<std::size_t>(r) * static_cast<std::size_t>(qw) + c;
      valid[q] = std::isfinite(z00) && std::isfinite(z10) && std::isfinite(z01) && std::isfinite(z11);
      diagonal[q] = z00 + z11 <= z10 + z01 ? 0 : 1;  // the lower diagonal: a convex (valley) fold
    }
  // Triangle t of quad q (index 2q + t): its three nodes as (dc, dr) offsets.
  static constexpr std::array<std::array<std::array<int, 2>, 3>, 4> kNodes{{
      {{{0, 0}, {1, 0}, {1, 1}}},  // diagonal 0, triangle 0: top and right edges
      {{{0, 0}, {1, 1}, {0, 1}}},  // diagonal 0, triangle 1: left and bottom
      {{{0, 0}, {1, 0}, {0, 1}}},  // diagonal 1, triangle 0: top and left
      {{{1, 0}, {1, 1}, {0, 1}}},  // diagonal 1, triangle 1: right and bottom
  }};
  const auto vertices = [&](std::size_t tri, const FaceFrame& ff) {
    const std::size_t q = tri / 2;
    const int c = static_cast<int>(q % static_cast<std::size_t>(qw)), r = static_cast<int>(q / qw);
    const auto& k = kNodes[static_cast<std::size_t>(diagonal[q] * 2 + tri % 2)];
    std::array<Point3, 3> v;
    for (int n = 0; n < 3; ++n) {
      const int gc = win.col0 + c + k[n][0], gr = win.row0 + r + k[n][1];
      v[static_cast<std::size_t>(n)] = ff.at(gc * mx, gr * my, node(gc, gr));
    }
    return v;
  };
  // The triangle of quad (c, r) on its edge: 0 top, 1 bottom, 2 left, 3 right; -1 none.
  const auto on_edge = [&](int c, int r, int edge) -> std::int64_t {
    if (c < 0 || r < 0 || c >= qw || r >= qh) return -1;
    const std::size_t q = static_cast<std::size_t>(r) * static_cast<std::size_t>(qw) + c;
    const int d = diagonal[q];
    const int t = edge == 0 ? 0 : edge == 1 ? 1 : edge == 2 ? (d == 0 ? 1 : 0) : (d == 0 ? 0 : 1);
    return static_cast<std::int64_t>(2 * q + t);
  };

  // A triangle's edges by slot: 0 the diagonal (shared with the other
  // triangle of its quad), 1 and 2 the quad edges it lies on (0 top,
  // 1 bottom, 2 left, 3 right).
  const auto quad_edge = [&](std::size_t tri, int slot) {
    const int d = diagonal[tri / 2], t = static_cast<int>(tri % 2);
    if (slot == 1) return d == 0 ? (t == 0 ? 0 : 2) : (t == 0 ? 0 : 3);
    return d == 0 ? (t == 0 ? 3 : 1) : (t == 0 ? 2 : 1);
  };
  static constexpr std::array<int, 4> kEdgeDc{0, 0, -1, 1}, kEdgeDr{-1, 1, 0, 0};
  // Nodes (dc, dr) of quad edges: top (0,0)-(1,0), bottom (0,1)-(1,1), left (0,0)-(0,1), right (1,0)-(1,1).
  static constexpr std::array<std::array<std::array<int, 2>, 2>, 4> kEdgeNodes{
      {{{{0, 0}, {1, 0}}}, {{{0, 1}, {1, 1}}}, {{{0, 0}, {0, 1}}}, {{{1, 0}, {1, 1}}}}};
  // The triangle across a triangle's edge (-1: none, outside the window).
  const auto across = [&](std::size_t tri, int slot) -> std::int64_t {
    if (slot == 0) return static_cast<std::int64_t>(tri ^ 1);
    const std::size_t q = tri / 2;
    const int c = static_cast<int>(q % static_cast<std::size_t>(qw)), r = static_cast<int>(q / qw);
    const int edge = quad_edge(tri, slot);
    return on_edge(c + kEdgeDc[static_cast<std::size_t>(edge)], r + kEdgeDr[static_cast<std::size_t>(edge)], edge ^ 1);
  };
  // The two nodes of a triangle's edge, in a face's frame.
  const auto edge_ends = [&](std::size_t tri, int slot, const FaceFrame& ff) {
    const std::size_t q = tri / 2;
    const int c = static_cast<int>(q % static_cast<std::size_t>(qw)), r = static_cast<int>(q / qw);
    std::array<std::array<int, 2>, 2> nodes;
    if (slot == 0) {  // the diagonal
      nodes = diagonal[q] == 0 ? std::array<std::array<int, 2>, 2>{{{0, 0}, {1, 1}}}
                               : std::array<std::array<int, 2>, 2>{{{1, 0}, {0, 1}}};
    } else {
      nodes = kEdgeNodes[static_cast<std::size_t>(quad_edge(tri, slot))];
    }
    std::array<Point3, 2> ends;
    for (std::size_t m = 0; m < 2; ++m) {
      const int gc = win.col0 + c + nodes[m][0], gr = win.row0 + r + nodes[m][1];
      ends[m] = ff.at(gc * mx, gr * my, node(gc, gr));
    }
    return ends;
  };
  struct Boundary {
    std::uint32_t tri;
    std::uint8_t slot;
  };
  std::vector<Boundary> boundary;

  std::vector<std::uint8_t> state(2 * quads);
  std::vector<std::int32_t> parent(2 * quads);
  Array array;
  const std::array<FaceFrame, 4> faces{{{1.0, true}, {-1.0, true}, {1.0, false}, {-1.0, false}}};
  terrain::Grid<std::uint8_t> reason(win.width(), win.height(), std::uint8_t{0});  // 0: no face held it
  for (const FaceFrame& ff : faces) {
    HORIZON_RETURN_IF_ERROR(check_control(control));
    // The region's top face in this frame.
    const Point3 ca = ff.at(f.col_min * mx, f.row_min * my, zt), cb = ff.at(f.col_max * mx, f.row_max * my, zt);
    const double p1 = std::max(ca.p, cb.p), l0 = std::min(ca.l, cb.l), l1 = std::max(ca.l, cb.l);
    const double p0 = std::min(ca.p, cb.p);
    const std::array<Point3, 4> corners{{{p0, l0, zt}, {p0, l1, zt}, {p1, l0, zt}, {p1, l1, zt}}};
    const Point3 v0{0.5 * (p0 + p1), 0.5 * (l0 + l1), zt};

    // 1-2. Patches beyond the region, and which face every viewpoint.
    std::uint64_t front = 0;
    for (std::size_t tri = 0; tri < 2 * quads; ++tri) {
      parent[tri] = static_cast<std::int32_t>(tri);
      state[tri] = kOut;
      if (!valid[tri / 2]) continue;
      const auto v = vertices(tri, ff);
      if (!(v[0].p > p1 && v[1].p > p1 && v[2].p > p1)) continue;
      const double ux = v[1].p - v[0].p, uy = v[1].l - v[0].l, uz = v[1].z - v[0].z;
      const double wx = v[2].p - v[0].p, wy = v[2].l - v[0].l, wz = v[2].z - v[0].z;
      double nx = uy * wz - uz * wy, ny = uz * wx - ux * wz, nz = ux * wy - uy * wx;
      if (nz < 0) nx = -nx, ny = -ny, nz = -nz;  // the upward normal: the terrain's front is above it
      bool faces_all = true;
      for (const Point3& c : corners)
        faces_all = faces_all && nx * (c.p - v[0].p) + ny * (c.l - v[0].l) + nz * (c.z - v[0].z) > 0.0;
      state[tri] = faces_all ? kFront : kBack;
      ++out.stats.patches;
      front += faces_all;
    }
    out.stats.front_facing += front;
    if (front == 0) continue;
    array.reset(options.columns, options.rows);

    // 3. Sub-surfaces (front-facing patches joined across shared edges), and
    // their boundary edges, kept for step 4.
    boundary.clear();
    for (int r = 0; r < qh; ++r) {
      if ((r & 4095) == 0) HORIZON_RETURN_IF_ERROR(check_control(control));
      for (int c = 0; c < qw; ++c)
        for (int t = 0; t < 2; ++t) {
          const std::size_t tri = 2 * (static_cast<std::size_t>(r) * static_cast<std::size_t>(qw) + c) + t;
          if (state[tri] != kFront) continue;
          for (int slot = 0; slot < 3; ++slot) {
            const std::int64_t n = across(tri, slot);
            if (n >= 0 && state[static_cast<std::size_t>(n)] == kFront) {
              const int a = find(parent, static_cast<std::int32_t>(tri)),
                        b = find(parent, static_cast<std::int32_t>(n));
              if (a != b) parent[static_cast<std::size_t>(std::max(a, b))] = std::min(a, b);
            } else {
              boundary.push_back({static_cast<std::uint32_t>(tri), static_cast<std::uint8_t>(slot)});
            }
          }
        }
    }
    out.stats.boundary_edges += boundary.size();

    // 4. Render from v0: each element's centre takes the nearest patch holding it.
    for (std::size_t tri = 0; tri < 2 * quads; ++tri) {
      if (state[tri] == kOut) continue;
      const auto v = vertices(tri, ff);
      std::array<double, 3> a{}, b{};
      for (std::size_t k = 0; k < 3; ++k) {
        const double d = v[k].p - v0.p;
        a[k] = (v[k].l - v0.l) / d;
        b[k] = (v[k].z - v0.z) / d;
      }
      Extent seen;
      for (std::size_t k = 0; k < 3; ++k) seen.add(a[k], b[k]);
      const auto [i0, i1, j0, j1] = array.clip(array.rect_of(seen));
      if (i0 > i1 || j0 > j1) continue;
      const double area = (a[1] - a[0]) * (b[2] - b[0]) - (a[2] - a[0]) * (b[1] - b[0]);
      if (area == 0.0) continue;
      const double ux = v[1].p - v[0].p, uy = v[1].l - v[0].l, uz = v[1].z - v[0].z;
      const double wx = v[2].p - v[0].p, wy = v[2].l - v[0].l, wz = v[2].z - v[0].z;
      const double nx = uy * wz - uz * wy, ny = uz * wx - ux * wz, nz = ux * wy - uy * wx;
      const double lift = nx * (v[0].p - v0.p) + ny * (v[0].l - v0.l) + nz * (v[0].z - v0.z);
      for (long j = j0; j <= j1; ++j) {
        const double bc = -kSpanB + (static_cast<double>(j) + 0.5) * array.wb;
        for (long i = i0; i <= i1; ++i) {
          const double ac = -kSpanA + (static_cast<double>(i) + 0.5) * array.wa;
          // Strictly inside (barycentric weights of one sign, none zero).
          const double w0 = (a[1] - ac) * (b[2] - bc) - (a[2] - ac) * (b[1] - bc);
          const double w1 = (a[2] - ac) * (b[0] - bc) - (a[0] - ac) * (b[2] - bc);
          const double w2 = (a[0] - ac) * (b[1] - bc) - (a[1] - ac) * (b[0] - bc);
          const bool inside = area > 0 ? (w0 > 0 && w1 > 0 && w2 > 0) : (w0 < 0 && w1 < 0 && w2 < 0);
          if (!inside) continue;
          // Where the ray (1, ac, bc) from v0 meets the patch's plane.
          const double along = lift / (nx + ny * ac + nz * bc);
          const std::size_t e = array.at(static_cast<int>(i), static_cast<int>(j));
          if (along < array.depth[e]) {
            array.depth[e] = static_cast<float>(along);
            array.id[e] = static_cast<std::int32_t>(tri);
          }
        }
      }
    }
    std::uint64_t roots = 0;
    for (std::size_t tri = 0; tri < 2 * quads; ++tri)
      roots += state[tri] == kFront && find(parent, static_cast<std::int32_t>(tri)) == static_cast<std::int32_t>(tri);
    out.stats.sub_surfaces += roots;
    for (std::int32_t& id : array.id)
      if (id >= 0) id = state[static_cast<std::size_t>(id)] == kFront ? find(parent, id) : -1;

    // 5. Each boundary edge's fuzzy extent takes its own sub-surface's
    // elements out of that sub-surface's umbra (NF(S) = FR(S) less the
    // extents of S's boundary edges; another sub-surface's edges do not
    // touch it).
    for (const Boundary& edge : boundary) {
      const auto ends = edge_ends(edge.tri, edge.slot, ff);
      const Extent e = extent_of(ends, corners);
      const auto [i0, i1, j0, j1] = array.clip(array.rect_of(e));
      const std::int32_t root = find(parent, static_cast<std::int32_t>(edge.tri));
      for (long j = j0; j <= j1; ++j)
        for (long i = i0; i <= i1; ++i) {
          const std::size_t k = array.at(static_cast<int>(i), static_cast<int>(j));
          if (array.id[k] == root) array.mask[k] = 1;
        }
    }

    // 6. Farthest depths of each element's sub-surface.
    for (std::size_t tri = 0; tri < 2 * quads; ++tri) {
      if (state[tri] != kFront) continue;
      const auto v = vertices(tri, ff);
      const Extent e = extent_of(v, corners);
      const auto [i0, i1, j0, j1] = array.clip(array.rect_of(e));
      const std::int32_t root = find(parent, static_cast<std::int32_t>(tri));
      const double farthest = std::max({v[0].p, v[1].p, v[2].p});
      for (long j = j0; j <= j1; ++j)
        for (long i = i0; i <= i1; ++i) {
          const std::size_t k = array.at(static_cast<int>(i), static_cast<int>(j));
          if (array.id[k] == root) array.far[k] = std::max(array.far[k], farthest);
        }
    }

    out.stats.elements += array.id.size();
    for (std::size_t k = 0; k < array.id.size(); ++k) out.stats.umbra_elements += array.id[k] >= 0 && !array.mask[k];

    // 7. Items: every element of the extent umbra, its sub-surface nearer than the item.
    for (int j = 0; j < win.height(); ++j)
      for (int i = 0; i < win.width(); ++i) {
        std::uint8_t& code = out.codes.at(i, j);
        if (code != 2) continue;
        const int gc = win.col0 + i, gr = win.row0 + j;
        const Point3 q = ff.at(gc * mx, gr * my, dem.elevation.at(gc, gr) + options.target_height);
        if (!(q.p > p1)) continue;
        const Extent e = extent_of(std::array<Point3, 1>{q}, corners);
        const Rect r = array.rect_of(e);
        if (!array.holds(r)) continue;  // leaves the array
        const auto [i0, i1, j0, j1] = r;
        bool hidden = true;
        std::uint8_t why = 0;  // 1 not umbra, 2 too deep
        for (long jj = j0; hidden && jj <= j1; ++jj)
          for (long ii = i0; hidden && ii <= i1; ++ii) {
            const std::size_t k = array.at(static_cast<int>(ii), static_cast<int>(jj));
            hidden = array.id[k] >= 0 && !array.mask[k] && array.far[k] < q.p;
            if (!hidden) why = array.id[k] >= 0 && !array.mask[k] ? 2 : 1;
          }
        if (hidden)
          code = 0;
        else
          reason.at(i, j) = why;
      }
  }
  for (int j = 0; j < win.height(); ++j)
    for (int i = 0; i < win.width(); ++i) {
      const std::uint8_t code = out.codes.at(i, j);
      out.stats.always_hidden += code == 0;
      if (code != 2) continue;
      const std::uint8_t why = reason.at(i, j);
      (why == 1 ? out.stats.not_umbra : why == 2 ? out.stats.too_deep : out.stats.off_array) += 1;
    }
  out.stats.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return out;
}

}  // namespace horizon::evaluation
