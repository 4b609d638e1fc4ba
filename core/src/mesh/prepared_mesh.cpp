#include "horizon/mesh/prepared_mesh.hpp"

#include <CGAL/Min_circle_2.h>
#include <CGAL/Min_circle_2_traits_2.h>
#include <CGAL/Random.h>
#include <CGAL/Simple_cartesian.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <map>
#include <memory>
#include <numbers>

#include "horizon/common/parallel.hpp"
#include "mesh/sector_frame.hpp"
#include "mesh/prepared_parts.hpp"
#include "mesh/walls.hpp"

namespace horizon::mesh {
namespace {

using Clock = std::chrono::steady_clock;
double seconds_since(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}

Status check_options(const PrepareOptions& o) {
  auto bad = [](const std::string& what) { return make_error(ErrorCode::kInvalidArgument, what, "mesh"); };
  const CrystalOptions& c = o.crystals;
  if (c.seeds < 1 || c.seeds > 1'000'000) return bad("seeds must be 1 to 1000000, not " + std::to_string(c.seeds));
  if (c.min_group_size < 1 || c.min_group_size > 1'000'000)
    return bad("min_group_size must be 1 to 1000000 triangles, not " + std::to_string(c.min_group_size));
  if (c.max_orphan_passes < 0 || c.max_orphan_passes > 1000)
    return bad("max_orphan_passes must be 0 to 1000, not " + std::to_string(c.max_orphan_passes));
  if (c.max_groups < 1 || c.max_groups > 1'000'000)
    return bad("max_groups must be 1 to 1000000, not " + std::to_string(c.max_groups));
  if (!(o.merge_cutoff > 0.0 && o.merge_cutoff <= 1.0))
    return bad("merge_cutoff must be a fraction of the mesh's area in (0, 1], not " + number_text(o.merge_cutoff));
  if (o.max_chain_corners < 2 || o.max_chain_corners > 64)
    return bad("max_chain_corners must be 2 to 64, not " + std::to_string(o.max_chain_corners));
  return Status::Ok();
}

// GCC 12 at -O3 warns of an uninitialised temporary inside CGAL's
// Min_circle_2 support-set code (a false positive in the library's
// header); the pragma is scoped to this function.
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
Circle min_circle(const std::vector<TinVertex>& vertices, const std::vector<std::uint32_t>& ids) {
  using K = CGAL::Simple_cartesian<double>;
  std::vector<K::Point_2> points;
  points.reserve(ids.size());
  for (std::uint32_t v : ids) points.emplace_back(vertices[v].x, vertices[v].y);
  // Welzl's algorithm wants the points shuffled (expected linear time), and
  // CGAL's default generator is seeded from the clock: a fixed seed, one
  // generator a call (calls run on several threads), so that the same TIN
  // and knobs give the same circles, and so the same walls and culls.
  CGAL::Random random(0x5eed);
  CGAL::Min_circle_2<CGAL::Min_circle_2_traits_2<K>> circle(points.begin(), points.end(), true, random);
  const auto& c = circle.circle();
  Circle out{c.center().x(), c.center().y(), std::sqrt(c.squared_radius())};
  // Rounding in the construction must not leave a vertex outside.
  for (std::uint32_t v : ids)
    out.radius = std::max(out.radius, std::hypot(vertices[v].x - out.x, vertices[v].y - out.y));
  out.radius *= 1 + 1e-6;
  return out;
}
#pragma GCC diagnostic pop

Circle enclosing(const Circle& a, const Circle& b) {
  const double d = std::hypot(b.x - a.x, b.y - a.y);
  if (d + b.radius <= a.radius) return a;
  if (d + a.radius <= b.radius) return b;
  const double radius = (d + a.radius + b.radius) / 2;
  const double f = (radius - a.radius) / d;
  return {a.x + (b.x - a.x) * f, a.y + (b.y - a.y) * f, radius * (1 + 1e-9)};
}

class Builder {
 public:
  Builder(PreparedMesh& mesh, const PrepareOptions& options) : mesh_(mesh), options_(options) {}

