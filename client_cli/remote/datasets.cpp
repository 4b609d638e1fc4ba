// `horizon datasets --server HOST:PORT`: every dataset the daemon holds, page by page,
// and every mesh it serves.
#include <iostream>

#include "commands/command.hpp"
#include "output.hpp"
#include "remote/client.hpp"
#include "remote/module_abi.hpp"

namespace horizon::cli::remote {

int impl::run_datasets(const Args& args, bool json) {
  Client client(args);
  const int page_size = args.positive_integer("--page-size").value_or(100);
  std::vector<v1::Dataset> all;
  v1::ListDatasetsRequest request;
  request.set_page_size(page_size);
  do {
    v1::ListDatasetsResponse page;
    if (auto s = client.datasets().ListDatasets(client.context().get(), request, &page); !s.ok())
      return report_status(s, client.address());
    for (const v1::Dataset& d : page.datasets()) all.push_back(d);
    request.set_page_token(page.next_page_token());
  } while (!request.page_token().empty());
  v1::ListMeshesResponse meshes;
  if (auto s = client.meshes().ListMeshes(client.context().get(), v1::ListMeshesRequest(), &meshes); !s.ok())
    return report_status(s, client.address());

  if (json) {
    Json list = Json::array();
    for (const v1::Dataset& d : all)
      list.push_back({{"name", d.name()},
                      {"source", d.source()},
                      {"width", d.width()},
                      {"height", d.height()},
                      {"epsg", d.epsg() ? Json(d.epsg()) : Json(nullptr)},
                      {"crs_name", d.crs_name().empty() ? Json(nullptr) : Json(d.crs_name())},
                      {"cell_size_m", {{"x", d.cell_size_x_m()}, {"y", d.cell_size_y_m()}}},
                      {"elevation", d.has_elevation_min() ? Json{{"min", d.elevation_min()}, {"max", d.elevation_max()}}
                                                          : Json(nullptr)},
                      {"resident_bytes", d.resident_bytes()}});
    Json mesh_list = Json::array();
    for (const v1::MeshSummary& m : meshes.meshes())
      mesh_list.push_back({{"name", m.name()},
                           {"source", m.source()},
                           {"vertices", m.vertices()},
                           {"triangles", m.triangles()},
                           {"groups", m.leaf_groups()},
                           {"resident_bytes", m.resident_bytes()}});
    print_json(Json{{"server", client.address()}, {"datasets", std::move(list)}, {"meshes", std::move(mesh_list)}});
    return kExitOk;
  }
  std::cout << all.size() << " datasets on " << client.address() << '\n';
  for (const v1::Dataset& d : all)
    std::cout << "  " << d.name() << ": " << d.width() << " x " << d.height() << " cells, "
              << (d.epsg()               ? "EPSG:" + std::to_string(d.epsg())
                  : d.crs_name().empty() ? std::string("no CRS")
                                         : "'" + d.crs_name() + "'")
              << ", " << fixed(d.cell_size_x_m(), 1) << " m cells, " << with_separators(d.resident_bytes())
              << " bytes resident (" << d.source() << ")\n";
  if (meshes.meshes_size() > 0) {
    std::cout << meshes.meshes_size() << " meshes\n";
    for (const v1::MeshSummary& m : meshes.meshes())
      std::cout << "  " << m.name() << ": " << m.vertices() << " vertices, " << m.triangles() << " triangles, "
                << m.leaf_groups() << " groups, " << with_separators(m.resident_bytes()) << " bytes resident ("
                << m.source() << ")\n";
  }
  return kExitOk;
}

}  // namespace horizon::cli::remote
