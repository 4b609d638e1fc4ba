// mesh_service.hpp — horizon.v1.MeshService: per-frame culling of the TIN
// meshes the daemon prepared at load (protos/horizon/v1/mesh.proto,
// meshes.hpp). DescribeMesh and CullMesh run on the worker pool as unary calls
// (unary_call.hpp: admission, deadlines, the log line); the culling
// itself is core's mesh/cull.hpp, read from the mesh's snapshot, which the
// call holds to its end. ListMeshes answers at once from the snapshot.
#pragma once

#include "horizon/v1/mesh.grpc.pb.h"
#include "server_env.hpp"

namespace horizon::server {

// The most vertices, and triangles, one DescribeMesh page holds: about
// 2 MiB of message, under gRPC's 4 MiB default receive limit.
inline constexpr std::uint32_t kMaxMeshPage = 65'536;

class MeshService final : public v1::MeshService::CallbackService {
 public:
  explicit MeshService(ServerEnv& env) : env_(env) {}

  grpc::ServerUnaryReactor* ListMeshes(grpc::CallbackServerContext* context, const v1::ListMeshesRequest* request,
                                       v1::ListMeshesResponse* response) override;
  grpc::ServerUnaryReactor* DescribeMesh(grpc::CallbackServerContext* context, const v1::DescribeMeshRequest* request,
                                         v1::DescribeMeshResponse* response) override;
  grpc::ServerUnaryReactor* CullMesh(grpc::CallbackServerContext* context, const v1::CullMeshRequest* request,
                                     v1::CullMeshResponse* response) override;

 private:
  ServerEnv& env_;
};

}  // namespace horizon::server
