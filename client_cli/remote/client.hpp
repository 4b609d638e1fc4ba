// client.hpp — the gRPC side of --server: a channel to the daemon, call
// contexts with the command's deadline, and the daemon's errors reported the
// way embedded mode reports the engine's.
#pragma once

#include <memory>
#include <optional>
#include <string>

#include <grpcpp/client_context.h>
#include <grpcpp/support/status.h>

#include "args.hpp"
#include "horizon/geodesy/crs.hpp"
#include "horizon/geodesy/observer.hpp"
#include "horizon/terrain/geotiff_options.hpp"
#include "horizon/v1/datasets.grpc.pb.h"
#include "horizon/v1/mesh.grpc.pb.h"
#include "horizon/v1/session.grpc.pb.h"
#include "horizon/v1/trace.grpc.pb.h"
#include "horizon/v1/visibility.grpc.pb.h"
#include "horizon/visibility/cull.hpp"
#include "horizon/visibility/options.hpp"
#include "horizon/visibility/viewshed_outputs.hpp"
#include "horizon/visibility/work_stats.hpp"

namespace horizon::cli::remote {

class Client {
 public:
  // Reads --server, --deadline, --ca, --client-cert and --token-file
  // (UsageError when malformed or unreadable). Without --ca the channel is
  // plaintext; the token, when given, goes with every call.
  explicit Client(const Args& args);

  const std::string& address() const { return address_; }
  // A context carrying the deadline (and the bearer token).
  std::unique_ptr<grpc::ClientContext> context() const;

  v1::DatasetService::Stub& datasets() { return *datasets_; }
  // GetDataset for `name` into `out`, under context()'s deadline.
  grpc::Status get_dataset(const std::string& name, v1::Dataset& out);
  v1::VisibilityService::Stub& visibility() { return *visibility_; }
  v1::SessionService::Stub& sessions() { return *sessions_; }
  v1::TraceService::Stub& traces() { return *traces_; }
  v1::MeshService::Stub& meshes() { return *meshes_; }

 private:
  std::string address_;
  double deadline_seconds_ = 60.0;
  std::string token_;
  std::unique_ptr<v1::DatasetService::Stub> datasets_;
  std::unique_ptr<v1::VisibilityService::Stub> visibility_;
  std::unique_ptr<v1::SessionService::Stub> sessions_;
  std::unique_ptr<v1::TraceService::Stub> traces_;
  std::unique_ptr<v1::MeshService::Stub> meshes_;
};

// Prints "horizon: error: <message> (<CODE> from HOST:PORT[, field F])" and
// returns the exit status: 2 for INVALID_ARGUMENT (a request the daemon found
// malformed is a usage error), 1 otherwise.
int report_status(const grpc::Status& status, const std::string& address);

// The daemon's answer in engine terms, so the embedded printers can be reused.
geodesy::GridPoint to_grid_point(const v1::ResolvedPoint& p);
std::optional<geodesy::LonLat> to_lonlat(const v1::ResolvedPoint& p);
visibility::WorkStats to_stats(const v1::WorkStats& s);

v1::Point to_proto_point(const geodesy::PointSpec& spec);
v1::Box to_proto_box(const visibility::BoxSpec& box);
v1::Algorithm to_proto_algorithm(visibility::Algorithm algorithm);
v1::Backend to_proto_backend(visibility::Backend backend);
v1::GpuMethod to_proto_gpu_method(visibility::GpuMethod method);
// The options every viewshed request shares (target height, reach,
// curvature, nodata, algorithm, ray spacing, field of view); backend and GPU
// are the caller's.
void fill_options(const visibility::ViewshedOptions& options, v1::ViewshedOptions& out);
v1::RasterKind to_proto_raster(visibility::ViewshedOutput output);
v1::GeotiffFormat to_proto_format(terrain::TiffFormat format);

}  // namespace horizon::cli::remote
