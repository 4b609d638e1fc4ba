#include "remote/client.hpp"

#include <cmath>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>

#include <grpcpp/create_channel.h>
#include <grpcpp/security/credentials.h>
#include <grpcpp/support/channel_arguments.h>

#include "commands/command.hpp"
#include "google/rpc/error_details.pb.h"
#include "google/rpc/status.pb.h"

namespace horizon::cli::remote {
namespace {

// A PEM or token file's text; UsageError naming `flag` when it cannot be read.
std::string read_text(const std::string& path, const char* flag) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw UsageError(std::string(flag) + ": cannot read '" + path + "'");
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

}  // namespace

Client::Client(const Args& args) {
  address_ = args.text("--server").value_or("");
  if (address_.empty() || address_.find(':') == std::string::npos)
    throw UsageError("--server: expected HOST:PORT, got '" + address_ + "'");
  if (auto d = args.non_negative("--deadline")) {
    if (*d <= 0)
      throw UsageError("--deadline: expected a positive number of seconds, got '" + *args.text("--deadline") + "'");
    deadline_seconds_ = *d;
  }
  grpc::ChannelArguments channel_args;
  channel_args.SetMaxReceiveMessageSize(256 << 20);  // big LineOfSight profiles and CullBoxes answers
  channel_args.SetMaxSendMessageSize(256 << 20);
  std::shared_ptr<grpc::ChannelCredentials> credentials = grpc::InsecureChannelCredentials();
  if (auto ca = args.text("--ca")) {
    grpc::SslCredentialsOptions tls;
    tls.pem_root_certs = read_text(*ca, "--ca");
    if (auto pair = args.text("--client-cert")) {
      const auto comma = pair->find(',');
      if (comma == std::string::npos) throw UsageError("--client-cert: expected CERT.pem,KEY.pem, got '" + *pair + "'");
      tls.pem_cert_chain = read_text(pair->substr(0, comma), "--client-cert");
      tls.pem_private_key = read_text(pair->substr(comma + 1), "--client-cert");
    }
    credentials = grpc::SslCredentials(tls);
  } else if (args.has("--client-cert")) {
    throw UsageError("--client-cert needs --ca (a client certificate is presented over TLS)");
  }
  if (auto file = args.text("--token-file")) {
    const std::string text = read_text(*file, "--token-file");
    token_ = text.substr(0, text.find_first_of("\r\n"));
    if (token_.empty()) throw UsageError("--token-file: '" + *file + "' starts with an empty line");
  } else if (const char* env = std::getenv("HORIZON_TOKEN"); env && *env) {
    token_ = env;
  }
  auto channel = grpc::CreateCustomChannel(address_, credentials, channel_args);
  datasets_ = v1::DatasetService::NewStub(channel);
  visibility_ = v1::VisibilityService::NewStub(channel);
  sessions_ = v1::SessionService::NewStub(channel);
  traces_ = v1::TraceService::NewStub(channel);
  meshes_ = v1::MeshService::NewStub(channel);
}

grpc::Status Client::get_dataset(const std::string& name, v1::Dataset& out) {
  v1::GetDatasetRequest request;
  request.set_name(name);
  return datasets_->GetDataset(context().get(), request, &out);
}

std::unique_ptr<grpc::ClientContext> Client::context() const {
  auto context = std::make_unique<grpc::ClientContext>();
  if (!token_.empty()) context->AddMetadata("authorization", "Bearer " + token_);
  context->set_deadline(std::chrono::system_clock::now() +
                        std::chrono::duration_cast<std::chrono::system_clock::duration>(
                            std::chrono::duration<double>(deadline_seconds_)));
  return context;
}

int report_status(const grpc::Status& status, const std::string& address) {
  std::string field;
  google::rpc::Status details;
  if (!status.error_details().empty() && details.ParseFromString(status.error_details())) {
    for (const auto& any : details.details()) {
      google::rpc::BadRequest bad;
      if (any.UnpackTo(&bad) && bad.field_violations_size() > 0) field = bad.field_violations(0).field();
      google::rpc::QuotaFailure quota;
      if (any.UnpackTo(&quota) && quota.violations_size() > 0) field = quota.violations(0).subject();
    }
  }
  static const char* kNames[] = {
      "OK",        "CANCELLED",      "UNKNOWN",           "INVALID_ARGUMENT",   "DEADLINE_EXCEEDED",
      "NOT_FOUND", "ALREADY_EXISTS", "PERMISSION_DENIED", "RESOURCE_EXHAUSTED", "FAILED_PRECONDITION",
      "ABORTED",   "OUT_OF_RANGE",   "UNIMPLEMENTED",     "INTERNAL",           "UNAVAILABLE",
      "DATA_LOSS", "UNAUTHENTICATED"};
  const int code = static_cast<int>(status.error_code());
  const char* name = code >= 0 && code <= 16 ? kNames[code] : "UNKNOWN";
  std::fprintf(stderr, "horizon: error: %s (%s from %s%s%s)\n", status.error_message().c_str(), name, address.c_str(),
               field.empty() ? "" : ", field ", field.c_str());
  return status.error_code() == grpc::StatusCode::INVALID_ARGUMENT ? kExitUsage : kExitFailure;
}

geodesy::GridPoint to_grid_point(const v1::ResolvedPoint& p) {
  geodesy::GridPoint g;
  g.col = p.col();
  g.row = p.row();
  g.x = p.x();
  g.y = p.y();
  g.ground = p.ground();
  g.elevation = p.elevation();
  return g;
}

std::optional<geodesy::LonLat> to_lonlat(const v1::ResolvedPoint& p) {
  if (!p.has_lon() || !p.has_lat()) return std::nullopt;
  return geodesy::LonLat{p.lon(), p.lat()};
}

visibility::WorkStats to_stats(const v1::WorkStats& s) {
  visibility::WorkStats w;
  w.dem_cells = s.dem_cells();
  w.window_cells = s.window_cells();
  w.cells_evaluated = s.cells_evaluated();
  w.terrain_samples = s.terrain_samples();
  w.rays = s.rays();
  w.seconds = s.seconds();
  if (!s.backend().empty()) w.backend = s.backend();  // empty from a daemon older than the field: the CPU
  w.gpu_fallback = s.gpu_fallback();
  w.device_seconds = s.device_seconds();
  w.gpu_variant = s.gpu_variant();
  return w;
}

v1::Box to_proto_box(const visibility::BoxSpec& b) {
  v1::Box out;
  out.set_frame(b.frame == geodesy::PointFrame::kWgs84 ? v1::FRAME_WGS84 : v1::FRAME_DATASET_CRS);
  out.set_x_min(b.x_min);
  out.set_y_min(b.y_min);
  out.set_x_max(b.x_max);
  out.set_y_max(b.y_max);
  out.set_z_min(b.z_min);
  out.set_z_max(b.z_max);
  return out;
}

v1::Point to_proto_point(const geodesy::PointSpec& spec) {
  v1::Point p;
  p.set_frame(spec.frame == geodesy::PointFrame::kWgs84 ? v1::FRAME_WGS84 : v1::FRAME_DATASET_CRS);
  p.set_x(spec.x);
  p.set_y(spec.y);
  p.set_height(spec.height);
  p.set_height_mode(spec.height_mode == geodesy::HeightMode::kAbsolute ? v1::HEIGHT_MODE_ABSOLUTE
                                                                       : v1::HEIGHT_MODE_ABOVE_GROUND);
  if (spec.ground == geodesy::GroundSample::kCell) p.set_ground(v1::GROUND_SAMPLE_CELL);
  return p;
}

v1::Algorithm to_proto_algorithm(visibility::Algorithm algorithm) {
  switch (algorithm) {
    case visibility::Algorithm::kRadial:
      return v1::ALGORITHM_FAST;
    case visibility::Algorithm::kExact:
      return v1::ALGORITHM_EXACT;
    case visibility::Algorithm::kConservative:
      return v1::ALGORITHM_CONSERVATIVE;
    case visibility::Algorithm::kR3:
      return v1::ALGORITHM_R3;
  }
  return v1::ALGORITHM_UNSPECIFIED;
}

v1::Backend to_proto_backend(visibility::Backend backend) {
  switch (backend) {
    case visibility::Backend::kAuto:
      return v1::BACKEND_AUTO;
    case visibility::Backend::kCpu:
      return v1::BACKEND_CPU;
    case visibility::Backend::kGpu:
      return v1::BACKEND_GPU;
  }
  return v1::BACKEND_UNSPECIFIED;
}

v1::GpuMethod to_proto_gpu_method(visibility::GpuMethod method) {
  switch (method) {
    case visibility::GpuMethod::kFragment:
      return v1::GPU_METHOD_FRAGMENT;
    case visibility::GpuMethod::kCompute:
      return v1::GPU_METHOD_COMPUTE;
  }
  return v1::GPU_METHOD_UNSPECIFIED;
}

void fill_options(const visibility::ViewshedOptions& options, v1::ViewshedOptions& o) {
  o.set_target_height(options.target_height);
  if (std::isfinite(options.max_distance)) o.set_max_distance(options.max_distance);
  o.set_curvature(options.curvature_coefficient);
  o.set_nodata(options.nodata == visibility::NodataPolicy::kFill ? v1::NODATA_POLICY_FILL
                                                                 : v1::NODATA_POLICY_TRANSPARENT);
  o.set_nodata_fill_height(options.nodata_fill_height);
  o.set_algorithm(to_proto_algorithm(options.algorithm));
  o.set_ray_spacing(options.radial.ray_spacing);
  const visibility::FieldOfView& view = options.field_of_view;
  o.set_azimuth_start(view.azimuth_start);
  o.set_azimuth_end(view.azimuth_end);
  o.set_min_distance(view.min_distance);
  if (view.limits_pitch()) {
    o.set_pitch_min(view.pitch_min);
    o.set_pitch_max(view.pitch_max);
  }
}

v1::RasterKind to_proto_raster(visibility::ViewshedOutput output) {
  switch (output) {
    case visibility::ViewshedOutput::kVisibility:
      return v1::RASTER_KIND_VISIBLE;
    case visibility::ViewshedOutput::kBoolean:
      return v1::RASTER_KIND_BOOLEAN;
    case visibility::ViewshedOutput::kOhf:
      return v1::RASTER_KIND_OHF;
    case visibility::ViewshedOutput::kMinTargetHeight:
      return v1::RASTER_KIND_MIN_TARGET_HEIGHT;
    case visibility::ViewshedOutput::kVerticalAngle:
      return v1::RASTER_KIND_VERTICAL_ANGLE;
    case visibility::ViewshedOutput::kElevationDifference:
      return v1::RASTER_KIND_ELEVATION_DIFFERENCE;
  }
  return v1::RASTER_KIND_UNSPECIFIED;
}

v1::GeotiffFormat to_proto_format(terrain::TiffFormat format) {
  return format == terrain::TiffFormat::kCog ? v1::GEOTIFF_FORMAT_COG : v1::GEOTIFF_FORMAT_GTIFF;
}

}  // namespace horizon::cli::remote
