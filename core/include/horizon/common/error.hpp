// horizon/common/error.hpp — the engine's error channel for bad input.
//
// Two channels, never mixed:
//   * our own bugs are assert()ed;
//   * anything a user can get wrong (a file, a request field, a CLI flag, a
//     config key) comes back as an Error inside a Result<T> / Status, whose
//     message names what was wrong ("dem 'x.tif': band 3 requested, file has 1").
// Core never throws across its public API. Only server/ maps ErrorCode to gRPC
// status codes; the CLI maps it to exit code 1.
#pragma once

#include <cassert>
#include <cstdint>
#include <string>
#include <utility>
#include <variant>

namespace horizon {

enum class ErrorCode {
  kInvalidArgument,    // a parameter or field is malformed (NaN, negative distance, ...)
  kNotFound,           // a file or dataset does not exist
  kOutOfRange,         // a position lies outside the data (observer outside the DEM)
  kUnsupported,        // well-formed but not handled (CRS, pixel type, rotated transform)
  kDataError,          // a file exists but its content is wrong (not a raster, truncated)
  kIoError,            // the operating system refused a read or write
  kCancelled,          // the caller's CancelToken fired
  kDeadlineExceeded,   // the caller's deadline passed
  kResourceExhausted,  // a configured limit (cells, memory) would be exceeded
  kInternal,           // a library we call failed in a way we did not foresee
};

// Short stable name of a code ("invalid_argument"), for logs and JSON.
const char* error_code_name(ErrorCode code);

struct Error {
  ErrorCode code = ErrorCode::kInternal;
  std::string message;  // full sentence for a person; names the file/field/cell
  std::string field;    // the offending input's name ("observer", "max_distance", a path); may be empty
};

// A number as messages write it: printf's %.*g with `significant` digits
// ("0.5", "1e+06", "3e+38").
std::string number_text(double value, int significant = 6);

// A size as messages write it: whole MiB, rounded up ("13 MiB").
std::string mib_text(std::uint64_t bytes);

inline Error make_error(ErrorCode code, std::string message, std::string field = {}) {
  return Error{code, std::move(message), std::move(field)};
}

// Result<T>: a value or an Error. Cheap to move; check ok() before value().
template <class T>
class [[nodiscard]] Result {
 public:
  Result(T value) : v_(std::move(value)) {}          // NOLINT(google-explicit-constructor)
  Result(Error error) : v_(std::move(error)) {}      // NOLINT(google-explicit-constructor)

  bool ok() const { return v_.index() == 0; }
  explicit operator bool() const { return ok(); }

  T& value() & { assert(ok()); return std::get<0>(v_); }
  const T& value() const& { assert(ok()); return std::get<0>(v_); }
  T&& value() && { assert(ok()); return std::get<0>(std::move(v_)); }
  T* operator->() { return &value(); }
  const T* operator->() const { return &value(); }
  T& operator*() & { return value(); }
  const T& operator*() const& { return value(); }

  const Error& error() const { assert(!ok()); return std::get<1>(v_); }

 private:
  std::variant<T, Error> v_;
};

// Status: success or an Error.
class [[nodiscard]] Status {
 public:
  Status() = default;
  Status(Error error) : error_(std::move(error)), ok_(false) {}  // NOLINT(google-explicit-constructor)
  static Status Ok() { return Status(); }

  bool ok() const { return ok_; }
  explicit operator bool() const { return ok_; }
  const Error& error() const { assert(!ok_); return error_; }

 private:
  Error error_;
  bool ok_ = true;
};

}  // namespace horizon

// Propagate an error from a Status/Result expression to the caller.
#define HORIZON_RETURN_IF_ERROR(expr)              \
  do {                                             \
    auto&& horizon_status_ = (expr);               \
    if (!horizon_status_.ok()) return horizon_status_.error(); \
  } while (0)
