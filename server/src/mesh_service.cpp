#include "mesh_service.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <string>

#include "arena_allocator.hpp"
#include "call_scope.hpp"
#include "grpc_status.hpp"
#include "horizon/mesh/cull.hpp"
#include "translate.hpp"
#include "unary_call.hpp"

namespace horizon::server {
namespace {

// Message bytes per item of an answer (protobuf's repeated fields and their
// encodings, with room): a triangle run or group index, a vertex, a
// triangle, a box flag.
constexpr std::uint64_t kBytesPerRun = 48;
constexpr std::uint64_t kBytesPerVertex = 64;
constexpr std::uint64_t kBytesPerTriangle = 48;

// The mesh by name, from a snapshot the caller keeps for the call.
Result<std::shared_ptr<const ServedMesh>> find_mesh(const MeshSet& set, const std::string& name,
                                                    RequestRecord& record) {
  record.dataset = name.substr(0, kMaxDatasetName);
  return find_by_name(set, name, "mesh");
}

void fill_run(std::uint32_t first, std::uint32_t count, v1::TriangleRun& out) {
  out.set_first_triangle(first);
  out.set_triangle_count(count);
}

grpc::Status describe(CallScope& scope, const MeshSet& set, const v1::DescribeMeshRequest& request,
                      v1::DescribeMeshResponse& response) {
  auto found = find_mesh(set, request.mesh(), scope.record());
  if (!found.ok()) return scope.status_of(found.error());
  const ServedMesh& served = **found;
  const mesh::MeshModel& model = served.model;
  const mesh::PreparedMesh& p = model.prepared();
  response.set_name(served.config.name);
  response.set_source(served.source);
  response.set_vertices(static_cast<std::uint32_t>(p.tin.vertices.size()));
  response.set_triangles(static_cast<std::uint32_t>(p.tin.triangles.size()));
  v1::MeshKnobs& k = *response.mutable_knobs();
  const mesh::PrepareOptions& o = served.config.prepare;
  k.set_sectors(static_cast<std::uint32_t>(o.horizons.sectors));
  k.set_subsectors(static_cast<std::uint32_t>(o.horizons.subsectors));
  k.set_seeds(static_cast<std::uint32_t>(o.crystals.seeds));
  k.set_min_group(static_cast<std::uint32_t>(o.crystals.min_group_size));
  k.set_max_groups(static_cast<std::uint32_t>(o.crystals.max_groups));
  k.set_orphan_passes(static_cast<std::uint32_t>(o.crystals.max_orphan_passes));
  k.set_merge_cutoff(o.merge_cutoff);
  k.set_random_seed(o.crystals.random_seed);
  if (model.fit()) {
    response.set_fit_max_error_m(model.fit()->max_error);
    response.set_fit_rmse_m(model.fit()->rmse);
  }
  response.set_frame(model.frame().geographic() ? "tangent plane" : "crs");
  response.set_leaf_groups(p.stats.leaf_groups);
  response.set_nodes(static_cast<std::uint32_t>(p.groups.size()));
  response.set_levels(p.stats.levels);
  fill_run(p.always_visible_first, p.always_visible_count, *response.mutable_always_visible());
  response.mutable_groups()->Reserve(static_cast<int>(p.stats.leaf_groups));
  for (const mesh::MeshGroup& g : p.groups)
    if (g.leaf()) fill_run(g.first_triangle, g.triangle_count, *response.add_groups());
  response.set_registered_boxes(model.boxes() ? static_cast<std::uint32_t>(model.boxes()->size()) : 0);
  response.set_prepare_seconds(model.prepare_seconds());
  response.set_from_cache(model.cache_use().hit);
  response.set_resident_bytes(served.memory.bytes());

  const std::vector<mesh::TinVertex>& vertices = model.crs_vertices();
  const std::size_t v_end =
      std::min<std::size_t>(vertices.size(), std::size_t{request.vertex_offset()} + request.vertex_count());
  for (std::size_t v = request.vertex_offset(); v < v_end; ++v) {
    v1::MeshVertex& out = *response.add_vertex_page();
    out.set_x(vertices[v].x);
    out.set_y(vertices[v].y);
    out.set_z(vertices[v].z);
  }
  const std::size_t t_end =
      std::min<std::size_t>(p.tin.triangles.size(), std::size_t{request.triangle_offset()} + request.triangle_count());
  for (std::size_t t = request.triangle_offset(); t < t_end; ++t) {
    v1::MeshTriangle& out = *response.add_triangle_page();
    out.set_a(p.tin.triangles[t][0]);
    out.set_b(p.tin.triangles[t][1]);
    out.set_c(p.tin.triangles[t][2]);
  }
  return grpc::Status::OK;
}

grpc::Status cull(CallScope& scope, const MeshSet& set, const v1::CullMeshRequest& request,
                  v1::CullMeshResponse& response) {
  auto found = find_mesh(set, request.mesh(), scope.record());
  if (!found.ok()) return scope.status_of(found.error());
  const mesh::MeshModel& model = (*found)->model;
  if (!request.has_observer())
    return scope.status_of(make_error(ErrorCode::kInvalidArgument, "observer: required", "observer"));
  auto spec = to_point_spec(request.observer(), "observer");
  if (!spec.ok()) return scope.status_of(spec.error());
  if (request.has_azimuth_from() != request.has_azimuth_to())
    return scope.status_of(make_error(ErrorCode::kInvalidArgument,
                                      "azimuth_from and azimuth_to: give both (the view) or neither (all round)",
                                      request.has_azimuth_from() ? "azimuth_to" : "azimuth_from"));
  if (request.include_boxes() && !model.boxes())
    return scope.status_of(make_error(ErrorCode::kInvalidArgument,
                                      "include_boxes: mesh '" + request.mesh() +
                                          "' has no registered boxes (config meshes." + request.mesh() + ".boxes)",
                                      "include_boxes"));
  auto eye = model.eye(*spec, "observer");
  if (!eye.ok()) return scope.status_of(eye.error());

  mesh::CullQuery query;
  query.camera = eye->local;
  query.mode =
      request.mode() == v1::CULL_MODE_CONSERVATIVE ? mesh::CullMode::kConservative : mesh::CullMode::kApproximate;
  if (request.has_azimuth_from()) query.azimuth_from = request.azimuth_from(), query.azimuth_to = request.azimuth_to();
  scope.record().algorithm = query.mode == mesh::CullMode::kConservative ? "mesh_conservative" : "mesh_approximate";
  const auto started = std::chrono::steady_clock::now();
  auto answer = mesh::cull(model.prepared(), query);
  if (!answer.ok()) return scope.status_of(answer.error());
  const mesh::PreparedMesh& p = model.prepared();
  response.mutable_drawn()->Reserve(static_cast<int>(answer->visible_groups.size()));
  response.mutable_drawn_groups()->Reserve(static_cast<int>(answer->visible_groups.size()));
  for (std::uint32_t g : answer->visible_groups) {
    fill_run(p.groups[g].first_triangle, p.groups[g].triangle_count, *response.add_drawn());
    response.add_drawn_groups(g);
  }
  if (request.include_boxes()) {
    const mesh::RegisteredBoxes& boxes = *model.boxes();
    std::uint32_t hidden = 0;
    response.mutable_box_hidden()->Reserve(static_cast<int>(boxes.size()));
    for (std::size_t k = 0; k < boxes.size(); ++k) {
      const bool h = boxes.hidden(p, k, eye->local);
      hidden += h ? 1 : 0;
      response.add_box_hidden(h);
    }
    response.set_boxes_hidden(hidden);
  }
  response.set_cull_microseconds(
      std::chrono::duration<double, std::micro>(std::chrono::steady_clock::now() - started).count());
  fill_run(p.always_visible_first, p.always_visible_count, *response.mutable_always_visible());
  response.set_groups_tested(answer->groups_tested);
  response.set_groups_culled(answer->groups_culled);
  response.set_frustum_culled(answer->frustum_culled);
  response.set_triangles_culled(answer->triangles_culled);
  response.set_triangles_drawn(answer->triangles_visible);
  v1::MeshVertex& at = *response.mutable_observer();
  at.set_x(eye->crs.x);
  at.set_y(eye->crs.y);
  at.set_z(eye->crs.z);
  response.set_observer_ground(eye->ground);
  return grpc::Status::OK;
}

}  // namespace

grpc::ServerUnaryReactor* MeshService::ListMeshes(grpc::CallbackServerContext* context,
                                                  const v1::ListMeshesRequest* request,
                                                  v1::ListMeshesResponse* response) {
  auto* reactor = context->DefaultReactor();
  CallScope scope(env_, context, "ListMeshes");
  grpc::Status status = grpc::Status::OK;
  if (auto refused = scope.admit(*request)) {
    status = *refused;
  } else {
    for (const auto& [name, served] : *env_.meshes.snapshot()) {
      const mesh::PreparedMesh& p = served->model.prepared();
      v1::MeshSummary& out = *response->add_meshes();
      out.set_name(name);
      out.set_source(served->source);
      out.set_vertices(static_cast<std::uint32_t>(p.tin.vertices.size()));
      out.set_triangles(static_cast<std::uint32_t>(p.tin.triangles.size()));
      out.set_leaf_groups(p.stats.leaf_groups);
      out.set_resident_bytes(served->memory.bytes());
    }
  }
  scope.finish(status);
  reactor->Finish(status);
  return reactor;
}

grpc::ServerUnaryReactor* MeshService::DescribeMesh(grpc::CallbackServerContext* context,
                                                    const v1::DescribeMeshRequest* request,
                                                    v1::DescribeMeshResponse* response) {
  // Bounded before the call queues: a page is at most kMaxMeshPage of each.
  if (request->vertex_count() > kMaxMeshPage || request->triangle_count() > kMaxMeshPage) {
    auto* reactor = context->DefaultReactor();
    CallScope scope(env_, context, "DescribeMesh");
    const char* field = request->vertex_count() > kMaxMeshPage ? "vertex_count" : "triangle_count";
    const grpc::Status status = to_grpc_status(make_error(
        ErrorCode::kInvalidArgument,
        std::string(field) + ": at most " + std::to_string(kMaxMeshPage) + " a page (ask for the next page after)",
        field));
    scope.finish(status);
    reactor->Finish(status);
    return reactor;
  }
  auto set = env_.meshes.snapshot();
  std::uint64_t groups = 0;
  if (auto it = set->find(request->mesh()); it != set->end()) groups = it->second->model.prepared().stats.leaf_groups;
  const std::uint64_t messages = held_bytes(*request) + groups * kBytesPerRun +
                                 std::uint64_t{request->vertex_count()} * kBytesPerVertex +
                                 std::uint64_t{request->triangle_count()} * kBytesPerTriangle;
  return UnaryCall::start(env_, context, "DescribeMesh", *request, messages, 0, {},
                          [set = std::move(set), request, response](CallScope& scope) {
                            return describe(scope, *set, *request, *response);
                          });
}

grpc::ServerUnaryReactor* MeshService::CullMesh(grpc::CallbackServerContext* context,
                                                const v1::CullMeshRequest* request, v1::CullMeshResponse* response) {
  auto set = env_.meshes.snapshot();
  std::uint64_t groups = 0, boxes = 0;
  if (auto it = set->find(request->mesh()); it != set->end()) {
    groups = it->second->model.prepared().stats.leaf_groups;
    boxes = it->second->model.boxes() ? it->second->model.boxes()->size() : 0;
  }
  // The request, and an answer of every leaf drawn (a run and an index each) and every box's flag.
  const std::uint64_t messages = held_bytes(*request) + groups * kBytesPerRun + boxes;
  return UnaryCall::start(
      env_, context, "CullMesh", *request, messages, 0, {},
      [set = std::move(set), request, response](CallScope& scope) { return cull(scope, *set, *request, *response); });
}

}  // namespace horizon::server