  // Leaves from the crystals, then the hierarchy over them. The leaves
  // are independent of one another and built in parallel (each into its
  // own slots), then appended in order.
  void build(const Crystals& crystals, std::vector<std::vector<std::uint32_t>>& faces_of) {
    const SectorFrame frame(mesh_.tin.vertices, mesh_.horizons);
    const int s = mesh_.sectors;
    const auto sectors = static_cast<std::size_t>(s);
    faces_of = crystals.groups;
    const std::size_t leaves = crystals.groups.size();
    std::vector<MeshGroup> leaf_groups(leaves);
    std::vector<OcclusionChain> leaf_regions(leaves * sectors);
    parallel_for(leaves, options_.horizons.threads, [&](std::size_t g) {
      const auto& faces = crystals.groups[g];
      std::vector<std::uint32_t> vertices;
      for (std::uint32_t f : faces) vertices.insert(vertices.end(), mesh_.tin.triangles[f].begin(), mesh_.tin.triangles[f].end());
      std::sort(vertices.begin(), vertices.end());
      vertices.erase(std::unique(vertices.begin(), vertices.end()), vertices.end());
      MeshGroup& group = leaf_groups[g];
      group.triangle_count = static_cast<std::uint32_t>(faces.size());
      group.circle = min_circle(mesh_.tin.vertices, vertices);
      std::vector<OcclusionChain::Ray> rays;
      for (int i = 0; i < s; ++i) {
        // The vertices' rays at once; a vertex with no horizon empties it.
        rays.clear();
        for (std::uint32_t v : vertices) {
          const auto ray = frame.ray(v, i);
          if (!ray) {
            rays.clear();
            break;
          }
          rays.push_back(*ray);
        }
        leaf_regions[g * sectors + static_cast<std::size_t>(i)] =
            OcclusionChain::lower_envelope(rays).simplified(static_cast<std::size_t>(options_.max_chain_corners));
      }
    });
    mesh_.groups.insert(mesh_.groups.end(), leaf_groups.begin(), leaf_groups.end());
    mesh_.regions.insert(mesh_.regions.end(), std::make_move_iterator(leaf_regions.begin()),
                         std::make_move_iterator(leaf_regions.end()));
    mesh_.stats.leaf_groups = static_cast<std::uint32_t>(mesh_.groups.size());
    met_.resize(mesh_.groups.size());
    for (std::size_t g = 0; g < crystals.collisions.size(); ++g)
      for (const auto& [other, count] : crystals.collisions[g]) met_[g][other] = count;
    merge_levels();
  }

 private:
  void merge_levels() {
    std::vector<std::uint32_t> active;
    for (std::uint32_t g = 0; g < mesh_.groups.size(); ++g) active.push_back(g);
    while (!active.empty()) {
      std::vector<std::uint32_t> next;
      std::vector<bool> taken(mesh_.groups.size() * 2 + 1, false);
      bool merged = false;
      for (std::uint32_t g : active) {
        if (taken[g]) continue;
        if (met_[g].empty()) {
          mesh_.top_level.push_back(g);
          continue;
        }
        std::uint32_t h = met_[g].begin()->first, most = 0;
        for (const auto& [other, count] : met_[g])
          if (count > most) most = count, h = other;
        if (taken[h]) continue;  // its partner is paired already: carried up (below)
        const std::uint32_t parent = merge(g, h);
        if (taken.size() <= parent) taken.resize(parent + 1, false);
        taken[g] = taken[h] = taken[parent] = true;
        merged = true;
        const Circle& c = mesh_.groups[parent].circle;
        if (std::numbers::pi * c.radius * c.radius > options_.merge_cutoff * mesh_.area) {
          retire(parent);
          mesh_.top_level.push_back(parent);
        } else {
          next.push_back(parent);
        }
      }
      // Groups not paired this level (their partner was taken) wait for
      // the next; a group only becomes top-level above with no collision
      // left, and then no other group names it.
      for (std::uint32_t g : active)
        if (!taken[g] && !met_[g].empty()) next.push_back(g);
      if (!merged) {
        for (std::uint32_t g : next) mesh_.top_level.push_back(g);
        break;
      }
      ++mesh_.stats.levels;
      std::sort(next.begin(), next.end());
      active = std::move(next);
    }
    std::sort(mesh_.top_level.begin(), mesh_.top_level.end());
  }

