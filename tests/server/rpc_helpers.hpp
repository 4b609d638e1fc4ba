// rpc_helpers.hpp — small helpers for calling a test daemon through the
// generated stubs and reading the google.rpc details of its errors.
#pragma once

#include <chrono>
#include <memory>
#include <string>

#include <grpcpp/client_context.h>

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
