// rpc_helpers.hpp — small helpers for calling a test daemon through the
// generated stubs and reading the google.rpc details of its errors.
#pragma once

#include <chrono>
#include <future>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include <grpcpp/client_context.h>
#include <grpcpp/generic/generic_stub.h>
#include <grpcpp/support/byte_buffer.h>

#include "google/rpc/error_details.pb.h"
#include "google/rpc/status.pb.h"
#include "horizon/v1/datasets.grpc.pb.h"
#include "horizon/v1/visibility.grpc.pb.h"

namespace horizon::testing {

inline std::unique_ptr<grpc::ClientContext> context_with_deadline(std::chrono::milliseconds deadline = std::chrono::seconds(30)) {
  auto c = std::make_unique<grpc::ClientContext>();
  c->set_deadline(std::chrono::system_clock::now() + deadline);
  return c;
}

// A unary call of `method` ("/package.Service/Method") whose request is
// `request`'s bytes as they are: a message no stub would send, or one of a
// service outside our protos. The response's bytes go to `response` when
// it is given and the call succeeds.
inline grpc::Status raw_unary_call(grpc::GenericStub& stub, const std::string& method, const std::string& request,
                                   std::chrono::milliseconds deadline, std::string* response = nullptr) {
  grpc::Slice slice(request);
  grpc::ByteBuffer in(&slice, 1), out;
  grpc::ClientContext context;
  context.set_deadline(std::chrono::system_clock::now() + deadline);
  std::promise<grpc::Status> done;
  stub.UnaryCall(&context, method, grpc::StubOptions(), &in, &out,
                 [&done](grpc::Status status) { done.set_value(std::move(status)); });
  const grpc::Status status = done.get_future().get();
  if (status.ok() && response) {
    std::vector<grpc::Slice> slices;
    if (!out.Dump(&slices).ok())
      return grpc::Status(grpc::StatusCode::INTERNAL, "the response's bytes were unreadable");
    response->clear();
    for (const grpc::Slice& s : slices) response->append(reinterpret_cast<const char*>(s.begin()), s.size());
  }
  return status;
}

// The field named by a BadRequest (or the subject of a QuotaFailure) in the status details; "" if none.
inline std::string violated_field(const grpc::Status& status) {
  google::rpc::Status details;
  if (status.error_details().empty() || !details.ParseFromString(status.error_details())) return "";
  for (const auto& any : details.details()) {
    google::rpc::BadRequest bad;
    if (any.UnpackTo(&bad) && bad.field_violations_size() > 0) return bad.field_violations(0).field();
    google::rpc::QuotaFailure quota;
    if (any.UnpackTo(&quota) && quota.violations_size() > 0) return quota.violations(0).subject();
  }
  return "";
}

inline v1::Point point(double x, double y, double height = 2.0, v1::Frame frame = v1::FRAME_DATASET_CRS) {
  v1::Point p;
  p.set_frame(frame);
  p.set_x(x);
  p.set_y(y);
  p.set_height(height);
  return p;
}

}  // namespace horizon::testing