  // A parent of g and h: their collisions less their mutual ones, their
  // regions intersected.
  std::uint32_t merge(std::uint32_t g, std::uint32_t h) {
    const auto parent = static_cast<std::uint32_t>(mesh_.groups.size());
    MeshGroup group;
    group.children[0] = static_cast<std::int32_t>(g);
    group.children[1] = static_cast<std::int32_t>(h);
    group.triangle_count = mesh_.groups[g].triangle_count + mesh_.groups[h].triangle_count;
    group.circle = enclosing(mesh_.groups[g].circle, mesh_.groups[h].circle);
    mesh_.groups.push_back(group);
    const int s = mesh_.sectors;
    for (int i = 0; i < s; ++i)
      mesh_.regions.push_back(OcclusionChain::intersect(mesh_.region(g, i), mesh_.region(h, i))
                                  .simplified(static_cast<std::size_t>(options_.max_chain_corners)));
    met_.emplace_back();
    for (std::uint32_t child : {g, h}) {
      for (const auto& [other, count] : met_[child]) {
        if (other == g || other == h) continue;
        met_[parent][other] += count;
        met_[other].erase(child);
        met_[other][parent] += count;
      }
      met_[child].clear();
    }
    return parent;
  }

  // A top-level group takes no further part in merging.
  void retire(std::uint32_t g) {
    for (const auto& [other, count] : met_[g]) met_[other].erase(g);
    met_[g].clear();
  }

