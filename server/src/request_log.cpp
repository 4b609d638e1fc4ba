// Structured log lines (nlohmann-json kept to this file).
#include "request_log.hpp"

#include <chrono>
#include <cstdio>
#include <cmath>
#include <ctime>
#include <mutex>

#include <nlohmann/json.hpp>

namespace horizon::server {
namespace {

std::mutex g_mutex;

std::string timestamp() {
  const auto now = std::chrono::system_clock::now();
  const std::time_t t = std::chrono::system_clock::to_time_t(now);
  const auto ms = std::chrono::duration_cast<std::chrono::milliseconds>(now.time_since_epoch()).count() % 1000;
  std::tm tm{};
  gmtime_r(&t, &tm);
  char buffer[96];
  std::snprintf(buffer, sizeof buffer, "%04d-%02d-%02dT%02d:%02d:%02d.%03dZ", tm.tm_year + 1900, tm.tm_mon + 1,
                tm.tm_mday, tm.tm_hour, tm.tm_min, tm.tm_sec, static_cast<int>(ms));
  return buffer;
}

void emit(const nlohmann::ordered_json& j) {
  const std::string line = j.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace) + "\n";
  std::lock_guard lock(g_mutex);
  std::fwrite(line.data(), 1, line.size(), stderr);
  std::fflush(stderr);
}

// A string field as logged: at most kMaxFieldBytes of it, then how long it was.
std::string bounded(std::string_view text) {
  constexpr std::size_t kMaxFieldBytes = 1024;
  if (text.size() <= kMaxFieldBytes) return std::string(text);
  return std::string(text.substr(0, kMaxFieldBytes)) + "... (" + std::to_string(text.size()) + " bytes)";
}

std::string_view level_for(const RequestRecord& r) {
  if (r.server_fault) return "error";
  return r.status == "OK" && r.gpu_fallback.empty() ? "info" : "warn";
}

}  // namespace

void log_request(const RequestRecord& r) {
  nlohmann::ordered_json j;
  j["ts"] = timestamp();
  j["level"] = level_for(r);
  j["event"] = "request";
  j["method"] = r.method;
  j["dataset"] = bounded(r.dataset);
  j["cells"] = r.cells;
  j["boxes"] = r.boxes;
  j["lines"] = r.lines;
  j["algorithm"] = r.algorithm;
  j["backend"] = r.backend;
  j["gpu_fallback"] = bounded(r.gpu_fallback);
  j["duration_ms"] = std::round(r.duration_ms * 1000.0) / 1000.0;
  j["status"] = r.status;
  j["message"] = bounded(r.message);
  emit(j);
}

void log_event(std::string_view level, std::string_view event, std::initializer_list<LogField> fields) {
  nlohmann::ordered_json j;
  j["ts"] = timestamp();
  j["level"] = level;
  j["event"] = event;
  for (const LogField& f : fields) {
    if (f.raw)
      j[std::string(f.key)] = nlohmann::ordered_json::parse(f.value, nullptr, false);
    else
      j[std::string(f.key)] = bounded(f.value);
  }
  emit(j);
}

}  // namespace horizon::server
