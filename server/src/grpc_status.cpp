#include "grpc_status.hpp"

#include "google/rpc/error_details.pb.h"
#include "google/rpc/status.pb.h"

namespace horizon::server {

grpc::StatusCode grpc_code(ErrorCode code) {
  switch (code) {
    case ErrorCode::kInvalidArgument: return grpc::StatusCode::INVALID_ARGUMENT;
    case ErrorCode::kNotFound: return grpc::StatusCode::NOT_FOUND;
    case ErrorCode::kOutOfRange: return grpc::StatusCode::OUT_OF_RANGE;
    case ErrorCode::kUnsupported: return grpc::StatusCode::FAILED_PRECONDITION;
    case ErrorCode::kDataError: return grpc::StatusCode::FAILED_PRECONDITION;
    case ErrorCode::kResourceExhausted: return grpc::StatusCode::RESOURCE_EXHAUSTED;
    case ErrorCode::kCancelled: return grpc::StatusCode::CANCELLED;
    case ErrorCode::kDeadlineExceeded: return grpc::StatusCode::DEADLINE_EXCEEDED;
    case ErrorCode::kIoError: return grpc::StatusCode::INTERNAL;
    case ErrorCode::kInternal: return grpc::StatusCode::INTERNAL;
  }
  return grpc::StatusCode::INTERNAL;
}

grpc::Status to_grpc_status(const Error& error) {
  const grpc::StatusCode code = grpc_code(error.code);
  google::rpc::Status status;
  status.set_code(static_cast<int>(code));
  status.set_message(error.message);
  if (!error.field.empty()) {
    switch (error.code) {
      case ErrorCode::kInvalidArgument:
      case ErrorCode::kOutOfRange:
      case ErrorCode::kUnsupported:
      case ErrorCode::kDataError: {
        google::rpc::BadRequest bad;
        auto* v = bad.add_field_violations();
        v->set_field(error.field);
        v->set_description(error.message);
        status.add_details()->PackFrom(bad);
        break;
      }
      case ErrorCode::kResourceExhausted: {
        google::rpc::QuotaFailure quota;
        auto* v = quota.add_violations();
        v->set_subject(error.field);
        v->set_description(error.message);
        status.add_details()->PackFrom(quota);
        break;
      }
      case ErrorCode::kNotFound: {
        google::rpc::ResourceInfo info;
        info.set_resource_type("horizon.v1.Dataset");
        info.set_resource_name(error.field);
        info.set_description(error.message);
        status.add_details()->PackFrom(info);
        break;
      }
      default:
        break;
    }
  }
  if (status.details_size() == 0) return grpc::Status(code, error.message);
  return grpc::Status(code, error.message, status.SerializeAsString());
}

const char* grpc_code_name(grpc::StatusCode code) {
  switch (code) {
    case grpc::StatusCode::OK: return "OK";
    case grpc::StatusCode::CANCELLED: return "CANCELLED";
    case grpc::StatusCode::UNKNOWN: return "UNKNOWN";
    case grpc::StatusCode::INVALID_ARGUMENT: return "INVALID_ARGUMENT";
    case grpc::StatusCode::DEADLINE_EXCEEDED: return "DEADLINE_EXCEEDED";
    case grpc::StatusCode::NOT_FOUND: return "NOT_FOUND";
    case grpc::StatusCode::ALREADY_EXISTS: return "ALREADY_EXISTS";
    case grpc::StatusCode::PERMISSION_DENIED: return "PERMISSION_DENIED";
    case grpc::StatusCode::UNAUTHENTICATED: return "UNAUTHENTICATED";
    case grpc::StatusCode::RESOURCE_EXHAUSTED: return "RESOURCE_EXHAUSTED";
    case grpc::StatusCode::FAILED_PRECONDITION: return "FAILED_PRECONDITION";
    case grpc::StatusCode::ABORTED: return "ABORTED";
    case grpc::StatusCode::OUT_OF_RANGE: return "OUT_OF_RANGE";
    case grpc::StatusCode::UNIMPLEMENTED: return "UNIMPLEMENTED";
    case grpc::StatusCode::INTERNAL: return "INTERNAL";
    case grpc::StatusCode::UNAVAILABLE: return "UNAVAILABLE";
    case grpc::StatusCode::DATA_LOSS: return "DATA_LOSS";
    default: return "UNKNOWN";
  }
}

bool is_server_fault(grpc::StatusCode code) {
  return code == grpc::StatusCode::INTERNAL || code == grpc::StatusCode::UNKNOWN ||
         code == grpc::StatusCode::DATA_LOSS;
}

}  // namespace horizon::server