  PreparedMesh& mesh_;
  const PrepareOptions& options_;
  std::vector<std::map<std::uint32_t, std::uint32_t>> met_;
};

// Triangles reordered so each group is one run: the trees depth first.
void reorder(PreparedMesh& mesh, const std::vector<std::vector<std::uint32_t>>& leaf_faces,
             const std::vector<std::uint32_t>& always_visible) {
  std::vector<TinTriangle> triangles;
  triangles.reserve(mesh.tin.triangles.size());
  mesh.source_triangle.clear();
  // Iterative depth-first walk; a group's run starts where its first leaf's does.
  for (std::uint32_t root : mesh.top_level) {
    std::vector<std::pair<std::uint32_t, bool>> stack{{root, false}};
    while (!stack.empty()) {
      auto [g, done] = stack.back();
      stack.pop_back();
      MeshGroup& group = mesh.groups[g];
      if (done) {
        const MeshGroup& first = mesh.groups[static_cast<std::size_t>(group.children[0])];
        group.first_triangle = first.first_triangle;
        continue;
      }
      if (group.leaf()) {
        group.first_triangle = static_cast<std::uint32_t>(triangles.size());
        for (std::uint32_t f : leaf_faces[g]) {
          triangles.push_back(mesh.tin.triangles[f]);
          mesh.source_triangle.push_back(f);
        }
        continue;
      }
      stack.push_back({g, true});
      stack.push_back({static_cast<std::uint32_t>(group.children[1]), false});
      stack.push_back({static_cast<std::uint32_t>(group.children[0]), false});
    }
  }
  mesh.always_visible_first = static_cast<std::uint32_t>(triangles.size());
  mesh.always_visible_count = static_cast<std::uint32_t>(always_visible.size());
  for (std::uint32_t f : always_visible) {
    triangles.push_back(mesh.tin.triangles[f]);
    mesh.source_triangle.push_back(f);
  }
  mesh.tin.triangles = std::move(triangles);
}

}  // namespace

void flatten_regions(PreparedMesh& mesh) {
  mesh.chain_begin.clear();
  mesh.corner_t.clear();
  mesh.corner_z.clear();
  mesh.chain_slope.clear();
  mesh.chain_begin.assign(1, 0);
  for (const OcclusionChain& chain : mesh.regions) {
    for (const ChainPoint& c : chain.corners()) {
      mesh.corner_t.push_back(c.t);
      mesh.corner_z.push_back(c.z);
    }
    mesh.chain_slope.push_back(chain.final_slope());
    mesh.chain_begin.push_back(static_cast<std::uint32_t>(mesh.corner_t.size()));
  }
}

int PreparedMesh::sector_of(double dx, double dy) const {
  const double p = pseudo_angle(dx, dy);
  const auto it = std::upper_bound(sector_starts.begin(), sector_starts.end(), p);
  return static_cast<int>(it - sector_starts.begin()) - 1;
}

void set_sector_tables(PreparedMesh& mesh) {
  mesh.centre_directions.clear();
  mesh.sector_starts.clear();
  for (int i = 0; i < mesh.sectors; ++i) {
    const Wedge w = Wedge::sector(i, mesh.sectors);
    mesh.centre_directions.push_back({w.rx, w.ry});
    mesh.sector_starts.push_back(i == 0 ? 0.0 : pseudo_angle(w.ay, -w.ax));  // the first edge's direction
  }
}

void set_group_columns(PreparedMesh& mesh) {
  GroupColumns& c = mesh.columns;
  c = {};
  const std::size_t n = mesh.groups.size();
  for (const MeshGroup& g : mesh.groups) {
    c.x.push_back(g.circle.x);
    c.y.push_back(g.circle.y);
    c.radius.push_back(g.circle.radius);
  }
  // The scalar cull's order: roots in top_level order, each tree depth
  // first, children[0] before children[1].
  constexpr std::uint32_t kUnreached = ~0u;
  c.leaf_rank.assign(n, kUnreached);
  std::vector<bool> reached(n, false);
  bool twice = false;
  std::vector<std::uint32_t> stack;
  for (auto it = mesh.top_level.rbegin(); it != mesh.top_level.rend(); ++it) stack.push_back(*it);
  while (!stack.empty() && !twice) {
    const std::uint32_t g = stack.back();
    stack.pop_back();
    if (reached[g]) twice = true;
    reached[g] = true;
    const MeshGroup& group = mesh.groups[g];
    if (group.leaf()) {
      c.leaf_rank[g] = static_cast<std::uint32_t>(c.leaf_order.size());
      c.leaf_order.push_back(g);
    } else {
      stack.push_back(static_cast<std::uint32_t>(group.children[1]));
      stack.push_back(static_cast<std::uint32_t>(group.children[0]));
    }
  }
  constexpr std::size_t kIndexLimit = std::size_t{1} << 31;
  const std::size_t chains = n * static_cast<std::size_t>(mesh.sectors);
  c.usable = !twice && chains < kIndexLimit && mesh.corner_t.size() < kIndexLimit &&
             mesh.wall_radius.size() < kIndexLimit;
}

Result<PreparedMesh> prepare_mesh(Tin tin, const PrepareOptions& options, const RunControl* control) {
  HORIZON_RETURN_IF_ERROR(check_options(options));
  PreparedMesh mesh;
  mesh.tin = std::move(tin);
  for (const TinTriangle& t : mesh.tin.triangles) mesh.area += std::abs(signed_area(mesh.tin, t));

  // Progress: the horizons are most of the work (0 to 0.8), then a step a
  // phase; cancellation and the deadline are checked between phases too.
  RunControl horizon_control;
  if (control) {
    horizon_control.cancel = control->cancel;
    horizon_control.deadline = control->deadline;
    if (control->progress) horizon_control.progress = [control](double f) { control->progress(0.8 * f); };
  }
  auto start = Clock::now();
  auto horizons = compute_horizons(mesh.tin.vertices, options.horizons, control ? &horizon_control : nullptr);
  if (!horizons.ok()) return horizons.error();
  mesh.horizons = std::move(*horizons);
  mesh.sectors = mesh.horizons.sectors;
  set_sector_tables(mesh);
  mesh.stats.horizon_seconds = seconds_since(start);

  HORIZON_RETURN_IF_ERROR(check_control(control));
  start = Clock::now();
  // The crystals grow one face at a time on one thread; the walls' floor
  // pyramid needs only the TIN, so it is built meanwhile on another (when
  // there is one). Its time counts towards the grouping's.
  Crystals crystals;
  std::shared_ptr<const FloorPyramid> floors;
  parallel_for(2, options.horizons.threads, [&](std::size_t job) {
    if (job == 0)
      crystals = grow_crystals(mesh.tin, mesh.horizons, options.crystals);
    else
      floors = build_floors(mesh.tin);
  });
  mesh.stats.orphan_passes = crystals.orphan_passes;
  mesh.stats.grouping_seconds = seconds_since(start);
  report_progress(control, 0.85);

  HORIZON_RETURN_IF_ERROR(check_control(control));
  start = Clock::now();
  std::vector<std::vector<std::uint32_t>> leaf_faces;
  Builder(mesh, options).build(crystals, leaf_faces);
  reorder(mesh, leaf_faces, crystals.always_visible);
  flatten_regions(mesh);
  mesh.stats.hierarchy_seconds = seconds_since(start);
  report_progress(control, 0.9);
  HORIZON_RETURN_IF_ERROR(check_control(control));
  start = Clock::now();
  build_walls(mesh, *floors, options.horizons.threads);
  mesh.stats.wall_seconds = seconds_since(start);
  set_group_columns(mesh);
  report_progress(control, 1.0);
  return mesh;
}

}  // namespace horizon::mesh
