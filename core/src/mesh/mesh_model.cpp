#include "horizon/mesh/mesh_model.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <thread>
#include <utility>

#include "horizon/mesh/tin_io.hpp"
#include "horizon/mesh/tin_visibility.hpp"

namespace horizon::mesh {

struct MeshModel::Parts {
  PreparedMesh prepared;
  std::vector<TinVertex> crs_vertices;
  LocalFrame frame;
  std::optional<terrain::Dem> dem;
  std::optional<TinFit> fit;
  std::unique_ptr<TinVisibility> surface;  // over prepared.tin: a mesh file's ground
  std::optional<RegisteredBoxes> boxes;
  CacheUse cache_use;
  double prepare_seconds = 0.0;
};

namespace {

template <class T>
std::uint64_t bytes_of(const std::vector<T>& v) {
  return static_cast<std::uint64_t>(v.capacity()) * sizeof(T);
}

// Prepares `tin` (already in its frame), through the cache when one is
// named; `seconds` gets the wall time.
Result<PreparedMesh> prepare(Tin tin, const MeshModelOptions& options, const RunControl* control, CacheUse& use,
                             double& seconds) {
  if (options.before_prepare) HORIZON_RETURN_IF_ERROR(options.before_prepare(tin));
  const auto started = std::chrono::steady_clock::now();
  auto prepared = options.cache_dir.empty() ? prepare_mesh(std::move(tin), options.prepare, control)
                                            : prepare_cached(tin, options.prepare, options.cache_dir, &use, control);
  seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
  return prepared;
}

}  // namespace

std::uint64_t preparation_bytes(std::uint64_t vertices, const PrepareOptions& options, unsigned threads) {
  const std::uint64_t t = threads ? threads : std::max(1u, std::thread::hardware_concurrency());
  const auto s = static_cast<std::uint64_t>(std::max(options.horizons.sectors, 1));
  const auto k = static_cast<std::uint64_t>(std::max(options.horizons.subsectors, 1));
  // A vertex: 300 bytes of TIN, triangulation, groups, regions and walls,
  // 8·s of horizons and their slopes, and per thread 200 bytes of leaf
  // arrays and hull plus 16·(k + 1) of sorts. A group (at most the cap,
  // parents as many again): its chains and walls in every sector.
  const auto groups = static_cast<std::uint64_t>(std::max(options.crystals.max_groups, 1)) * 2;
  const auto corners = static_cast<std::uint64_t>(std::max(options.max_chain_corners, 2));
  return vertices * (300 + 8 * s + t * (200 + 16 * (k + 1))) + groups * s * (corners * 24 + 96);
}

std::uint64_t memory_bytes(const PreparedMesh& m) {
  std::uint64_t bytes = bytes_of(m.tin.vertices) + bytes_of(m.tin.triangles) + bytes_of(m.source_triangle) +
                        bytes_of(m.horizons.horizon) + bytes_of(m.groups) + bytes_of(m.top_level) +
                        bytes_of(m.regions) + bytes_of(m.chain_begin) + bytes_of(m.corner_t) + bytes_of(m.corner_z) +
                        bytes_of(m.chain_slope) + bytes_of(m.group_top) + bytes_of(m.wall_begin) +
                        bytes_of(m.wall_radius) + bytes_of(m.wall_slope) + bytes_of(m.centre_directions) +
                        bytes_of(m.sector_starts) + bytes_of(m.columns.x) + bytes_of(m.columns.y) +
                        bytes_of(m.columns.radius) + bytes_of(m.columns.leaf_order) + bytes_of(m.columns.leaf_rank);
  for (const OcclusionChain& chain : m.regions) bytes += bytes_of(chain.corners());
  return bytes;
}

MeshModel::MeshModel(std::unique_ptr<Parts> parts) : p_(std::move(parts)) {}
MeshModel::MeshModel(MeshModel&&) noexcept = default;
MeshModel& MeshModel::operator=(MeshModel&&) noexcept = default;
MeshModel::~MeshModel() = default;

Result<MeshModel> MeshModel::from_dem(terrain::Dem dem, const MeshModelOptions& options, const RunControl* control) {
  auto parts = std::make_unique<Parts>();
  auto built = tin_from_dem(dem, options.greedy);
  if (!built.ok()) return built.error();
  auto frame = LocalFrame::for_dem(dem);
  if (!frame.ok()) return frame.error();
  parts->frame = std::move(*frame);
  parts->fit = built->fit;
  parts->crs_vertices = built->tin.vertices;
  Tin tin = std::move(built->tin);
  parts->frame.to_local(tin);
  auto prepared = prepare(std::move(tin), options, control, parts->cache_use, parts->prepare_seconds);
  if (!prepared.ok()) return prepared.error();
  parts->prepared = std::move(*prepared);
  parts->dem = std::move(dem);
  return MeshModel(std::move(parts));
}

Result<MeshModel> MeshModel::from_file(const std::string& path, const MeshModelOptions& options,
                                       const RunControl* control) {
  auto parts = std::make_unique<Parts>();
  auto tin = read_tin(path);
  if (!tin.ok()) return tin.error();
  parts->crs_vertices = tin->vertices;
  auto prepared = prepare(std::move(*tin), options, control, parts->cache_use, parts->prepare_seconds);
  if (!prepared.ok()) return prepared.error();
  parts->prepared = std::move(*prepared);
  parts->surface = std::make_unique<TinVisibility>(parts->prepared.tin);
  return MeshModel(std::move(parts));
}

const PreparedMesh& MeshModel::prepared() const {
  return p_->prepared;
}
const std::vector<TinVertex>& MeshModel::crs_vertices() const {
  return p_->crs_vertices;
}
const LocalFrame& MeshModel::frame() const {
  return p_->frame;
}
const terrain::Dem* MeshModel::dem() const {
  return p_->dem ? &*p_->dem : nullptr;
}
const std::optional<TinFit>& MeshModel::fit() const {
  return p_->fit;
}
const CacheUse& MeshModel::cache_use() const {
  return p_->cache_use;
}
double MeshModel::prepare_seconds() const {
  return p_->prepare_seconds;
}
const RegisteredBoxes* MeshModel::boxes() const {
  return p_->boxes ? &*p_->boxes : nullptr;
}

Result<MeshEye> MeshModel::eye(const geodesy::PointSpec& spec, const char* what) const {
  if (p_->dem) {
    auto point = geodesy::resolve_point(*p_->dem, spec, what);
    if (!point.ok()) return point.error();
    const TinVertex crs{point->x, point->y, point->elevation};
    return MeshEye{p_->frame.to_local(crs), crs, point->ground};
  }
  const std::string name = what;
  if (spec.frame != geodesy::PointFrame::kDatasetCrs)
    return make_error(ErrorCode::kInvalidArgument,
                      name + ": a mesh file has no CRS to place longitude and latitude in; give x and y of its frame",
                      name);
  if (!std::isfinite(spec.x) || !std::isfinite(spec.y) || !std::isfinite(spec.height))
    return make_error(ErrorCode::kInvalidArgument, name + ": x, y and height must be finite numbers", name);
  const std::optional<double> ground = p_->surface->height_at(spec.x, spec.y);
  if (spec.height_mode == geodesy::HeightMode::kAbsolute) {
    const TinVertex at{spec.x, spec.y, spec.height};
    return MeshEye{at, at, ground.value_or(NAN)};
  }
  if (!ground)
    return make_error(ErrorCode::kOutOfRange,
                      name + " (" + std::to_string(spec.x) + ", " + std::to_string(spec.y) +
                          ") is off the mesh: no surface to stand a height above ground on (give an altitude)",
                      name);
  const TinVertex at{spec.x, spec.y, *ground + spec.height};
  return MeshEye{at, at, *ground};
}

Status MeshModel::register_boxes(std::span<const visibility::BoxSpec> specs, unsigned threads) {
  std::vector<MeshBox> boxes;
  boxes.reserve(specs.size());
  for (std::size_t k = 0; k < specs.size(); ++k) {
    visibility::BoxSpec b = specs[k];
    if (b.frame != geodesy::PointFrame::kDatasetCrs) {
      if (!p_->dem)
        return make_error(ErrorCode::kInvalidArgument,
                          "box " + std::to_string(k) +
                              ": a mesh file has no CRS to place longitude and latitude in; give x and y of its frame",
                          "boxes");
      // Into the DEM's CRS as every query does it (visibility/cull.hpp: the
      // rectangle bounding its corners and edge midpoints), wholly on the DEM.
      const terrain::Dem& dem = *p_->dem;
      auto footprint = visibility::resolve_boxes(dem.georef, dem.width(), dem.height(), dem.source, {&b, 1});
      if (!footprint.ok()) {
        Error e = footprint.error();
        e.message = "box " + std::to_string(k) + ": " + e.message;
        e.field = "boxes";
        return e;
      }
      const terrain::GeoTransform& t = dem.georef.transform;
      const visibility::BoxFootprint& f = footprint->front();
      const double xa = t.origin_x + (f.col_min + 0.5) * t.pixel_width,
                   xb = t.origin_x + (f.col_max + 0.5) * t.pixel_width;
      const double ya = t.origin_y + (f.row_min + 0.5) * t.pixel_height,
                   yb = t.origin_y + (f.row_max + 0.5) * t.pixel_height;
      b.frame = geodesy::PointFrame::kDatasetCrs;
      b.x_min = std::min(xa, xb), b.x_max = std::max(xa, xb);
      b.y_min = std::min(ya, yb), b.y_max = std::max(ya, yb);
    }
    // The footprint's corners into the frame, and their bounding box there.
    MeshBox m{INFINITY, INFINITY, -INFINITY, -INFINITY, b.z_min, b.z_max};
    for (double x : {b.x_min, b.x_max})
      for (double y : {b.y_min, b.y_max}) {
        const TinVertex p = p_->frame.to_local({x, y, 0.0});
        m.x_min = std::min(m.x_min, p.x), m.x_max = std::max(m.x_max, p.x);
        m.y_min = std::min(m.y_min, p.y), m.y_max = std::max(m.y_max, p.y);
      }
    if (!(b.x_min <= b.x_max) || !(b.y_min <= b.y_max)) m = {NAN, NAN, NAN, NAN, b.z_min, b.z_max};
    boxes.push_back(m);
  }
  auto registered = RegisteredBoxes::make(p_->prepared, boxes, threads);
  if (!registered.ok()) return registered.error();
  p_->boxes = std::move(*registered);
  return Status::Ok();
}

std::uint64_t MeshModel::memory_bytes() const {
  std::uint64_t bytes = mesh::memory_bytes(p_->prepared) + bytes_of(p_->crs_vertices);
  if (p_->dem)
    bytes +=
        static_cast<std::uint64_t>(p_->dem->width()) * static_cast<std::uint64_t>(p_->dem->height()) * sizeof(float);
  if (p_->surface) bytes += p_->surface->memory_bytes();
  if (p_->boxes) bytes += p_->boxes->memory_bytes();
  return bytes;
}

}  // namespace horizon::mesh
