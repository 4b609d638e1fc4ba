// Configuration parsing (nlohmann-json kept to this file).
#include "config.hpp"

#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cstdlib>
#include <fstream>
#include <set>
#include <sstream>

#include <nlohmann/json.hpp>

#include "auth.hpp"
#include "file_digest.hpp"
#include "horizon/trace/camera.hpp"
#include "memory_budget.hpp"

namespace horizon::server {

static_assert(kMaxTracePixelsCeiling ==
                  static_cast<std::uint64_t>(trace::kMaxSide) * static_cast<std::uint64_t>(trace::kMaxSide),
              "limits.max_trace_pixels tops out at the engine's largest frame");

namespace {

using Json = nlohmann::json;
namespace fs = std::filesystem;

Error config_error(const std::string& source, const std::string& key, const std::string& what) {
  return make_error(ErrorCode::kInvalidArgument, "config '" + source + "': " + key + ": " + what, key);
}

Status check_keys(const Json& object, const std::string& source, const std::string& prefix,
                  const std::set<std::string>& allowed) {
  for (const auto& [key, value] : object.items()) {
    (void)value;
    if (!allowed.contains(key)) {
      std::string list;
      for (const std::string& k : allowed) list += (list.empty() ? "" : ", ") + k;
      return config_error(source, prefix + key, "unknown key (expected one of: " + list + ")");
    }
  }
  return Status::Ok();
}

Result<std::string> get_string(const Json& object, const std::string& source, const std::string& key,
                               const std::string& path, bool allow_empty) {
  const Json& v = object.at(key);
  if (!v.is_string()) return config_error(source, path, "expected a string, got " + v.dump());
  std::string s = v.get<std::string>();
  if (!allow_empty && s.empty()) return config_error(source, path, "must not be empty");
  return s;
}

// A whole number in [lo, hi].
Result<std::uint64_t> get_count(const Json& object, const std::string& source, const std::string& key,
                                const std::string& path, std::uint64_t lo, std::uint64_t hi) {
  const Json& v = object.at(key);
  if (!v.is_number_integer() || (v.is_number_integer() && !v.is_number_unsigned() && v.get<std::int64_t>() < 0))
    return config_error(source, path, "expected a whole number >= " + std::to_string(lo) + ", got " + v.dump());
  const std::uint64_t n = v.get<std::uint64_t>();
  if (n < lo || n > hi)
    return config_error(source, path,
                        "must be in [" + std::to_string(lo) + ", " + std::to_string(hi) + "], got " + v.dump());
  return n;
}

Status check_address(const std::string& source, const std::string& key, const std::string& address) {
  const auto colon = address.rfind(':');
  if (colon == std::string::npos || colon == 0 || colon + 1 == address.size())
    return config_error(source, key, "expected host:port, got '" + address + "'");
  const std::string port = address.substr(colon + 1);
  if (port.find_first_not_of("0123456789") != std::string::npos || port.size() > 5 || std::stoi(port) > 65535)
    return config_error(source, key, "port must be a number in [0, 65535], got '" + address + "'");
  return Status::Ok();
}

Status parse_datasets(const Json& j, const std::string& source, Config& config) {
  if (!j.is_object()) return config_error(source, "datasets", "expected an object of name -> file");
  for (const auto& [name, value] : j.items()) {
    const std::string key = "datasets." + name;
    if (name.empty() || name.size() > kMaxDatasetName || name.find_first_of("/\\ \t\n") != std::string::npos)
      return config_error(
          source, key,
          "a dataset name is 1-" + std::to_string(kMaxDatasetName) + " characters without '/', '\\' or spaces");
    DatasetConfig d;
    d.name = name;
    if (value.is_string()) {
      d.file = value.get<std::string>();
    } else if (value.is_object()) {
      HORIZON_RETURN_IF_ERROR(
          check_keys(value, source, key + ".", {"file", "band", "missing_tiles", "valid_range", "sha256"}));
      if (!value.contains("file")) return config_error(source, key + ".file", "missing");
      auto file = get_string(value, source, "file", key + ".file", false);
      if (!file.ok()) return file.error();
      d.file = *file;
      if (value.contains("band")) {
        auto band = get_count(value, source, "band", key + ".band", 1, 65535);
        if (!band.ok()) return band.error();
        d.band = static_cast<int>(*band);
      }
      if (value.contains("missing_tiles")) {
        auto missing = get_string(value, source, "missing_tiles", key + ".missing_tiles", false);
        if (!missing.ok()) return missing.error();
        if (*missing != "error" && *missing != "nodata")
          return config_error(source, key + ".missing_tiles",
                              "expected \"error\" or \"nodata\", got '" + *missing + "'");
        d.missing_as_nodata = *missing == "nodata";
      }
      if (value.contains("valid_range")) {
        const Json& range = value["valid_range"];
        const bool numbers = range.is_array() && range.size() == 2 && range[0].is_number() && range[1].is_number();
        if (!numbers || !(range[0].get<double>() < range[1].get<double>()))
          return config_error(source, key + ".valid_range",
                              "expected [min, max] elevations with min < max, got " + range.dump());
        d.valid_min = range[0].get<double>();
        d.valid_max = range[1].get<double>();
      }
      if (value.contains("sha256")) {
        auto digest = get_string(value, source, "sha256", key + ".sha256", false);
        if (!digest.ok()) return digest.error();
        if (!is_sha256_hex(*digest))
          return config_error(
              source, key + ".sha256",
              "expected the file's SHA-256 as 64 hex digits (sha256sum's), got '" + digest->substr(0, 80) + "'");
        d.sha256 = *digest;
        for (char& c : d.sha256) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
      }
    } else {
      return config_error(source, key,
                          "expected a file or folder name or {\"file\": ..., \"band\": N, ...}, got " + value.dump());
    }
    if (d.file.empty()) return config_error(source, key, "file name must not be empty");
    config.datasets.push_back(std::move(d));
  }
  // nlohmann::json objects iterate in key order, so the list is sorted by name.
  return Status::Ok();
}

// A number in [lo, hi] (lo_open: lo itself excluded).
Result<double> get_number(const Json& object, const std::string& source, const std::string& key,
                          const std::string& path, double lo, double hi, bool lo_open) {
  const Json& v = object.at(key);
  const bool in = v.is_number() && (lo_open ? v.get<double>() > lo : v.get<double>() >= lo) && v.get<double>() <= hi;
  if (!in)
    return config_error(source, path,
                        std::string("expected a number in ") + (lo_open ? "(" : "[") + Json(lo).dump() + ", " +
                            Json(hi).dump() + "], got " + v.dump());
  return v.get<double>();
}

// "meshes": name -> {"dataset" | "file", knobs, "boxes"}. After the datasets
// (a mesh names one) and the limits (they cap its boxes).
Status parse_meshes(const Json& j, const std::string& source, Config& config) {
  if (!j.is_object()) return config_error(source, "meshes", "expected an object of name -> {\"dataset\": ...}");
  for (const auto& [name, value] : j.items()) {
    const std::string key = "meshes." + name;
    if (name.empty() || name.size() > kMaxDatasetName || name.find_first_of("/\\ \t\n") != std::string::npos)
      return config_error(
          source, key,
          "a mesh name is 1-" + std::to_string(kMaxDatasetName) + " characters without '/', '\\' or spaces");
    if (!value.is_object())
      return config_error(source, key, "expected {\"dataset\": NAME} or {\"file\": \"mesh.ply\"}, got " + value.dump());
    HORIZON_RETURN_IF_ERROR(
        check_keys(value, source, key + ".",
                   {"dataset", "file", "vertices", "max_error_m", "sectors", "subsectors", "seeds", "min_group",
                    "max_groups", "orphan_passes", "merge_cutoff", "random_seed", "boxes"}));
    MeshConfig m;
    m.name = name;
    if (value.contains("dataset") == value.contains("file"))
      return config_error(source, key,
                          "give one of \"dataset\" (a TIN built from it) or \"file\" (an OBJ or PLY mesh)");
    if (value.contains("dataset")) {
      auto d = get_string(value, source, "dataset", key + ".dataset", false);
      if (!d.ok()) return d.error();
      m.dataset = *d;
      const bool known = std::any_of(config.datasets.begin(), config.datasets.end(),
                                     [&](const DatasetConfig& c) { return c.name == m.dataset; });
      if (!known) return config_error(source, key + ".dataset", "'" + m.dataset + "' is not a configured dataset");
    } else {
      auto f = get_string(value, source, "file", key + ".file", false);
      if (!f.ok()) return f.error();
      m.file = *f;
      for (const char* dem_only : {"vertices", "max_error_m"})
        if (value.contains(dem_only))
          return config_error(source, key + "." + dem_only, "applies to a TIN built from a dataset, not a mesh file");
    }
    struct Count {
      const char* name;
      std::uint64_t lo, hi;
      int* out;
    };
    const Count counts[] = {{"sectors", 3, 256, &m.prepare.horizons.sectors},
                            {"subsectors", 1, 64, &m.prepare.horizons.subsectors},
                            {"seeds", 1, 1'000'000, &m.prepare.crystals.seeds},
                            {"min_group", 1, 1'000'000, &m.prepare.crystals.min_group_size},
                            {"max_groups", 1, 1'000'000, &m.prepare.crystals.max_groups},
                            {"orphan_passes", 0, 1000, &m.prepare.crystals.max_orphan_passes}};
    for (const Count& c : counts) {
      if (!value.contains(c.name)) continue;
      auto v = get_count(value, source, c.name, key + "." + c.name, c.lo, c.hi);
      if (!v.ok()) return v.error();
      *c.out = static_cast<int>(*v);
    }
    if (m.prepare.horizons.sectors * m.prepare.horizons.subsectors > 1024)
      return config_error(source, key + ".subsectors", "sectors x subsectors must be at most 1024");
    if (value.contains("vertices")) {
      auto v = get_count(value, source, "vertices", key + ".vertices", 4, 16'000'000);
      if (!v.ok()) return v.error();
      m.greedy.max_vertices = static_cast<std::uint32_t>(*v);
    }
    if (value.contains("max_error_m")) {
      auto v = get_number(value, source, "max_error_m", key + ".max_error_m", 0.0, 1e6, false);
      if (!v.ok()) return v.error();
      m.greedy.max_error = *v;
    }
    if (value.contains("merge_cutoff")) {
      auto v = get_number(value, source, "merge_cutoff", key + ".merge_cutoff", 0.0, 1.0, true);
      if (!v.ok()) return v.error();
      m.prepare.merge_cutoff = *v;
    }
    if (value.contains("random_seed")) {
      auto v = get_count(value, source, "random_seed", key + ".random_seed", 0, UINT64_MAX);
      if (!v.ok()) return v.error();
      m.prepare.crystals.random_seed = *v;
    }
    if (value.contains("boxes")) {
      const Json& boxes = value.at("boxes");
      if (!boxes.is_array()) return config_error(source, key + ".boxes", "expected an array of boxes");
      if (boxes.size() > config.limits.max_boxes)
        return config_error(source, key + ".boxes",
                            std::to_string(boxes.size()) +
                                " boxes, more than limits.max_boxes = " + std::to_string(config.limits.max_boxes));
      for (std::size_t i = 0; i < boxes.size(); ++i) {
        const Json& b = boxes[i];
        const std::string at = key + ".boxes[" + std::to_string(i) + "]";
        const bool six = b.is_array() && b.size() == 6 &&
                         std::all_of(b.begin(), b.end(), [](const Json& x) { return x.is_number(); });
        if (!six)
          return config_error(source, at, "expected [x_min, y_min, x_max, y_max, z_min, z_max], got " + b.dump());
        visibility::BoxSpec box;
        box.x_min = b[0].get<double>(), box.y_min = b[1].get<double>();
        box.x_max = b[2].get<double>(), box.y_max = b[3].get<double>();
        box.z_min = b[4].get<double>(), box.z_max = b[5].get<double>();
        if (!(box.x_min <= box.x_max && box.y_min <= box.y_max && box.z_min <= box.z_max))
          return config_error(source, at, "each minimum must be at most its maximum, got " + b.dump());
        m.boxes.push_back(box);
      }
    }
    config.meshes.push_back(std::move(m));
  }
  return Status::Ok();
}

// The text of the file `key` names (relative to base_dir).
Result<std::string> read_named_file(const Json& object, const std::string& source, const std::string& name,
                                    const std::string& key, const fs::path& base_dir) {
  auto v = get_string(object, source, name, key, false);
  if (!v.ok()) return v.error();
  const fs::path path = base_dir / *v;
  std::ifstream in(path, std::ios::binary);
  if (!in) return config_error(source, key, "cannot read '" + path.string() + "'");
  std::ostringstream text;
  text << in.rdbuf();
  if (text.str().empty()) return config_error(source, key, "'" + path.string() + "' is empty");
  return text.str();
}

Status parse_security(const Json& j, const std::string& source, const fs::path& base_dir, Config& c) {
  if (j.contains("plaintext")) {
    if (!j.at("plaintext").is_boolean()) return config_error(source, "plaintext", "expected true or false");
    c.plaintext = j.at("plaintext").get<bool>();
  }
  if (j.contains("tls")) {
    const Json& t = j.at("tls");
    if (!t.is_object()) return config_error(source, "tls", "expected {\"cert_file\": ..., \"key_file\": ...}");
    HORIZON_RETURN_IF_ERROR(check_keys(t, source, "tls.", {"cert_file", "key_file", "client_ca_file"}));
    for (const char* required : {"cert_file", "key_file"})
      if (!t.contains(required)) return config_error(source, std::string("tls.") + required, "missing (required)");
    TlsConfig tls;
    auto cert = read_named_file(t, source, "cert_file", "tls.cert_file", base_dir);
    if (!cert.ok()) return cert.error();
    auto key = read_named_file(t, source, "key_file", "tls.key_file", base_dir);
    if (!key.ok()) return key.error();
    tls.cert_pem = std::move(*cert);
    tls.key_pem = std::move(*key);
    if (t.contains("client_ca_file")) {
      auto ca = read_named_file(t, source, "client_ca_file", "tls.client_ca_file", base_dir);
      if (!ca.ok()) return ca.error();
      tls.client_ca_pem = std::move(*ca);
    }
    c.tls = std::move(tls);
  }
  if (c.tls && c.plaintext) return config_error(source, "plaintext", "true beside \"tls\": choose one transport");
  if (j.contains("health_listen")) {
    auto v = get_string(j, source, "health_listen", "health_listen", false);
    if (!v.ok()) return v.error();
    HORIZON_RETURN_IF_ERROR(check_address(source, "health_listen", *v));
    if (!c.tls)
      return config_error(source, "health_listen", "only with \"tls\" (without it, the gRPC port serves health)");
    c.health_listen = *v;
  }
  if (!c.tls && !c.plaintext)
    return config_error(source, "plaintext",
                        "no \"tls\" given: set \"tls\" (certificate and key), or \"plaintext\": true to serve "
                        "gRPC unencrypted (loopback and tests only)");
  if (j.contains("auth_tokens_file")) {
    auto v = get_string(j, source, "auth_tokens_file", "auth_tokens_file", false);
    if (!v.ok()) return v.error();
    auto tokens = read_tokens(base_dir / *v, "auth_tokens_file");
    if (!tokens.ok()) return config_error(source, "auth_tokens_file", tokens.error().message);
    c.auth_tokens = std::move(*tokens);
  }
  return Status::Ok();
}

Status parse_limits(const Json& j, const std::string& source, Limits& limits) {
  if (!j.is_object()) return config_error(source, "limits", "expected an object");
  HORIZON_RETURN_IF_ERROR(
      check_keys(j, source, "limits.",
                 {"max_cells", "max_boxes", "max_lines", "max_pending", "max_observers", "max_trace_pixels"}));
  if (j.contains("max_cells")) {
    auto v = get_count(j, source, "max_cells", "limits.max_cells", 1, 2'000'000'000);
    if (!v.ok()) return v.error();
    limits.max_cells = *v;
  }
  if (j.contains("max_boxes")) {
    auto v = get_count(j, source, "max_boxes", "limits.max_boxes", 1, 1'000'000);
    if (!v.ok()) return v.error();
    limits.max_boxes = static_cast<std::uint32_t>(*v);
  }
  if (j.contains("max_lines")) {
    auto v = get_count(j, source, "max_lines", "limits.max_lines", 1, 1'000'000);
    if (!v.ok()) return v.error();
    limits.max_lines = static_cast<std::uint32_t>(*v);
  }
  if (j.contains("max_pending")) {
    auto v = get_count(j, source, "max_pending", "limits.max_pending", 1, 100'000);
    if (!v.ok()) return v.error();
    limits.max_pending = static_cast<std::uint32_t>(*v);
  }
  if (j.contains("max_observers")) {
    auto v = get_count(j, source, "max_observers", "limits.max_observers", 1, 100'000);
    if (!v.ok()) return v.error();
    limits.max_observers = static_cast<std::uint32_t>(*v);
  }
  if (j.contains("max_trace_pixels")) {
    auto v = get_count(j, source, "max_trace_pixels", "limits.max_trace_pixels", 1, kMaxTracePixelsCeiling);
    if (!v.ok()) return v.error();
    limits.max_trace_pixels = *v;
  }
  return Status::Ok();
}

Status parse_sessions(const Json& j, const std::string& source, SessionConfig& sessions) {
  if (!j.is_object()) return config_error(source, "sessions", "expected an object");
  HORIZON_RETURN_IF_ERROR(check_keys(
      j, source, "sessions.", {"max", "idle_ms", "max_boxes", "max_level_size", "level_size", "subtile", "exact_mb"}));
  struct Key {
    const char* name;
    std::uint64_t lo, hi;
    std::uint32_t* out;
  };
  const Key keys[] = {{"max", 0, 10'000, &sessions.max},
                      {"idle_ms", 100, 86'400'000, &sessions.idle_ms},
                      {"max_boxes", 1, 1'000'000, &sessions.max_boxes},
                      {"max_level_size", 64, 4096, &sessions.max_level_size},
                      {"level_size", 64, 4096, &sessions.level_size},
                      {"subtile", 8, 2048, &sessions.subtile},
                      {"exact_mb", 1, 1'048'576, &sessions.exact_mb}};
  for (const Key& k : keys) {
    if (!j.contains(k.name)) continue;
    auto v = get_count(j, source, k.name, std::string("sessions.") + k.name, k.lo, k.hi);
    if (!v.ok()) return v.error();
    *k.out = static_cast<std::uint32_t>(*v);
  }
  for (const Key& k : {keys[3], keys[4], keys[5]})
    if ((*k.out & (*k.out - 1)) != 0)
      return config_error(source, std::string("sessions.") + k.name,
                          "must be a power of two, got " + std::to_string(*k.out));
  if (sessions.level_size > sessions.max_level_size)
    return config_error(source, "sessions.level_size", "must not exceed sessions.max_level_size");
  if (sessions.subtile * 2 > sessions.level_size)
    return config_error(source, "sessions.subtile", "must be at most sessions.level_size / 2");
  return Status::Ok();
}

Status parse_gpu(const Json& j, const std::string& source, GpuConfig& gpu) {
  if (!j.is_object()) return config_error(source, "gpu", "expected an object, got " + j.dump());
  HORIZON_RETURN_IF_ERROR(check_keys(j, source, "gpu.", {"contexts"}));
  if (j.contains("contexts")) {
    auto v = get_count(j, source, "contexts", "gpu.contexts", 0, 64);
    if (!v.ok()) return v.error();
    gpu.contexts = static_cast<std::uint32_t>(*v);
  }
  return Status::Ok();
}

fs::path default_scratch_dir() {
  if (const char* tmp = std::getenv("TMPDIR"); tmp && *tmp) return tmp;
  return "/tmp";
}

}  // namespace

Result<Config> parse_config(const std::string& text, const std::string& source, const fs::path& base_dir,
                            const ConfigOverrides& overrides) {
  Json j;
  try {
    j = Json::parse(text);
  } catch (const Json::exception& e) {  // parse_error, and out_of_range for a number beyond double (1e400)
    return make_error(ErrorCode::kInvalidArgument, "config '" + source + "': not valid JSON: " + e.what(), "");
  }
  if (!j.is_object()) return config_error(source, "(document)", "expected a JSON object");
  if (!overrides.listen.empty()) j["listen"] = overrides.listen;
  if (!overrides.metrics_listen.empty()) j["metrics_listen"] = overrides.metrics_listen;
  if (!overrides.data_root.empty()) j["data_root"] = fs::absolute(overrides.data_root).string();
  HORIZON_RETURN_IF_ERROR(check_keys(j, source, "",
                                     {"listen",
                                      "metrics_listen",
                                      "data_root",
                                      "datasets",
                                      "memory_budget_mb",
                                      "block_cache_mb",
                                      "receive_buffer_mb",
                                      "worker_kept_mb",
                                      "io_threads",
                                      "worker_threads",
                                      "engine_threads",
                                      "limits",
                                      "gpu",
                                      "default_deadline_ms",
                                      "shutdown_grace_ms",
                                      "scratch_dir",
                                      "tls",
                                      "health_listen",
                                      "plaintext",
                                      "auth_tokens_file",
                                      "sessions",
                                      "meshes",
                                      "mesh_cache_dir"}));
  Config c;
  c.source = source;
  for (const char* required : {"listen", "data_root", "datasets", "memory_budget_mb"})
    if (!j.contains(required)) return config_error(source, required, "missing (required)");

  auto listen = get_string(j, source, "listen", "listen", false);
  if (!listen.ok()) return listen.error();
  c.listen = *listen;
  HORIZON_RETURN_IF_ERROR(check_address(source, "listen", c.listen));
  if (j.contains("metrics_listen")) {
    auto m = get_string(j, source, "metrics_listen", "metrics_listen", true);
    if (!m.ok()) return m.error();
    c.metrics_listen = *m;
    if (!c.metrics_listen.empty()) HORIZON_RETURN_IF_ERROR(check_address(source, "metrics_listen", c.metrics_listen));
  }

  auto root = get_string(j, source, "data_root", "data_root", false);
  if (!root.ok()) return root.error();
  c.data_root = base_dir / *root;
  std::error_code ec;
  if (!fs::is_directory(c.data_root, ec))
    return config_error(source, "data_root", "'" + c.data_root.string() + "' is not a directory");
  c.data_root = fs::canonical(c.data_root, ec);

  HORIZON_RETURN_IF_ERROR(parse_datasets(j.at("datasets"), source, c));

  auto budget = get_count(j, source, "memory_budget_mb", "memory_budget_mb", 64, 16u << 20);
  if (!budget.ok()) return budget.error();
  c.memory_budget_bytes = *budget << 20;
  if (j.contains("block_cache_mb")) {
    auto v = get_count(j, source, "block_cache_mb", "block_cache_mb", 1, 1u << 20);
    if (!v.ok()) return v.error();
    c.block_cache_bytes = *v << 20;
  }
  c.worker_kept_bytes = c.memory_budget_bytes / 4;
  if (j.contains("worker_kept_mb")) {
    auto v = get_count(j, source, "worker_kept_mb", "worker_kept_mb", 0, *budget);
    if (!v.ok()) return v.error();
    c.worker_kept_bytes = *v << 20;
  }
  if (j.contains("io_threads")) {
    auto v = get_count(j, source, "io_threads", "io_threads", 1, 64);
    if (!v.ok()) return v.error();
    c.io_threads = static_cast<unsigned>(*v);
  }
  if (j.contains("worker_threads")) {
    auto v = get_count(j, source, "worker_threads", "worker_threads", 0, 1024);
    if (!v.ok()) return v.error();
    c.worker_threads = static_cast<unsigned>(*v);
  }
  if (j.contains("engine_threads")) {
    auto v = get_count(j, source, "engine_threads", "engine_threads", 0, 1024);
    if (!v.ok()) return v.error();
    c.engine_threads = static_cast<unsigned>(*v);
  }
  if (j.contains("limits")) HORIZON_RETURN_IF_ERROR(parse_limits(j.at("limits"), source, c.limits));
  if (j.contains("gpu")) HORIZON_RETURN_IF_ERROR(parse_gpu(j.at("gpu"), source, c.gpu));
  if (j.contains("sessions")) HORIZON_RETURN_IF_ERROR(parse_sessions(j.at("sessions"), source, c.sessions));
  if (j.contains("meshes")) HORIZON_RETURN_IF_ERROR(parse_meshes(j.at("meshes"), source, c));
  if (j.contains("mesh_cache_dir")) {
    auto v = get_string(j, source, "mesh_cache_dir", "mesh_cache_dir", false);
    if (!v.ok()) return v.error();
    c.mesh_cache_dir = base_dir / *v;
  }
  if (j.contains("default_deadline_ms")) {
    auto v = get_count(j, source, "default_deadline_ms", "default_deadline_ms", 1, 3'600'000);
    if (!v.ok()) return v.error();
    c.default_deadline = std::chrono::milliseconds(*v);
  }
  if (j.contains("shutdown_grace_ms")) {
    auto v = get_count(j, source, "shutdown_grace_ms", "shutdown_grace_ms", 0, 600'000);
    if (!v.ok()) return v.error();
    c.shutdown_grace = std::chrono::milliseconds(*v);
  }
  // Requests on the wire: after the limits, which size the largest request.
  const std::uint64_t largest_request = largest_request_bytes(c.limits);
  if (j.contains("receive_buffer_mb")) {
    auto v = get_count(j, source, "receive_buffer_mb", "receive_buffer_mb", 1, 1u << 20);
    if (!v.ok()) return v.error();
    c.receive_buffer_bytes = *v << 20;
    if (c.receive_buffer_bytes < largest_request)
      return config_error(source, "receive_buffer_mb",
                          std::to_string(*v) + " MiB cannot hold the largest request the limits allow (" +
                              mib_text(largest_request) + ": limits.max_boxes, max_lines or max_observers)");
  } else {
    const std::uint64_t largest_in_whole_mib = (largest_request + (1u << 20) - 1) >> 20 << 20;
    c.receive_buffer_bytes = std::max<std::uint64_t>(c.memory_budget_bytes / 8, largest_in_whole_mib);
  }
  if (!j.contains("block_cache_mb")) {
    // Half of what the budget leaves after the process's own overhead and the
    // receive buffers, at least 1 MiB, at most 256 MiB.
    const std::uint64_t fixed = MemoryBudget::kBaseBytes + c.receive_buffer_bytes;
    const std::uint64_t left = c.memory_budget_bytes > fixed ? c.memory_budget_bytes - fixed : 0;
    c.block_cache_bytes = std::clamp<std::uint64_t>(left / 2 >> 20 << 20, 1ull << 20, 256ull << 20);
  }
  if (c.block_cache_bytes + c.receive_buffer_bytes + MemoryBudget::kBaseBytes > c.memory_budget_bytes) {
    const char* key = j.contains("block_cache_mb")      ? "block_cache_mb"
                      : j.contains("receive_buffer_mb") ? "receive_buffer_mb"
                                                        : "memory_budget_mb";
    return config_error(source, key,
                        "block_cache_mb = " + std::to_string(c.block_cache_bytes >> 20) +
                            " and receive_buffer_mb = " + std::to_string(c.receive_buffer_bytes >> 20) +
                            " do not fit in memory_budget_mb = " + std::to_string(c.memory_budget_bytes >> 20) +
                            " (which also holds 48 MiB of process overhead and the requests' working memory)");
  }
  c.scratch_dir = default_scratch_dir();
  if (j.contains("scratch_dir")) {
    auto v = get_string(j, source, "scratch_dir", "scratch_dir", false);
    if (!v.ok()) return v.error();
    c.scratch_dir = base_dir / *v;
  }
  if (!fs::is_directory(c.scratch_dir, ec) || ::access(c.scratch_dir.c_str(), W_OK) != 0)
    return config_error(source, "scratch_dir", "'" + c.scratch_dir.string() + "' is not a writable directory");
  HORIZON_RETURN_IF_ERROR(parse_security(j, source, base_dir, c));
  return c;
}

std::uint64_t largest_request_bytes(const Limits& limits) {
  const std::uint64_t need =
      1'048'576 + 96ull * std::max<std::uint64_t>({limits.max_boxes, limits.max_lines, limits.max_observers});
  return std::min<std::uint64_t>(need, 512ull << 20);
}

Result<Config> load_config(const std::string& path, const ConfigOverrides& overrides) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return make_error(ErrorCode::kNotFound, "config '" + path + "': cannot be opened", "config");
  std::ostringstream text;
  text << in.rdbuf();
  const fs::path base = fs::absolute(path).parent_path();
  return parse_config(text.str(), path, base, overrides);
}

namespace {

// `file` (relative to data_root) resolved, symlinks followed, and checked to
// lie inside the root and to be a file (or, with `folders`, a folder).
// Errors name `key`.
Result<fs::path> resolve_inside_root(const Config& config, const std::string& file, const std::string& key,
                                     bool folders) {
  const fs::path joined = config.data_root / file;
  std::error_code ec;
  const fs::path resolved = fs::weakly_canonical(joined, ec);
  if (ec) return config_error(config.source, key, "cannot resolve '" + joined.string() + "': " + ec.message());
  // Inside the root: the resolved path starts with the (canonical) root.
  const auto rel = resolved.lexically_relative(config.data_root);
  if (rel.empty() || *rel.begin() == "..")
    return config_error(config.source, key,
                        "'" + file + "' resolves to '" + resolved.string() + "', outside data_root '" +
                            config.data_root.string() + "'");
  if (!fs::is_regular_file(resolved, ec) && !(folders && fs::is_directory(resolved, ec)))
    return make_error(ErrorCode::kNotFound,
                      "config '" + config.source + "': " + key + ": no such file" + (folders ? " or folder" : "") +
                          " '" + resolved.string() + "'",
                      key);
  return resolved;
}

}  // namespace

Result<fs::path> resolve_dataset_file(const Config& config, const DatasetConfig& dataset) {
  return resolve_inside_root(config, dataset.file, "datasets." + dataset.name, true);
}

Result<fs::path> resolve_mesh_file(const Config& config, const MeshConfig& mesh) {
  return resolve_inside_root(config, mesh.file, "meshes." + mesh.name + ".file", false);
}

std::vector<std::string> keys_needing_restart(const Config& a, const Config& b) {
  std::vector<std::string> keys;
  const auto differ = [&keys](bool changed, const char* key) {
    if (changed) keys.emplace_back(key);
  };
  differ(a.listen != b.listen, "listen");
  differ(a.metrics_listen != b.metrics_listen, "metrics_listen");
  differ(a.memory_budget_bytes != b.memory_budget_bytes, "memory_budget_mb");
  differ(a.block_cache_bytes != b.block_cache_bytes, "block_cache_mb");
  differ(a.receive_buffer_bytes != b.receive_buffer_bytes, "receive_buffer_mb");
  differ(a.worker_kept_bytes != b.worker_kept_bytes, "worker_kept_mb");
  differ(a.io_threads != b.io_threads, "io_threads");
  differ(a.worker_threads != b.worker_threads, "worker_threads");
  differ(a.engine_threads != b.engine_threads, "engine_threads");
  differ(a.limits.max_cells != b.limits.max_cells, "limits.max_cells");
  differ(a.limits.max_boxes != b.limits.max_boxes, "limits.max_boxes");
  differ(a.limits.max_observers != b.limits.max_observers, "limits.max_observers");
  differ(a.limits.max_lines != b.limits.max_lines, "limits.max_lines");
  differ(a.limits.max_pending != b.limits.max_pending, "limits.max_pending");
  differ(a.limits.max_trace_pixels != b.limits.max_trace_pixels, "limits.max_trace_pixels");
  differ(a.sessions.max != b.sessions.max, "sessions.max");
  differ(a.sessions.idle_ms != b.sessions.idle_ms, "sessions.idle_ms");
  differ(a.sessions.max_boxes != b.sessions.max_boxes, "sessions.max_boxes");
  differ(a.sessions.max_level_size != b.sessions.max_level_size, "sessions.max_level_size");
  differ(a.sessions.exact_mb != b.sessions.exact_mb, "sessions.exact_mb");
  differ(a.sessions.level_size != b.sessions.level_size, "sessions.level_size");
  differ(a.sessions.subtile != b.sessions.subtile, "sessions.subtile");
  differ(a.gpu.contexts != b.gpu.contexts, "gpu.contexts");
  differ(a.default_deadline != b.default_deadline, "default_deadline_ms");
  differ(a.shutdown_grace != b.shutdown_grace, "shutdown_grace_ms");
  differ(a.scratch_dir != b.scratch_dir, "scratch_dir");
  const auto tls_of = [](const Config& c) {
    return c.tls ? c.tls->cert_pem + '\0' + c.tls->key_pem + '\0' + c.tls->client_ca_pem : std::string();
  };
  differ(tls_of(a) != tls_of(b), "tls");
  differ(a.health_listen != b.health_listen, "health_listen");
  differ(a.plaintext != b.plaintext, "plaintext");
  differ(a.auth_tokens != b.auth_tokens, "auth_tokens_file");
  return keys;
}

}  // namespace horizon::server
