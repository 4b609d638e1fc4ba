// `horizon mesh cull MESH --server HOST:PORT ...`: DescribeMesh for the
// mesh's facts, then one CullMesh; the report has embedded mode's shape.
#include <chrono>
#include <cmath>
#include <iostream>

#include "commands/command.hpp"
#include "output.hpp"
#include "remote/client.hpp"
#include "remote/module_abi.hpp"

namespace horizon::cli::remote {

int impl::run_mesh_cull(const Args& args, const MeshCullInputs& inputs) {
  Client client(args);
  const auto started = std::chrono::steady_clock::now();
  v1::DescribeMeshRequest describe;
  describe.set_mesh(inputs.mesh);
  v1::DescribeMeshResponse facts;
  if (auto s = client.meshes().DescribeMesh(client.context().get(), describe, &facts); !s.ok())
    return report_status(s, client.address());

  v1::CullMeshRequest request;
  request.set_mesh(inputs.mesh);
  *request.mutable_observer() = to_proto_point(inputs.observer);
  if (inputs.azimuth_from) {
    request.set_azimuth_from(*inputs.azimuth_from);
    request.set_azimuth_to(*inputs.azimuth_to);
  }
  request.set_mode(inputs.conservative ? v1::CULL_MODE_CONSERVATIVE : v1::CULL_MODE_APPROXIMATE);
  request.set_include_boxes(inputs.boxes);
  v1::CullMeshResponse response;
  if (auto s = client.meshes().CullMesh(client.context().get(), request, &response); !s.ok())
    return report_status(s, client.address());

  Json report;
  report["input"] = inputs.mesh;
  report["server"] = client.address();
  report["source"] = facts.source();
  report["vertices"] = facts.vertices();
  report["triangles"] = facts.triangles();
  if (facts.has_fit_max_error_m())
    report["fit"] = {{"max_error_m", facts.fit_max_error_m()}, {"rmse_m", facts.fit_rmse_m()}};
  report["local_frame"] = facts.frame() == "tangent plane" ? "tangent plane at the DEM's centre" : "the CRS";
  const v1::MeshKnobs& k = facts.knobs();
  report["options"] = {
      {"sectors", k.sectors()},           {"subsectors", k.subsectors()},  {"seeds", k.seeds()},
      {"min_group", k.min_group()},       {"max_groups", k.max_groups()},  {"orphan_passes", k.orphan_passes()},
      {"merge_cutoff", k.merge_cutoff()}, {"random_seed", k.random_seed()}};
  report["prepare"] = {{"seconds", facts.prepare_seconds()},
                       {"from_cache", facts.from_cache()},
                       {"groups", facts.leaf_groups()},
                       {"nodes", facts.nodes()},
                       {"levels", facts.levels()},
                       {"always_visible_triangles", facts.always_visible().triangle_count()},
                       {"resident_bytes", facts.resident_bytes()}};
  report["observer"] = {{"x", response.observer().x()},
                        {"y", response.observer().y()},
                        {"z", response.observer().z()},
                        {"ground", finite_or_null(response.observer_ground())}};
  report["mode"] = inputs.conservative ? "conservative" : "approximate";
  report["cull"] = {{"microseconds", response.cull_microseconds()},    {"groups_tested", response.groups_tested()},
                    {"groups_culled", response.groups_culled()},       {"frustum_culled", response.frustum_culled()},
                    {"triangles_culled", response.triangles_culled()}, {"triangles_drawn", response.triangles_drawn()}};
  Json drawn = Json::array();
  for (int i = 0; i < response.drawn_size(); ++i)
    drawn.push_back({{"group", response.drawn_groups(i)},
                     {"first_triangle", response.drawn(i).first_triangle()},
                     {"triangle_count", response.drawn(i).triangle_count()}});
  report["drawn_groups"] = drawn;
  report["always_visible"] = {{"first_triangle", response.always_visible().first_triangle()},
                              {"triangle_count", response.always_visible().triangle_count()}};
  if (inputs.boxes) {
    Json list = Json::array();
    for (int i = 0; i < response.box_hidden_size(); ++i)
      list.push_back({{"index", i}, {"hidden", response.box_hidden(i)}});
    report["boxes"] = {{"registered", true},
                       {"count", response.box_hidden_size()},
                       {"hidden_count", response.boxes_hidden()},
                       {"boxes", list}};
  }
  report["total_seconds"] = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
  if (inputs.json) {
    std::cout << report.dump(2) << '\n';
    return kExitOk;
  }
  std::cout << "mesh " << inputs.mesh << " on " << client.address() << " (" << facts.source()
            << "): " << facts.vertices() << " vertices, " << facts.triangles() << " triangles, " << facts.leaf_groups()
            << " groups (" << k.sectors() << '/' << k.subsectors() << ")\n"
            << "  culled:    " << response.triangles_culled() << " triangles in " << response.groups_culled() << " of "
            << response.groups_tested() << " groups tested (" << report["mode"].get<std::string>() << ", "
            << fixed(response.cull_microseconds(), 1) << " us on the server)\n"
            << "  drawn:     " << response.triangles_drawn() << " triangles in " << response.drawn_size()
            << " groups and the always-visible set\n";
  if (inputs.boxes)
    std::cout << "  boxes:     " << response.boxes_hidden() << " of " << response.box_hidden_size()
              << " registered boxes hidden (walls; sound)\n";
  return kExitOk;
}

}  // namespace horizon::cli::remote
