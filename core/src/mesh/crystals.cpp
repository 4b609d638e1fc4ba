#include "horizon/mesh/crystals.hpp"

#include <algorithm>
#include <cmath>
#include <deque>
#include <map>
#include <numbers>
#include <random>

#include "mesh/sector_frame.hpp"

namespace horizon::mesh {
namespace {

constexpr std::uint32_t kNone = 0xffffffffu;

// Faces sharing an edge with each face (kNone where the edge is a border).
std::vector<std::array<std::uint32_t, 3>> face_neighbours(const Tin& tin) {
  std::vector<std::array<std::uint32_t, 4>> edges;  // lower vertex, higher vertex, face, slot
  edges.reserve(tin.triangles.size() * 3);
  for (std::uint32_t f = 0; f < tin.triangles.size(); ++f)
    for (std::uint32_t e = 0; e < 3; ++e) {
      std::uint32_t a = tin.triangles[f][e], b = tin.triangles[f][(e + 1) % 3];
      edges.push_back({std::min(a, b), std::max(a, b), f, e});
    }
  std::sort(edges.begin(), edges.end());
  std::vector<std::array<std::uint32_t, 3>> out(tin.triangles.size(), {kNone, kNone, kNone});
  for (std::size_t i = 0; i + 1 < edges.size(); ++i)
    if (edges[i][0] == edges[i + 1][0] && edges[i][1] == edges[i + 1][1]) {
      out[edges[i][2]][edges[i][3]] = edges[i + 1][2];
      out[edges[i + 1][2]][edges[i + 1][3]] = edges[i][2];
    }
  return out;
}

struct Crystal {
  std::vector<std::uint32_t> faces;
  std::uint32_t reference = 0;  // its lowest vertex
  std::deque<std::uint32_t> frontier;
};

class Grower {
 public:
  Grower(const Tin& tin, const VertexHorizons& horizons, const CrystalOptions& options)
      : tin_(tin), options_(options), frame_(tin.vertices, horizons), neighbours_(face_neighbours(tin)),
        owner_(tin.triangles.size(), kNone), tried_(tin.triangles.size(), kNone), rng_(options.random_seed) {}

  Crystals run() {
    const std::size_t faces = tin_.triangles.size();
    Crystals out;
    for (int pass = 0; pass <= options_.max_orphan_passes; ++pass) {
      std::vector<std::uint32_t> orphans;
      for (std::uint32_t f = 0; f < faces; ++f)
        if (owner_[f] == kNone) orphans.push_back(f);
      const std::size_t room = static_cast<std::size_t>(options_.max_groups) - crystals_.size();
      if (orphans.empty() || room == 0) break;
      double wanted = options_.seeds;
      if (pass > 0) wanted = std::max(1.0, std::round(options_.seeds * static_cast<double>(orphans.size()) / faces));
      const std::size_t seeds = std::min({static_cast<std::size_t>(wanted), room, orphans.size()});
      const std::size_t first = crystals_.size();
      plant(orphans, seeds);
      grow(first);
      if (pass > 0) out.orphan_passes = pass;
      std::size_t largest = 0;
      for (std::size_t c = first; c < crystals_.size(); ++c) largest = std::max(largest, crystals_[c].faces.size());
      if (largest < static_cast<std::size_t>(options_.min_group_size)) break;
    }
    finish(out);
    return out;
  }

 private:
  // Seeds on `seeds` distinct orphan faces, drawn by a partial Fisher–Yates.
  void plant(std::vector<std::uint32_t>& orphans, std::size_t seeds) {
    for (std::size_t i = 0; i < seeds; ++i) {
      const std::size_t j = i + static_cast<std::size_t>(rng_() % (orphans.size() - i));
      std::swap(orphans[i], orphans[j]);
      const std::uint32_t face = orphans[i];
      const auto id = static_cast<std::uint32_t>(crystals_.size());
      Crystal crystal;
      crystal.reference = lowest(tin_.triangles[face][0], face);
      crystals_.push_back(std::move(crystal));
      claim(id, face);
    }
  }

  std::uint32_t lowest(std::uint32_t start, std::uint32_t face) const {
    std::uint32_t best = start;
    for (std::uint32_t v : tin_.triangles[face]) {
      const TinVertex& a = tin_.vertices[v];
      const TinVertex& b = tin_.vertices[best];
      if (a.z < b.z || (a.z == b.z && v < best)) best = v;
    }
    return best;
  }

  void claim(std::uint32_t id, std::uint32_t face) {
    Crystal& crystal = crystals_[id];
    owner_[face] = id;
    crystal.faces.push_back(face);
    crystal.reference = lowest(crystal.reference, face);
    for (std::uint32_t n : neighbours_[face])
      if (n != kNone && owner_[n] != id) crystal.frontier.push_back(n);
  }

