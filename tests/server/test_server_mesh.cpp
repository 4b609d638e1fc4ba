// MeshService through a real horizond: meshes configured in "meshes" are
// prepared at load (a DEM dataset's TIN and an OBJ file), and CullMesh
// answers exactly what the embedded engine answers for the same TIN, knobs
// and viewpoint (every drawn run and count, both modes, with a frustum);
// DescribeMesh gives the prepared order page by page; registered boxes are
// answered; wrong fields are refused naming them; a second daemon prepares
// from the disk cache.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>
#include "daemon_process.hpp"

#include "horizon/mesh/cull.hpp"
#include "horizon/mesh/mesh_model.hpp"
#include "horizon/terrain/dem_reader.hpp"
#include "horizon/v1/mesh.grpc.pb.h"
#include "rpc_helpers.hpp"

namespace horizon::testing {
namespace {

constexpr const char* kAndes = "ecuador_andes_utm17s_10m_383x415.tif";
constexpr double kX = 713500, kY = 9558500;  // inside the Ecuador crop (UTM 17S)

// A crater 3 km across as a 61 x 61 lattice (50 m apart): a floor at 0 m
// inside radius 400 m, a rim 300 m high from 500 to 900 m, the plains at
// 0 m beyond 1 000 m. Written as OBJ.
void write_crater(const std::string& path) {
  std::ofstream out(path);
  const int n = 61;
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      const double x = i * 50.0, y = j * 50.0, d = std::hypot(x - 1500, y - 1500);
      const double z = d < 400 || d > 1000 ? 0.0 : d < 500 ? 3 * (d - 400) : d > 900 ? 3 * (1000 - d) : 300.0;
      out << "v " << x << ' ' << y << ' ' << z << '\n';
    }
  for (int j = 0; j + 1 < n; ++j)
    for (int i = 0; i + 1 < n; ++i) {
      const int a = j * n + i + 1, b = a + 1, c = a + n, d = c + 1;
      out << "f " << a << ' ' << b << ' ' << d << "\nf " << a << ' ' << d << ' ' << c << '\n';
    }
}

class ServerMesh : public ::testing::Test {
 protected:
  void SetUp() override {
    root_ = std::make_unique<TempDir>();
    std::filesystem::copy_file(bundled_dem(kAndes), root_->file(kAndes));
    write_crater(root_->file("crater.obj"));
    cache_ = root_->file("mesh_cache");
    daemon_ = start_daemon();
    ASSERT_TRUE(daemon_->ready()) << daemon_->error();
    meshes_ = v1::MeshService::NewStub(daemon_->channel());
  }

  std::unique_ptr<DaemonProcess> start_daemon() {
    DaemonOptions o;
    o.data_root = root_->path().string();
    o.datasets = {{"andes", kAndes}};
    o.extra_json = R"("meshes": {"andes_tin": {"dataset": "andes", "vertices": 3000, "seeds": 200},
                                 "crater": {"file": "crater.obj",
                                            "boxes": [[1490, 1490, 1510, 1510, 0, 20],
                                                      [2900, 1490, 2920, 1510, 0, 20]]}},
                    "mesh_cache_dir": ")" +
                   cache_ + "\",";
    return std::make_unique<DaemonProcess>(o);
  }

  // The embedded twin of the daemon's andes_tin.
  static mesh::MeshModel embedded_andes() {
    auto dem = terrain::read_dem(bundled_dem(kAndes));
    EXPECT_TRUE(dem.ok());
    mesh::MeshModelOptions options;
    options.greedy.max_vertices = 3000;
    options.prepare.crystals.seeds = 200;
    auto model = mesh::MeshModel::from_dem(std::move(*dem), options);
    EXPECT_TRUE(model.ok()) << model.error().message;
    return std::move(*model);
  }

  grpc::Status cull(const v1::CullMeshRequest& request, v1::CullMeshResponse& response) {
    return meshes_->CullMesh(context_with_deadline().get(), request, &response);
  }

  std::unique_ptr<TempDir> root_;
  std::string cache_;
  std::unique_ptr<DaemonProcess> daemon_;
  std::unique_ptr<v1::MeshService::Stub> meshes_;
};

