// Error names and RunControl polling.
#include "horizon/common/error.hpp"

#include <cstdio>

#include "horizon/common/control.hpp"

namespace horizon {

std::string number_text(double value, int significant) {
  char buffer[64];
  std::snprintf(buffer, sizeof buffer, "%.*g", significant, value);
  return buffer;
}

std::string mib_text(std::uint64_t bytes) {
  return std::to_string((bytes + (1 << 20) - 1) >> 20) + " MiB";
}

const char* error_code_name(ErrorCode code) {
  switch (code) {
    case ErrorCode::kInvalidArgument: return "invalid_argument";
    case ErrorCode::kNotFound: return "not_found";
    case ErrorCode::kOutOfRange: return "out_of_range";
    case ErrorCode::kUnsupported: return "unsupported";
    case ErrorCode::kDataError: return "data_error";
    case ErrorCode::kIoError: return "io_error";
    case ErrorCode::kCancelled: return "cancelled";
    case ErrorCode::kDeadlineExceeded: return "deadline_exceeded";
    case ErrorCode::kResourceExhausted: return "resource_exhausted";
    case ErrorCode::kInternal: return "internal";
  }
  return "internal";
}

Status RunControl::check() const {
  if (cancel && cancel->cancelled()) return make_error(ErrorCode::kCancelled, "the request was cancelled");
  if (deadline && std::chrono::steady_clock::now() >= *deadline)
    return make_error(ErrorCode::kDeadlineExceeded, "the request's deadline passed before the computation finished");
  return Status::Ok();
}

}  // namespace horizon
