// request_log.hpp — one structured (JSON) line per request and per daemon
// event, on stderr, written whole under a lock so lines never interleave.
//
//   {"ts":"2024-05-01T12:00:00.123Z","level":"info","event":"request","method":"CullBoxes",
//    "dataset":"everest","cells":44521,"boxes":10000,"lines":0,"algorithm":"fast","backend":"cpu",
//    "gpu_fallback":"","duration_ms":7.41,"status":"OK","message":""}
//
// level: "info" for OK, "warn" for errors the client caused or asked for
// (INVALID_ARGUMENT, NOT_FOUND, OUT_OF_RANGE, RESOURCE_EXHAUSTED,
// CANCELLED, DEADLINE_EXCEEDED, ...) and for an OK answer the CPU gave after
// the GPU asked for failed (gpu_fallback says what failed), "error" for the
// daemon's own failures (INTERNAL, UNKNOWN, DATA_LOSS, UNAVAILABLE at run time).
// String fields are cut at 1 KiB (the rest noted by its length): a client
// cannot make a line longer than a few KiB.
#pragma once

#include <cstdint>
#include <initializer_list>
#include <string>
#include <string_view>
#include <utility>

namespace horizon::server {

struct RequestRecord {
  std::string_view method;
  std::string dataset;
  std::uint64_t cells = 0;   // cells evaluated (viewshed/culling window)
  std::uint64_t boxes = 0;
  std::uint64_t lines = 0;
  std::string algorithm;
  std::string backend = "cpu";  // where the OHF was computed: "cpu" or "gpu"
  std::string gpu_fallback;     // why the GPU asked for did not answer; empty when it did, or was not asked
  double duration_ms = 0;
  std::string_view status;   // gRPC code name, "OK", "INVALID_ARGUMENT", ...
  std::string message;
  bool server_fault = false;  // logs at level "error"
};

void log_request(const RequestRecord& record);

// A daemon event: {"ts":..,"level":level,"event":event, <fields as strings or numbers>}.
// `fields` values are JSON text already (numbers) when `raw` is true, else strings.
struct LogField {
  std::string_view key;
  std::string value;
  bool raw = false;  // value is a JSON number/literal, not a string
};
void log_event(std::string_view level, std::string_view event, std::initializer_list<LogField> fields);

}  // namespace horizon::server