TEST_F(ServerMesh, CullMeshAnswersWhatTheEngineAnswers) {
  const mesh::MeshModel model = embedded_andes();
  struct Case {
    double x, y, height;
    v1::CullMode mode;
    std::optional<std::pair<double, double>> view;
  };
  const Case cases[] = {{kX, kY, 2, v1::CULL_MODE_APPROXIMATE, std::nullopt},
                        {kX, kY, 2, v1::CULL_MODE_CONSERVATIVE, std::nullopt},
                        {713900, 9558950, 10, v1::CULL_MODE_APPROXIMATE, std::pair{300.0, 60.0}},
                        {713900, 9558950, 10, v1::CULL_MODE_CONSERVATIVE, std::pair{90.0, 180.0}}};
  std::uint64_t culled_somewhere = 0;
  for (const Case& c : cases) {
    v1::CullMeshRequest request;
    request.set_mesh("andes_tin");
    *request.mutable_observer() = point(c.x, c.y, c.height);
    request.set_mode(c.mode);
    mesh::CullQuery query;
    if (c.view) {
      request.set_azimuth_from(c.view->first);
      request.set_azimuth_to(c.view->second);
      query.azimuth_from = c.view->first, query.azimuth_to = c.view->second;
    }
    v1::CullMeshResponse response;
    const grpc::Status status = cull(request, response);
    ASSERT_TRUE(status.ok()) << status.error_message();

    geodesy::PointSpec spec;
    spec.x = c.x, spec.y = c.y, spec.height = c.height;
    auto eye = model.eye(spec);
    ASSERT_TRUE(eye.ok());
    query.camera = eye->local;
    query.mode = c.mode == v1::CULL_MODE_CONSERVATIVE ? mesh::CullMode::kConservative : mesh::CullMode::kApproximate;
    auto answer = mesh::cull(model.prepared(), query);
    ASSERT_TRUE(answer.ok());
    ASSERT_EQ(response.drawn_groups_size(), static_cast<int>(answer->visible_groups.size()));
    for (int i = 0; i < response.drawn_groups_size(); ++i) {
      const std::uint32_t g = answer->visible_groups[static_cast<std::size_t>(i)];
      EXPECT_EQ(response.drawn_groups(i), g);
      EXPECT_EQ(response.drawn(i).first_triangle(), model.prepared().groups[g].first_triangle);
      EXPECT_EQ(response.drawn(i).triangle_count(), model.prepared().groups[g].triangle_count);
    }
    EXPECT_EQ(response.groups_tested(), answer->groups_tested);
    EXPECT_EQ(response.groups_culled(), answer->groups_culled);
    EXPECT_EQ(response.frustum_culled(), answer->frustum_culled);
    EXPECT_EQ(response.triangles_culled(), answer->triangles_culled);
    EXPECT_EQ(response.triangles_drawn(), answer->triangles_visible);
    EXPECT_EQ(response.triangles_culled() + response.triangles_drawn(), model.prepared().tin.triangles.size());
    EXPECT_DOUBLE_EQ(response.observer().z(), eye->crs.z);
    culled_somewhere += response.triangles_culled();
  }
  EXPECT_GT(culled_somewhere, 0u);  // the comparison is not between two empty answers
}

