// grpc_status.hpp — the daemon's only mapping from engine errors to gRPC
// status codes, with google.rpc error details (the gRPC/Google error model):
//
//   ErrorCode            gRPC code             details
//   kInvalidArgument     INVALID_ARGUMENT      BadRequest{field, description}
//   kNotFound            NOT_FOUND             ResourceInfo (datasets)
//   kOutOfRange          OUT_OF_RANGE          BadRequest
//   kUnsupported         FAILED_PRECONDITION   BadRequest when a field is named
//   kDataError           FAILED_PRECONDITION   BadRequest when a field is named
//   kResourceExhausted   RESOURCE_EXHAUSTED    QuotaFailure{subject = field}
//   kCancelled           CANCELLED
//   kDeadlineExceeded    DEADLINE_EXCEEDED
//   kIoError, kInternal  INTERNAL
//
// The details travel, serialized as google.rpc.Status, in the
// grpc-status-details-bin trailer, where every gRPC client library finds them.
#pragma once

#include <string>

#include <grpcpp/support/status.h>

#include "horizon/common/error.hpp"

namespace horizon::server {

grpc::StatusCode grpc_code(ErrorCode code);
// The status for `error`; error.field, when set, becomes the violation's field.
grpc::Status to_grpc_status(const Error& error);
// gRPC's name of a code ("INVALID_ARGUMENT"), for logs and metrics.
const char* grpc_code_name(grpc::StatusCode code);
// True for codes that mean the daemon itself failed (logged as errors).
bool is_server_fault(grpc::StatusCode code);

}  // namespace horizon::server
