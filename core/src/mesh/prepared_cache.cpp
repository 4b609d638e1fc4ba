#include "horizon/mesh/prepared_cache.hpp"

#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <type_traits>
#include <unistd.h>

#include "mesh/prepared_parts.hpp"

namespace horizon::mesh {
namespace {

constexpr char kMagic[] = "horizon prepared mesh 1\n";

// FNV-1a, 64 bits, over raw bytes.
struct Hash {
  std::uint64_t h = 1469598103934665603ull;
  void bytes(const void* data, std::size_t n) {
    const auto* p = static_cast<const unsigned char*>(data);
    for (std::size_t i = 0; i < n; ++i) h = (h ^ p[i]) * 1099511628211ull;
  }
};

// The knobs that change the result, in a fixed order.
std::vector<double> knobs(const PrepareOptions& o) {
  return {static_cast<double>(o.horizons.sectors),          static_cast<double>(o.horizons.subsectors),
          static_cast<double>(o.crystals.seeds),             static_cast<double>(o.crystals.min_group_size),
          static_cast<double>(o.crystals.max_orphan_passes), static_cast<double>(o.crystals.max_groups),
          static_cast<double>(o.crystals.random_seed),       o.merge_cutoff,
          static_cast<double>(o.max_chain_corners)};
}

class Writer {
 public:
  template <class T>
  void put(const T& value) {
    static_assert(std::is_trivially_copyable_v<T>);
    bytes_.append(reinterpret_cast<const char*>(&value), sizeof(T));
  }
  template <class T>
  void put_vector(const std::vector<T>& values) {
    put(static_cast<std::uint64_t>(values.size()));
    bytes_.append(reinterpret_cast<const char*>(values.data()), values.size() * sizeof(T));
  }
  const std::string& bytes() const { return bytes_; }

 private:
  std::string bytes_;
};

class Reader {
 public:
  explicit Reader(const std::string& bytes) : bytes_(bytes) {}
  template <class T>
  bool get(T& value) {
    if (bytes_.size() - at_ < sizeof(T)) return false;
    std::memcpy(&value, bytes_.data() + at_, sizeof(T));
    at_ += sizeof(T);
    return true;
  }
  // A vector whose length is bounded by the bytes left before it is sized.
  template <class T>
  bool get_vector(std::vector<T>& values) {
    std::uint64_t n = 0;
    if (!get(n) || n > (bytes_.size() - at_) / sizeof(T)) return false;
    values.resize(n);
    std::memcpy(values.data(), bytes_.data() + at_, n * sizeof(T));
    at_ += n * sizeof(T);
    return true;
  }
  bool done() const { return at_ == bytes_.size(); }
  bool skip_magic() {
    const std::size_t n = sizeof(kMagic) - 1;
    if (bytes_.compare(0, n, kMagic) != 0) return false;
    at_ = n;
    return true;
  }