TEST_F(ServerMesh, DescribeMeshGivesThePreparedOrderPageByPage) {
  const mesh::MeshModel model = embedded_andes();
  const mesh::PreparedMesh& p = model.prepared();
  v1::DescribeMeshRequest request;
  request.set_mesh("andes_tin");
  request.set_vertex_offset(100);
  request.set_vertex_count(50);
  request.set_triangle_offset(static_cast<std::uint32_t>(p.tin.triangles.size() - 10));
  request.set_triangle_count(1000);  // past the end: what there is
  v1::DescribeMeshResponse response;
  const grpc::Status status = meshes_->DescribeMesh(context_with_deadline().get(), request, &response);
  ASSERT_TRUE(status.ok()) << status.error_message();
  EXPECT_EQ(response.source(), "dataset:andes");
  EXPECT_EQ(response.vertices(), p.tin.vertices.size());
  EXPECT_EQ(response.triangles(), p.tin.triangles.size());
  EXPECT_EQ(response.leaf_groups(), p.stats.leaf_groups);
  EXPECT_EQ(response.knobs().seeds(), 200u);
  EXPECT_EQ(response.knobs().sectors(), 16u);
  EXPECT_EQ(response.frame(), "crs");
  ASSERT_TRUE(response.has_fit_max_error_m());
  EXPECT_DOUBLE_EQ(response.fit_max_error_m(), model.fit()->max_error);
  EXPECT_GT(response.resident_bytes(), 0u);
  ASSERT_EQ(response.groups_size(), static_cast<int>(p.stats.leaf_groups));
  ASSERT_EQ(response.vertex_page_size(), 50);
  for (int i = 0; i < 50; ++i) {
    EXPECT_EQ(response.vertex_page(i).x(), model.crs_vertices()[100 + static_cast<std::size_t>(i)].x);
    EXPECT_EQ(response.vertex_page(i).z(), model.crs_vertices()[100 + static_cast<std::size_t>(i)].z);
  }
  ASSERT_EQ(response.triangle_page_size(), 10);
  for (int i = 0; i < 10; ++i) {
    const mesh::TinTriangle& t = p.tin.triangles[p.tin.triangles.size() - 10 + static_cast<std::size_t>(i)];
    EXPECT_EQ(response.triangle_page(i).a(), t[0]);
    EXPECT_EQ(response.triangle_page(i).c(), t[2]);
  }

  request.set_triangle_count(65'537);
  const grpc::Status big = meshes_->DescribeMesh(context_with_deadline().get(), request, &response);
  EXPECT_EQ(big.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_EQ(violated_field(big), "triangle_count");
}

TEST_F(ServerMesh, AMeshFileTakesPointsInItsFrameAndAnswersItsBoxes) {
  // On the plains outside the rim, 2 m up: part of the crater floor is
  // culled, and so is the box on it; the box beside the eye is not.
  v1::CullMeshRequest request;
  request.set_mesh("crater");
  *request.mutable_observer() = point(2800, 1500, 2);
  request.set_mode(v1::CULL_MODE_CONSERVATIVE);
  request.set_include_boxes(true);
  v1::CullMeshResponse outside;
  grpc::Status status = cull(request, outside);
  ASSERT_TRUE(status.ok()) << status.error_message();
  EXPECT_DOUBLE_EQ(outside.observer_ground(), 0.0);
  EXPECT_DOUBLE_EQ(outside.observer().z(), 2.0);
  EXPECT_GT(outside.triangles_culled(), 0u);
  ASSERT_EQ(outside.box_hidden_size(), 2);
  EXPECT_TRUE(outside.box_hidden(0));
  EXPECT_FALSE(outside.box_hidden(1));
  EXPECT_EQ(outside.boxes_hidden(), 1u);

  // On the crater floor: the other way round.
  *request.mutable_observer() = point(1500, 1500, 2);
  v1::CullMeshResponse inside;
  ASSERT_TRUE(cull(request, inside).ok());
  EXPECT_GT(inside.triangles_culled(), 0u);
  EXPECT_FALSE(inside.box_hidden(0));
  EXPECT_TRUE(inside.box_hidden(1));

  // From far above, nothing is hidden.
  *request.mutable_observer() = point(1500, 1500, 5000);
  v1::CullMeshResponse above;
  ASSERT_TRUE(cull(request, above).ok());
  EXPECT_EQ(above.triangles_culled(), 0u);
  EXPECT_EQ(above.boxes_hidden(), 0u);

  // No CRS: longitude and latitude are refused; off the mesh there is no ground to stand on.
  *request.mutable_observer() = point(-78.5, -0.2, 2, v1::FRAME_WGS84);
  v1::CullMeshResponse refused;
  status = cull(request, refused);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT) << status.error_message();
  EXPECT_EQ(violated_field(status), "observer");
  *request.mutable_observer() = point(5000, 500, 2);
  status = cull(request, refused);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::OUT_OF_RANGE) << status.error_message();
  EXPECT_NE(status.error_message().find("off the mesh"), std::string::npos) << status.error_message();
}

TEST_F(ServerMesh, WrongFieldsAreRefusedNamingThem) {
  v1::CullMeshRequest request;
  v1::CullMeshResponse response;
  request.set_mesh("nowhere");
  *request.mutable_observer() = point(kX, kY);
  EXPECT_EQ(cull(request, response).error_code(), grpc::StatusCode::NOT_FOUND);
  request.set_mesh("");
  grpc::Status status = cull(request, response);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_EQ(violated_field(status), "mesh");

  request.set_mesh("andes_tin");
  request.set_azimuth_from(10);
  status = cull(request, response);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_EQ(violated_field(status), "azimuth_to");
  request.clear_azimuth_from();

  request.set_include_boxes(true);  // andes_tin has none registered
  status = cull(request, response);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_EQ(violated_field(status), "include_boxes");
  request.set_include_boxes(false);

  request.clear_observer();
  status = cull(request, response);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_EQ(violated_field(status), "observer");
  *request.mutable_observer() = point(0, 0);  // far off the DEM
  status = cull(request, response);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::OUT_OF_RANGE) << status.error_message();
}