  // Crystals from `first` on take turns, each claiming one face a turn,
  // until none can grow.
  void grow(std::size_t first) {
    std::vector<std::uint32_t> active;
    for (std::size_t c = first; c < crystals_.size(); ++c) active.push_back(static_cast<std::uint32_t>(c));
    while (!active.empty()) {
      std::size_t kept = 0;
      for (std::uint32_t id : active)
        if (turn(id)) active[kept++] = id;
      active.resize(kept);
    }
  }

  // One turn: frontier faces are tried until one is claimed. False when
  // the frontier ran dry.
  bool turn(std::uint32_t id) {
    Crystal& crystal = crystals_[id];
    while (!crystal.frontier.empty()) {
      const std::uint32_t face = crystal.frontier.front();
      crystal.frontier.pop_front();
      if (owner_[face] == id || tried_[face] == id) continue;
      tried_[face] = id;
      if (owner_[face] != kNone) {
        ++collisions_[{std::min(id, owner_[face]), std::max(id, owner_[face])}];
        continue;
      }
      bool seen = true;
      for (std::uint32_t v : tin_.triangles[face])
        if (frame_.occluded(crystal.reference, tin_.vertices[v])) seen = false;
      if (!seen) continue;
      claim(id, face);
      return true;
    }
    return false;
  }

  // Small crystals merged or freed; ids made dense; collisions summed.
  void finish(Crystals& out) {
    const std::size_t n = crystals_.size();
    const auto small = [&](std::size_t c) { return crystals_[c].faces.size() < static_cast<std::size_t>(options_.min_group_size); };
    std::vector<std::uint32_t> root(n);
    for (std::uint32_t c = 0; c < n; ++c) root[c] = c;
    auto find = [&](std::uint32_t c) {
      while (root[c] != c) c = root[c] = root[root[c]];
      return c;
    };
    // Each small crystal joins the small crystal it met most.
    std::vector<std::pair<std::uint32_t, std::uint32_t>> best(n, {0, kNone});  // (count, partner)
    for (const auto& [pair, count] : collisions_) {
      const auto [a, b] = pair;
      if (!small(a) || !small(b)) continue;
      for (auto [self, other] : {std::pair{a, b}, std::pair{b, a}})
        if (count > best[self].first || (count == best[self].first && other < best[self].second))
          best[self] = {count, other};
    }
    for (std::uint32_t c = 0; c < n; ++c)
      if (small(c) && best[c].second != kNone) root[find(c)] = find(best[c].second);
    std::vector<std::size_t> size(n, 0);
    for (std::uint32_t c = 0; c < n; ++c) size[find(c)] += crystals_[c].faces.size();
    std::vector<std::uint32_t> dense(n, kNone);
    for (std::uint32_t c = 0; c < n; ++c) {
      const std::uint32_t r = find(c);
      if (size[r] < static_cast<std::size_t>(options_.min_group_size)) continue;
      if (dense[r] == kNone) {
        dense[r] = static_cast<std::uint32_t>(out.groups.size());
        out.groups.emplace_back();
      }
      dense[c] = dense[r];
      auto& faces = out.groups[dense[c]];
      faces.insert(faces.end(), crystals_[c].faces.begin(), crystals_[c].faces.end());
    }
    for (auto& faces : out.groups) std::sort(faces.begin(), faces.end());
    std::vector<bool> grouped(tin_.triangles.size(), false);
    for (const auto& faces : out.groups)
      for (std::uint32_t f : faces) grouped[f] = true;
    for (std::uint32_t f = 0; f < grouped.size(); ++f)
      if (!grouped[f]) out.always_visible.push_back(f);
    std::vector<std::map<std::uint32_t, std::uint32_t>> met(out.groups.size());
    for (const auto& [pair, count] : collisions_) {
      const std::uint32_t a = dense[pair.first], b = dense[pair.second];
      if (a == kNone || b == kNone || a == b) continue;
      met[a][b] += count;
      met[b][a] += count;
    }
    out.collisions.resize(out.groups.size());
    for (std::size_t g = 0; g < met.size(); ++g) out.collisions[g].assign(met[g].begin(), met[g].end());
  }

  const Tin& tin_;
  const CrystalOptions& options_;
  SectorFrame frame_;
  std::vector<std::array<std::uint32_t, 3>> neighbours_;
  std::vector<std::uint32_t> owner_, tried_;
  std::vector<Crystal> crystals_;
  std::map<std::pair<std::uint32_t, std::uint32_t>, std::uint32_t> collisions_;
  std::mt19937_64 rng_;
};

}  // namespace

bool occluded_from_vertex(std::span<const TinVertex> vertices, const VertexHorizons& horizons, std::uint32_t vertex,
                          const TinVertex& camera) {
  return SectorFrame(vertices, horizons).occluded(vertex, camera);
}

Crystals grow_crystals(const Tin& tin, const VertexHorizons& horizons, const CrystalOptions& options) {
  return Grower(tin, horizons, options).run();
}

}  // namespace horizon::mesh