 private:
  const std::string& bytes_;
  std::size_t at_ = 0;
};

void put_tin(Writer& w, const Tin& tin) {
  w.put_vector(tin.vertices);
  w.put_vector(tin.triangles);
}

struct GroupRecord {
  std::uint32_t first_triangle, triangle_count;
  std::int32_t child0, child1;
  double x, y, radius;
};

}  // namespace

std::string prepared_cache_name(const Tin& tin, const PrepareOptions& options) {
  Hash hash;
  hash.bytes(tin.vertices.data(), tin.vertices.size() * sizeof(TinVertex));
  hash.bytes(tin.triangles.data(), tin.triangles.size() * sizeof(TinTriangle));
  const std::vector<double> k = knobs(options);
  hash.bytes(k.data(), k.size() * sizeof(double));
  char name[32];
  std::snprintf(name, sizeof name, "%016llx.hzmesh", static_cast<unsigned long long>(hash.h));
  return name;
}

Status save_prepared(const std::string& path, const Tin& input, const PrepareOptions& options,
                     const PreparedMesh& prepared) {
  Writer w;
  w.put_vector(knobs(options));
  put_tin(w, input);
  put_tin(w, prepared.tin);
  w.put_vector(prepared.source_triangle);
  w.put(static_cast<std::int32_t>(prepared.sectors));
  w.put_vector(prepared.horizons.horizon);
  std::vector<GroupRecord> groups;
  for (const MeshGroup& g : prepared.groups)
    groups.push_back({g.first_triangle, g.triangle_count, g.children[0], g.children[1], g.circle.x, g.circle.y,
                      g.circle.radius});
  w.put_vector(groups);
  w.put_vector(prepared.top_level);
  w.put(prepared.always_visible_first);
  w.put(prepared.always_visible_count);
  w.put(prepared.area);
  w.put(prepared.stats);
  w.put_vector(prepared.chain_begin);
  w.put_vector(prepared.corner_t);
  w.put_vector(prepared.corner_z);
  w.put_vector(prepared.chain_slope);
  w.put_vector(prepared.group_top);
  w.put_vector(prepared.wall_begin);
  w.put_vector(prepared.wall_radius);
  w.put_vector(prepared.wall_slope);

  // A checksum of everything before it: damage anywhere is refused.
  Hash sum;
  sum.bytes(w.bytes().data(), w.bytes().size());
  w.put(sum.h);

  // Whole or not at all: a private temporary file renamed into place.
  const std::string temporary = path + ".tmp" + std::to_string(::getpid());
  {
    std::ofstream out(temporary, std::ios::binary | std::ios::trunc);
    out.write(kMagic, sizeof(kMagic) - 1);
    out.write(w.bytes().data(), static_cast<std::streamsize>(w.bytes().size()));
    out.close();
    if (!out) {
      std::filesystem::remove(temporary);
      return make_error(ErrorCode::kIoError, path + ": cannot write the prepared mesh", "cache");
    }
  }
  std::error_code ec;
  std::filesystem::rename(temporary, path, ec);
  if (ec) {
    std::filesystem::remove(temporary);
    return make_error(ErrorCode::kIoError, path + ": " + ec.message(), "cache");
  }
  return Status::Ok();
}

Result<std::optional<PreparedMesh>> load_prepared(const std::string& path, const Tin& input,
                                                  const PrepareOptions& options) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec)) return std::optional<PreparedMesh>{};
  std::ifstream in(path, std::ios::binary);
  std::ostringstream buffer;
  buffer << in.rdbuf();
  const std::string bytes = buffer.str();
  auto corrupt = [&](const std::string& why) {
    return make_error(ErrorCode::kDataError, path + ": not a readable prepared mesh (" + why + ")", "cache");
  };
  const std::size_t header = sizeof(kMagic) - 1;
  if (bytes.size() < header + sizeof(std::uint64_t) || bytes.compare(0, header, kMagic) != 0)
    return corrupt("no header");
  Hash sum;
  sum.bytes(bytes.data() + header, bytes.size() - header - sizeof(std::uint64_t));
  std::uint64_t stored = 0;
  std::memcpy(&stored, bytes.data() + bytes.size() - sizeof stored, sizeof stored);
  if (stored != sum.h) return corrupt("checksum mismatch: damaged or cut short");
  const std::string body = bytes.substr(0, bytes.size() - sizeof stored);
  Reader r(body);
  if (!r.skip_magic()) return corrupt("no header");
  std::vector<double> k;
  Tin source;
  if (!r.get_vector(k) || !r.get_vector(source.vertices) || !r.get_vector(source.triangles))
    return corrupt("cut short");
  // Another mesh or other knobs (a hash collision): not this one.
  if (k != knobs(options) || source.vertices != input.vertices || source.triangles != input.triangles)
    return std::optional<PreparedMesh>{};

  PreparedMesh mesh;
  std::int32_t sectors = 0;
  std::vector<GroupRecord> groups;
  if (!r.get_vector(mesh.tin.vertices) || !r.get_vector(mesh.tin.triangles) || !r.get_vector(mesh.source_triangle) ||
      !r.get(sectors) || !r.get_vector(mesh.horizons.horizon) || !r.get_vector(groups) ||
      !r.get_vector(mesh.top_level) || !r.get(mesh.always_visible_first) || !r.get(mesh.always_visible_count) ||
      !r.get(mesh.area) || !r.get(mesh.stats) || !r.get_vector(mesh.chain_begin) || !r.get_vector(mesh.corner_t) ||
      !r.get_vector(mesh.corner_z) || !r.get_vector(mesh.chain_slope) || !r.get_vector(mesh.group_top) ||
      !r.get_vector(mesh.wall_begin) || !r.get_vector(mesh.wall_radius) || !r.get_vector(mesh.wall_slope))
    return corrupt("cut short");
  if (!r.done()) return corrupt("bytes after the end");

  // Every index the cull follows is checked, so a damaged file cannot
  // send it out of bounds.
  const std::size_t n_tri = mesh.tin.triangles.size(), n_groups = groups.size();
  const auto s = static_cast<std::size_t>(sectors);
  if (sectors != options.horizons.sectors || mesh.tin.vertices != input.vertices || n_tri != input.triangles.size() ||
      mesh.source_triangle.size() != n_tri || mesh.horizons.horizon.size() != input.vertices.size() * s ||
      mesh.always_visible_first > n_tri || mesh.always_visible_count > n_tri - mesh.always_visible_first)
    return corrupt("sizes disagree");
  for (const TinTriangle& t : mesh.tin.triangles)
    for (std::uint32_t v : t)
      if (v >= mesh.tin.vertices.size()) return corrupt("a triangle names a vertex past the end");
  for (std::size_t g = 0; g < n_groups; ++g) {
    const GroupRecord& rec = groups[g];
    if (rec.first_triangle > n_tri || rec.triangle_count > n_tri - rec.first_triangle)
      return corrupt("a group's triangles run past the end");
    const bool leaf = rec.child0 < 0 && rec.child1 < 0;
    if (!leaf && (rec.child0 < 0 || rec.child1 < 0 || static_cast<std::size_t>(rec.child0) >= g ||
                  static_cast<std::size_t>(rec.child1) >= g))
      return corrupt("a group's children are not earlier groups");
    MeshGroup group;
    group.first_triangle = rec.first_triangle;
    group.triangle_count = rec.triangle_count;
    group.children[0] = rec.child0;
    group.children[1] = rec.child1;
    group.circle = {rec.x, rec.y, rec.radius};
    mesh.groups.push_back(group);
    if ((g < mesh.stats.leaf_groups) != leaf) return corrupt("leaves are not the first groups");
  }
  for (std::uint32_t h : mesh.horizons.horizon)
    if (h != kNoHorizon && h >= mesh.tin.vertices.size()) return corrupt("a horizon names a vertex past the end");
  for (std::uint32_t g : mesh.top_level)
    if (g >= n_groups) return corrupt("a top-level group past the end");
  const std::size_t chains = n_groups * s;
  if (mesh.chain_begin.size() != chains + 1 || mesh.chain_slope.size() != chains ||
      mesh.corner_t.size() != mesh.corner_z.size() || mesh.group_top.size() != n_groups ||
      mesh.wall_begin.size() != chains + 1 || mesh.wall_radius.size() != mesh.wall_slope.size())
    return corrupt("region or wall tables disagree");
  for (std::size_t c = 0; c <= chains; ++c) {
    if (mesh.chain_begin[c] > mesh.corner_t.size() || (c > 0 && mesh.chain_begin[c] < mesh.chain_begin[c - 1]))
      return corrupt("a region's corners run past the end");
    if (mesh.wall_begin[c] > mesh.wall_radius.size() || (c > 0 && mesh.wall_begin[c] < mesh.wall_begin[c - 1]))
      return corrupt("a group's walls run past the end");
  }
  if (mesh.chain_begin.back() != mesh.corner_t.size() || mesh.wall_begin.back() != mesh.wall_radius.size())
    return corrupt("region or wall tables disagree");
  // The regions themselves, from the flat arrays.
  for (std::size_t c = 0; c < chains; ++c) {
    std::vector<ChainPoint> corners;
    for (std::uint32_t j = mesh.chain_begin[c]; j < mesh.chain_begin[c + 1]; ++j)
      corners.push_back({mesh.corner_t[j], mesh.corner_z[j]});
    auto chain = OcclusionChain::from_parts(std::move(corners), mesh.chain_slope[c]);
    if (!chain) return corrupt("a region is not a chain");
    mesh.regions.push_back(std::move(*chain));
  }
  mesh.sectors = sectors;
  mesh.horizons.sectors = sectors;
  set_sector_tables(mesh);
  set_group_columns(mesh);
  return std::optional<PreparedMesh>{std::move(mesh)};
}

Result<PreparedMesh> prepare_cached(const Tin& tin, const PrepareOptions& options, const std::string& directory,
                                    CacheUse* use, const RunControl* control) {
  CacheUse local;
  CacheUse& u = use ? *use : local;
  u = {};
  u.path = (std::filesystem::path(directory) / prepared_cache_name(tin, options)).string();
  auto loaded = load_prepared(u.path, tin, options);
  if (loaded.ok() && loaded->has_value()) {
    u.hit = true;
    return std::move(**loaded);
  }
  if (!loaded.ok()) u.note = loaded.error().message + "; prepared afresh";
  auto prepared = prepare_mesh(tin, options, control);
  if (!prepared.ok()) return prepared.error();
  std::error_code ec;
  std::filesystem::create_directories(directory, ec);
  if (ec) {
    u.note = directory + ": " + ec.message() + "; the prepared mesh was not cached";
  } else if (auto saved = save_prepared(u.path, tin, options, *prepared); !saved.ok()) {
    u.note = saved.error().message + "; the prepared mesh was not cached";
  }
  return prepared;
}

}  // namespace horizon::mesh