TEST_F(ServerMesh, ASecondDaemonPreparesFromTheDiskCache) {
  EXPECT_TRUE(daemon_->wait_for_log("\"event\":\"mesh_prepared\"")) << daemon_->log();
  EXPECT_NE(daemon_->log().find("\"from_cache\":false"), std::string::npos) << daemon_->log();
  daemon_.reset();
  auto again = start_daemon();
  ASSERT_TRUE(again->ready()) << again->error();
  const std::string log = again->log();
  EXPECT_EQ(log.find("\"from_cache\":false"), std::string::npos) << log;
  EXPECT_NE(log.find("\"from_cache\":true"), std::string::npos) << log;
  auto stub = v1::MeshService::NewStub(again->channel());
  v1::DescribeMeshRequest request;
  request.set_mesh("crater");
  v1::DescribeMeshResponse response;
  ASSERT_TRUE(stub->DescribeMesh(context_with_deadline().get(), request, &response).ok());
  EXPECT_TRUE(response.from_cache());
  EXPECT_EQ(response.registered_boxes(), 2u);
  EXPECT_EQ(response.source(), "file:crater.obj");
}

TEST_F(ServerMesh, ListMeshesNamesEveryMeshAndTheCliShowsThem) {
  v1::ListMeshesResponse list;
  ASSERT_TRUE(meshes_->ListMeshes(context_with_deadline().get(), v1::ListMeshesRequest(), &list).ok());
  ASSERT_EQ(list.meshes_size(), 2);
  EXPECT_EQ(list.meshes(0).name(), "andes_tin");  // in name order
  EXPECT_EQ(list.meshes(0).source(), "dataset:andes");
  EXPECT_EQ(list.meshes(0).vertices(), 3000u);
  EXPECT_GT(list.meshes(0).leaf_groups(), 0u);
  EXPECT_GT(list.meshes(0).resident_bytes(), 0u);
  EXPECT_EQ(list.meshes(1).name(), "crater");
  EXPECT_EQ(list.meshes(1).vertices(), 61u * 61u);
  EXPECT_EQ(list.meshes(1).triangles(), 2u * 60u * 60u);

  const CommandResult cli =
      run_command(std::string(HORIZON_CLI_PATH) + " datasets --server " + daemon_->address() + " --json");
  ASSERT_EQ(cli.exit_code, 0) << cli.output;
  const auto j = nlohmann::json::parse(cli.output);
  ASSERT_EQ(j["meshes"].size(), 2u);
  EXPECT_EQ(j["meshes"][1]["name"], "crater");
  EXPECT_EQ(j["meshes"][1]["source"], "file:crater.obj");
  EXPECT_EQ(j["datasets"].size(), 1u);
}

// `horizon mesh cull MESH --server`: the same groups and counts as the CLI
// culling its own TIN of the same DEM with the same knobs.
TEST_F(ServerMesh, TheCliCullsTheDaemonsMeshAsItCullsItsOwn) {
  const std::string eye = " --observer 713900,9558950 --height 10 --azimuth 300,60 --json";
  const CommandResult local = run_command(std::string(HORIZON_CLI_PATH) + " mesh cull " + root_->file(kAndes) +
                                          " --vertices 3000 --seeds 200" + eye);
  ASSERT_EQ(local.exit_code, 0) << local.output;
  const CommandResult remote =
      run_command(std::string(HORIZON_CLI_PATH) + " mesh cull andes_tin --server " + daemon_->address() + eye);
  ASSERT_EQ(remote.exit_code, 0) << remote.output;
  const auto a = nlohmann::json::parse(local.output), b = nlohmann::json::parse(remote.output);
  EXPECT_EQ(a["drawn_groups"], b["drawn_groups"]);
  EXPECT_EQ(a["always_visible"], b["always_visible"]);
  for (const char* key : {"groups_tested", "groups_culled", "frustum_culled", "triangles_culled", "triangles_drawn"})
    EXPECT_EQ(a["cull"][key], b["cull"][key]) << key;
  EXPECT_GT(b["cull"]["frustum_culled"].get<int>(), 0);
  EXPECT_EQ(a["vertices"], b["vertices"]);
  EXPECT_EQ(a["options"], b["options"]);

  // The daemon's knobs are its config's: a local knob is refused with --server.
  const CommandResult knob = run_command(std::string(HORIZON_CLI_PATH) + " mesh cull andes_tin --server " +
                                         daemon_->address() + " --sectors 8/1" + eye);
  EXPECT_EQ(knob.exit_code, 2) << knob.output;
  EXPECT_NE(knob.output.find("--sectors: applies to a local input"), std::string::npos) << knob.output;
}

}  // namespace
}  // namespace horizon::testing
