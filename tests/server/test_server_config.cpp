// horizond's configuration (server/src/config.hpp): every key that can be
// wrong is refused with an error whose field names it, and a good document
// gives the values written (relative paths resolved against the file's
// directory).
#include <gtest/gtest.h>

#include <unistd.h>

#include <cctype>
#include <filesystem>
#include <fstream>
#include <ostream>
#include <string>
#include <vector>

#include "auth.hpp"
#include "config.hpp"

namespace horizon::server {
namespace {

const std::filesystem::path kDataDir = HORIZON_DATA_DIR;

// A valid document with `extra` spliced in as more top-level keys, or with a
// key replaced when `extra` repeats it (nlohmann keeps the last duplicate).
std::string document(const std::string& extra) {
  return R"({"listen": "127.0.0.1:0", "plaintext": true, "data_root": ")" + kDataDir.string() +
         R"(", "datasets": {"rainier": "rainier_summit_srtm3_400x400.tif"}, "memory_budget_mb": 256)" +
         (extra.empty() ? "" : ", " + extra) + "}";
}

TEST(ServerConfig, GoodDocumentGivesItsValues) {
  auto c = parse_config(
      document(R"("worker_threads": 3, "engine_threads": 2, "limits": {"max_boxes": 500, "max_observers": 40,
                                               "max_trace_pixels": 1000000},
                                    "default_deadline_ms": 1500, "shutdown_grace_ms": 250,
                                    "datasets": {"b": {"file": "olinda_coast_utm25s_111x111.tif", "band": 1},
                                                 "a": "rainier_summit_srtm3_400x400.tif"})"),
      "test.json", "/");
  ASSERT_TRUE(c.ok()) << c.error().message;
  EXPECT_EQ(c->listen, "127.0.0.1:0");
  EXPECT_EQ(c->memory_budget_bytes, 256ull << 20);
  EXPECT_EQ(c->worker_threads, 3u);
  EXPECT_EQ(c->engine_threads, 2u);
  EXPECT_EQ(c->limits.max_boxes, 500u);
  EXPECT_EQ(c->limits.max_observers, 40u);
  EXPECT_EQ(c->limits.max_cells, Limits{}.max_cells);
  EXPECT_EQ(c->limits.max_trace_pixels, 1'000'000u);
  EXPECT_EQ(Limits{}.max_trace_pixels, 4096u * 4096u);  // the default
  EXPECT_EQ(c->default_deadline.count(), 1500);
  EXPECT_EQ(c->shutdown_grace.count(), 250);
  ASSERT_EQ(c->datasets.size(), 2u);
  EXPECT_EQ(c->datasets[0].name, "a");  // in name order
  EXPECT_EQ(c->datasets[1].name, "b");
  EXPECT_EQ(c->datasets[1].band, 1);
  auto file = resolve_dataset_file(*c, c->datasets[1]);
  ASSERT_TRUE(file.ok()) << file.error().message;
  EXPECT_EQ(*file, std::filesystem::canonical(kDataDir / "olinda_coast_utm25s_111x111.tif"));
}

// Found by fuzz_config: a number beyond double threw out of the parser
// (nlohmann's out_of_range, not a parse_error) and terminated the daemon.
TEST(ServerConfig, MeshesGiveTheirKnobsAndDefaultToTheThesis) {
  auto c = parse_config(document(R"("meshes": {"tin": {"dataset": "rainier", "vertices": 5000, "max_error_m": 0.5,
                                                       "sectors": 8, "subsectors": 2, "seeds": 100, "min_group": 20,
                                                       "max_groups": 300, "orphan_passes": 3, "merge_cutoff": 0.5,
                                                       "random_seed": 7, "boxes": [[1, 2, 3, 4, 5, 6]]},
                                               "file": {"file": "sub/m.ply"}},
                                    "mesh_cache_dir": "cache")"),
                        "test.json", "/base");
  ASSERT_TRUE(c.ok()) << c.error().message;
  ASSERT_EQ(c->meshes.size(), 2u);
  const MeshConfig& f = c->meshes[0];  // in name order
  EXPECT_EQ(f.name, "file");
  EXPECT_EQ(f.file, "sub/m.ply");
  EXPECT_EQ(f.prepare.horizons.sectors, 16);
  EXPECT_EQ(f.prepare.horizons.subsectors, 4);
  EXPECT_EQ(f.prepare.crystals.seeds, 500);
  EXPECT_EQ(f.prepare.merge_cutoff, 0.25);
  const MeshConfig& t = c->meshes[1];
  EXPECT_EQ(t.dataset, "rainier");
  EXPECT_EQ(t.greedy.max_vertices, 5000u);
  EXPECT_EQ(t.greedy.max_error, 0.5);
  EXPECT_EQ(t.prepare.horizons.sectors, 8);
  EXPECT_EQ(t.prepare.horizons.subsectors, 2);
  EXPECT_EQ(t.prepare.crystals.seeds, 100);
  EXPECT_EQ(t.prepare.crystals.min_group_size, 20);
  EXPECT_EQ(t.prepare.crystals.max_groups, 300);
  EXPECT_EQ(t.prepare.crystals.max_orphan_passes, 3);
  EXPECT_EQ(t.prepare.merge_cutoff, 0.5);
  EXPECT_EQ(t.prepare.crystals.random_seed, 7u);
  ASSERT_EQ(t.boxes.size(), 1u);
  EXPECT_EQ(t.boxes[0].y_max, 4.0);
  EXPECT_EQ(t.boxes[0].z_max, 6.0);
  EXPECT_EQ(c->mesh_cache_dir, std::filesystem::path("/base/cache"));
}

TEST(ServerConfig, ANumberBeyondDoubleIsInvalidJsonNotACrash) {
  auto c = parse_config(R"({"listen": "127.0.0.1:0", "plaintext": true, "memory_budget_mb": 1e400})", "test.json", "/");
  ASSERT_FALSE(c.ok());
  EXPECT_EQ(c.error().code, ErrorCode::kInvalidArgument);
  EXPECT_NE(c.error().message.find("not valid JSON"), std::string::npos) << c.error().message;
}

TEST(ServerConfig, TokensFileLinesAreCheckedWithoutEchoingThem) {
  const auto path = std::filesystem::temp_directory_path() / ("horizon-tokens-" + std::to_string(::getpid()));
  { std::ofstream(path) << "# comment\n\n  a-good-token-0123456789  \nshort\n"; }
  auto refused = parse_config(document(R"("auth_tokens_file": ")" + path.string() + R"(")"), "test.json", "/");
  ASSERT_FALSE(refused.ok());
  EXPECT_EQ(refused.error().field, "auth_tokens_file");
  EXPECT_NE(refused.error().message.find("line 4"), std::string::npos) << refused.error().message;
  EXPECT_EQ(refused.error().message.find("short"), std::string::npos) << refused.error().message;
  { std::ofstream(path) << "# comment\n\n  a-good-token-0123456789  \n"; }
  auto accepted = parse_config(document(R"("auth_tokens_file": ")" + path.string() + R"(")"), "test.json", "/");
  ASSERT_TRUE(accepted.ok()) << accepted.error().message;
  EXPECT_EQ(accepted->auth_tokens, std::vector<std::string>{"a-good-token-0123456789"});
  std::filesystem::remove(path);
}

TEST(ServerConfig, BearerTokensCompareWholeAndOnlyWithTheScheme) {
  const std::vector<std::string> tokens{"a-good-token-0123456789", "another-token-0123456789"};
  EXPECT_FALSE(check_bearer("Bearer a-good-token-0123456789", tokens));
  EXPECT_FALSE(check_bearer("Bearer another-token-0123456789", tokens));
  EXPECT_TRUE(check_bearer("Bearer a-good-token-012345678", tokens));    // a prefix
  EXPECT_TRUE(check_bearer("Bearer a-good-token-01234567890", tokens));  // longer
  EXPECT_TRUE(check_bearer("a-good-token-0123456789", tokens));          // no scheme
  EXPECT_TRUE(check_bearer("", tokens));
  EXPECT_EQ(check_bearer("", tokens)->error_code(), grpc::StatusCode::UNAUTHENTICATED);
  EXPECT_TRUE(same_secret("abc", "abc"));
  EXPECT_FALSE(same_secret("abd", "abc"));
  EXPECT_FALSE(same_secret("ab", "abc"));
  EXPECT_FALSE(same_secret("", "x"));
}

TEST(ServerConfig, TiledDatasetsAndTheBlockCache) {
  auto c = parse_config(document(R"("block_cache_mb": 64, "io_threads": 3,
                                    "datasets": {"t": {"file": ".", "missing_tiles": "nodata"},
                                                 "f": {"file": "zion_canyon_srtm3_465x457.tif", "missing_tiles": "error",
                                                       "valid_range": [-100, 30000],
                                                       "sha256": ")" +
                                 std::string(32, 'A') + std::string(32, '0') + R"("}})"),
                        "test.json", "/");
  ASSERT_TRUE(c.ok()) << c.error().message;
  EXPECT_EQ(c->block_cache_bytes, 64ull << 20);
  EXPECT_EQ(c->io_threads, 3u);
  ASSERT_EQ(c->datasets.size(), 2u);
  EXPECT_FALSE(c->datasets[0].missing_as_nodata);  // "f"
  EXPECT_TRUE(c->datasets[1].missing_as_nodata);   // "t"
  EXPECT_EQ(c->datasets[0].valid_min, -100.0);
  EXPECT_EQ(c->datasets[0].valid_max, 30000.0);
  EXPECT_EQ(c->datasets[0].sha256, std::string(32, 'a') + std::string(32, '0'));  // kept lowercase
  EXPECT_EQ(c->datasets[1].sha256, "");
  EXPECT_EQ(c->datasets[1].valid_min, -12000.0);  // the default
  EXPECT_EQ(c->datasets[1].valid_max, 9000.0);
  auto folder = resolve_dataset_file(*c, c->datasets[1]);
  ASSERT_TRUE(folder.ok()) << folder.error().message;  // a folder is a dataset too
  EXPECT_EQ(*folder, std::filesystem::canonical(kDataDir));
  // Unset, the receive buffers take an eighth of the budget (256 MiB here),
  // and the cache half of what is left after them and the process's own
  // 48 MiB, at most 256 MiB.
  auto d = parse_config(document(""), "test.json", "/");
  ASSERT_TRUE(d.ok());
  EXPECT_EQ(d->receive_buffer_bytes, 32ull << 20);
  EXPECT_EQ(d->block_cache_bytes, (256ull - 48 - 32) << 19);
}

// The workers' kept buffers take a quarter of the budget unless told, and
// never more than the whole.
TEST(ServerConfig, WorkersKeepAQuarterOfTheBudgetUnlessTold) {
  auto c = parse_config(document(""), "test.json", "/");
  ASSERT_TRUE(c.ok()) << c.error().message;
  EXPECT_EQ(c->worker_kept_bytes, 64ull << 20);
  auto none = parse_config(document(R"("worker_kept_mb": 0)"), "test.json", "/");
  ASSERT_TRUE(none.ok()) << none.error().message;
  EXPECT_EQ(none->worker_kept_bytes, 0u);
  auto all = parse_config(document(R"("worker_kept_mb": 256)"), "test.json", "/");
  ASSERT_TRUE(all.ok()) << all.error().message;
  EXPECT_EQ(all->worker_kept_bytes, 256ull << 20);
}

// gRPC's receive buffers hold at least the largest request the limits allow
// (1 MiB + 96 bytes a box: 10.2 MiB for the default 100 000 boxes), and the
// default grows with the limits.
TEST(ServerConfig, ReceiveBuffersHoldTheLargestRequest) {
  EXPECT_EQ(largest_request_bytes(Limits{}), 1'048'576u + 96u * 100'000u);
  auto c = parse_config(document(R"("receive_buffer_mb": 11)"), "test.json", "/");
  ASSERT_TRUE(c.ok()) << c.error().message;
  EXPECT_EQ(c->receive_buffer_bytes, 11ull << 20);
  auto big = parse_config(document(R"("limits": {"max_boxes": 1000000})"), "test.json", "/");
  ASSERT_TRUE(big.ok()) << big.error().message;
  EXPECT_EQ(big->receive_buffer_bytes, 93ull << 20);  // 92.5 MiB rounded up, above 256 / 8
  EXPECT_EQ(big->block_cache_bytes, (256ull - 48 - 93) / 2 << 20);
}

struct BadCase {
  const char* what;
  std::string text;
  const char* field;
};

void PrintTo(const BadCase& b, std::ostream* os) {
  *os << b.what << ": " << b.text;
}

class BadConfig : public ::testing::TestWithParam<BadCase> {};

TEST_P(BadConfig, IsRefusedNamingTheKey) {
  const BadCase& b = GetParam();
  auto c = parse_config(b.text, "bad.json", "/");
  ASSERT_FALSE(c.ok()) << b.what;
  EXPECT_EQ(c.error().code, ErrorCode::kInvalidArgument) << c.error().message;
  EXPECT_EQ(c.error().field, b.field) << c.error().message;
  EXPECT_NE(c.error().message.find("bad.json"), std::string::npos) << c.error().message;
  if (*b.field) {
    EXPECT_NE(c.error().message.find(b.field), std::string::npos) << c.error().message;
  }
}

INSTANTIATE_TEST_SUITE_P(
    EveryKey, BadConfig,
    ::testing::Values(
        BadCase{"not JSON", "{\"listen\": ", ""}, BadCase{"not an object", "[1, 2]", "(document)"},
        BadCase{"unknown key", document(R"("listne": "x:1")"), "listne"},
        BadCase{"missing listen", R"({"data_root": "/", "datasets": {}, "memory_budget_mb": 256})", "listen"},
        BadCase{"missing datasets", R"({"listen": "a:1", "data_root": "/", "memory_budget_mb": 256})", "datasets"},
        BadCase{"listen without port", document(R"("listen": "localhost")"), "listen"},
        BadCase{"sessions unknown key", document(R"("sessions": {"maximum": 3})"), "sessions.maximum"},
        BadCase{"sessions level_size not a power of two", document(R"("sessions": {"level_size": 1000})"),
                "sessions.level_size"},
        BadCase{"sessions level_size above max_level_size",
                document(R"("sessions": {"level_size": 4096, "max_level_size": 1024})"), "sessions.level_size"},
        BadCase{"sessions subtile too large", document(R"("sessions": {"level_size": 64, "subtile": 64})"),
                "sessions.subtile"},
        BadCase{"sessions idle_ms too short", document(R"("sessions": {"idle_ms": 5})"), "sessions.idle_ms"},
        BadCase{"sessions exact_mb zero", document(R"("sessions": {"exact_mb": 0})"), "sessions.exact_mb"},
        BadCase{"listen port too large", document(R"("listen": "localhost:70000")"), "listen"},
        BadCase{"listen not a string", document(R"("listen": 50051)"), "listen"},
        BadCase{"metrics_listen bad", document(R"("metrics_listen": "localhost:http")"), "metrics_listen"},
        BadCase{"data_root missing dir", document(R"("data_root": "/no/such/dir")"), "data_root"},
        BadCase{"datasets not an object", document(R"("datasets": ["a.tif"])"), "datasets"},
        BadCase{"dataset name with slash", document(R"("datasets": {"a/b": "x.tif"})"), "datasets.a/b"},
        BadCase{"dataset empty file", document(R"("datasets": {"a": ""})"), "datasets.a"},
        BadCase{"dataset number", document(R"("datasets": {"a": 3})"), "datasets.a"},
        BadCase{"dataset object without file", document(R"("datasets": {"a": {"band": 1}})"), "datasets.a.file"},
        BadCase{"dataset band 0", document(R"("datasets": {"a": {"file": "x.tif", "band": 0}})"), "datasets.a.band"},
        BadCase{"dataset unknown key", document(R"("datasets": {"a": {"file": "x.tif", "bands": 2}})"),
                "datasets.a.bands"},
        BadCase{"budget too small", document(R"("memory_budget_mb": 10)"), "memory_budget_mb"},
        BadCase{"budget negative", document(R"("memory_budget_mb": -1)"), "memory_budget_mb"},
        BadCase{"budget fractional", document(R"("memory_budget_mb": 100.5)"), "memory_budget_mb"},
        BadCase{"worker_threads string", document(R"("worker_threads": "2")"), "worker_threads"},
        BadCase{"engine_threads huge", document(R"("engine_threads": 5000)"), "engine_threads"},
        BadCase{"limits not an object", document(R"("limits": 5)"), "limits"},
        BadCase{"limits unknown key", document(R"("limits": {"max_cell": 5})"), "limits.max_cell"},
        BadCase{"max_cells 0", document(R"("limits": {"max_cells": 0})"), "limits.max_cells"},
        BadCase{"max_boxes too many", document(R"("limits": {"max_boxes": 2000000})"), "limits.max_boxes"},
        BadCase{"max_observers zero", document(R"("limits": {"max_observers": 0})"), "limits.max_observers"},
        BadCase{"max_lines negative", document(R"("limits": {"max_lines": -5})"), "limits.max_lines"},
        BadCase{"max_pending 0", document(R"("limits": {"max_pending": 0})"), "limits.max_pending"},
        BadCase{"max_trace_pixels 0", document(R"("limits": {"max_trace_pixels": 0})"), "limits.max_trace_pixels"},
        BadCase{"max_trace_pixels past 8192 x 8192", document(R"("limits": {"max_trace_pixels": 67108865})"),
                "limits.max_trace_pixels"},
        BadCase{"max_trace_pixels fractional", document(R"("limits": {"max_trace_pixels": 1e6})"),
                "limits.max_trace_pixels"},
        BadCase{"gpu not an object", document(R"("gpu": 2)"), "gpu"},
        BadCase{"gpu unknown key", document(R"("gpu": {"context": 2})"), "gpu.context"},
        BadCase{"gpu contexts string", document(R"("gpu": {"contexts": "2"})"), "gpu.contexts"},
        BadCase{"gpu contexts fractional", document(R"("gpu": {"contexts": 1.5})"), "gpu.contexts"},
        BadCase{"gpu contexts -1", document(R"("gpu": {"contexts": -1})"), "gpu.contexts"},
        BadCase{"gpu contexts 65", document(R"("gpu": {"contexts": 65})"), "gpu.contexts"},
        BadCase{"deadline 0", document(R"("default_deadline_ms": 0)"), "default_deadline_ms"},
        BadCase{"grace too long", document(R"("shutdown_grace_ms": 700000)"), "shutdown_grace_ms"},
        BadCase{"scratch_dir missing", document(R"("scratch_dir": "/no/such/dir")"), "scratch_dir"},
        BadCase{"missing_tiles unknown", document(R"("datasets": {"a": {"file": "x", "missing_tiles": "zero"}})"),
                "datasets.a.missing_tiles"},
        BadCase{"valid_range not a pair", document(R"("datasets": {"a": {"file": "x", "valid_range": [1]}})"),
                "datasets.a.valid_range"},
        BadCase{"sha256 too short", document(R"("datasets": {"a": {"file": "x", "sha256": "abc123"}})"),
                "datasets.a.sha256"},
        BadCase{"sha256 not hex",
                document(R"("datasets": {"a": {"file": "x", "sha256": ")" + std::string(63, '0') + R"(g"}})"),
                "datasets.a.sha256"},
        BadCase{"valid_range reversed", document(R"("datasets": {"a": {"file": "x", "valid_range": [100, -100]}})"),
                "datasets.a.valid_range"},
        BadCase{"neither tls nor plaintext", document(R"("plaintext": false)"), "plaintext"},
        BadCase{"plaintext not a boolean", document(R"("plaintext": "yes")"), "plaintext"},
        BadCase{"tls cert unreadable", document(R"("tls": {"cert_file": "/no/such.pem", "key_file": "/no/k"})"),
                "tls.cert_file"},
        BadCase{"tls without key", document(R"("tls": {"cert_file": "/no/such.pem"})"), "tls.key_file"},
        BadCase{"tls unknown key", document(R"("tls": {"cert": "x"})"), "tls.cert"},
        BadCase{"health_listen without tls", document(R"("health_listen": "127.0.0.1:0")"), "health_listen"},
        BadCase{"auth_tokens_file missing", document(R"("auth_tokens_file": "/no/such/tokens")"), "auth_tokens_file"},
        BadCase{"block_cache_mb 0", document(R"("block_cache_mb": 0)"), "block_cache_mb"},
        BadCase{"block_cache_mb over the budget", document(R"("block_cache_mb": 300)"), "block_cache_mb"},
        BadCase{"receive_buffer_mb 0", document(R"("receive_buffer_mb": 0)"), "receive_buffer_mb"},
        BadCase{"receive_buffer_mb below the largest request", document(R"("receive_buffer_mb": 10)"),
                "receive_buffer_mb"},
        BadCase{"block_cache_mb and receive_buffer_mb over the budget",
                document(R"("block_cache_mb": 150, "receive_buffer_mb": 60)"), "block_cache_mb"},
        BadCase{"receive_buffer_mb leaves no room for the cache", document(R"("receive_buffer_mb": 250)"),
                "receive_buffer_mb"},
        BadCase{"worker_kept_mb over the budget", document(R"("worker_kept_mb": 257)"), "worker_kept_mb"},
        BadCase{"worker_kept_mb negative", document(R"("worker_kept_mb": -1)"), "worker_kept_mb"},
        BadCase{"io_threads 0", document(R"("io_threads": 0)"), "io_threads"},
        BadCase{"meshes not an object", document(R"("meshes": [1])"), "meshes"},
        BadCase{"mesh neither dataset nor file", document(R"("meshes": {"m": {"sectors": 8}})"), "meshes.m"},
        BadCase{"mesh both dataset and file", document(R"("meshes": {"m": {"dataset": "rainier", "file": "m.obj"}})"),
                "meshes.m"},
        BadCase{"mesh unknown dataset", document(R"("meshes": {"m": {"dataset": "everest"}})"), "meshes.m.dataset"},
        BadCase{"mesh unknown key", document(R"("meshes": {"m": {"dataset": "rainier", "sector": 8}})"),
                "meshes.m.sector"},
        BadCase{"mesh sectors 2", document(R"("meshes": {"m": {"dataset": "rainier", "sectors": 2}})"),
                "meshes.m.sectors"},
        BadCase{"mesh sectors x subsectors over 1024",
                document(R"("meshes": {"m": {"dataset": "rainier", "sectors": 64, "subsectors": 32}})"),
                "meshes.m.subsectors"},
        BadCase{"mesh vertices 3", document(R"("meshes": {"m": {"dataset": "rainier", "vertices": 3}})"),
                "meshes.m.vertices"},
        BadCase{"mesh merge_cutoff 0", document(R"("meshes": {"m": {"dataset": "rainier", "merge_cutoff": 0}})"),
                "meshes.m.merge_cutoff"},
        BadCase{"mesh max_error negative", document(R"("meshes": {"m": {"dataset": "rainier", "max_error_m": -1}})"),
                "meshes.m.max_error_m"},
        BadCase{"mesh file with vertices", document(R"("meshes": {"m": {"file": "m.obj", "vertices": 100}})"),
                "meshes.m.vertices"},
        BadCase{"mesh box of five", document(R"("meshes": {"m": {"dataset": "rainier", "boxes": [[1, 2, 3, 4, 5]]}})"),
                "meshes.m.boxes[0]"},
        BadCase{
            "mesh box reversed",
            document(R"("meshes": {"m": {"dataset": "rainier", "boxes": [[0, 0, 1, 1, 0, 1], [5, 0, 1, 1, 0, 1]]}})"),
            "meshes.m.boxes[1]"},
        BadCase{"mesh boxes over max_boxes", document(R"("limits": {"max_boxes": 1},
                            "meshes": {"m": {"dataset": "rainier", "boxes": [[0, 0, 1, 1, 0, 1], [0, 0, 1, 1, 0, 1]]}})"),
                "meshes.m.boxes"},
        BadCase{"mesh_cache_dir empty", document(R"("mesh_cache_dir": "")"), "mesh_cache_dir"}),
    [](const ::testing::TestParamInfo<BadCase>& test) {
      // "listen port too large" -> "listen_port_too_large"
      std::string name;
      for (const char* p = test.param.what; *p; ++p) name += std::isalnum(static_cast<unsigned char>(*p)) ? *p : '_';
      return name;
    });

TEST(ServerConfig, GpuContextsDefaultToOnePerWorkerAndZeroTurnsTheGpuOff) {
  auto absent = parse_config(document(""), "test.json", "/");
  ASSERT_TRUE(absent.ok()) << absent.error().message;
  EXPECT_FALSE(absent->gpu.contexts.has_value());  // the daemon opens one per worker thread
  for (const auto& [text, contexts] :
       {std::pair{R"("gpu": {"contexts": 0})", 0u}, std::pair{R"("gpu": {"contexts": 64})", 64u},
        std::pair{R"("gpu": {"contexts": 3}, "worker_threads": 8)", 3u}}) {
    auto c = parse_config(document(text), "test.json", "/");
    ASSERT_TRUE(c.ok()) << c.error().message;
    ASSERT_TRUE(c->gpu.contexts.has_value()) << text;
    EXPECT_EQ(*c->gpu.contexts, contexts) << text;
  }
  auto empty = parse_config(document(R"("gpu": {})"), "test.json", "/");
  ASSERT_TRUE(empty.ok()) << empty.error().message;
  EXPECT_FALSE(empty->gpu.contexts.has_value());
}

TEST(ServerConfig, DatasetOutsideTheDataRootIsRefused) {
  auto c = parse_config(document(R"("datasets": {"escape": "../../CMakeLists.txt"})"), "c.json", "/");
  ASSERT_TRUE(c.ok()) << c.error().message;  // files are resolved when datasets load
  auto file = resolve_dataset_file(*c, c->datasets[0]);
  ASSERT_FALSE(file.ok());
  EXPECT_EQ(file.error().field, "datasets.escape");
  EXPECT_NE(file.error().message.find("outside data_root"), std::string::npos) << file.error().message;
}

TEST(ServerConfig, MissingDatasetFileIsNotFound) {
  auto c = parse_config(document(R"("datasets": {"gone": "no_such.tif"})"), "c.json", "/");
  ASSERT_TRUE(c.ok()) << c.error().message;
  auto file = resolve_dataset_file(*c, c->datasets[0]);
  ASSERT_FALSE(file.ok());
  EXPECT_EQ(file.error().code, ErrorCode::kNotFound);
  EXPECT_EQ(file.error().field, "datasets.gone");
}

TEST(ServerConfig, MissingConfigFileIsNotFound) {
  auto c = load_config("/no/such/horizond.json");
  ASSERT_FALSE(c.ok());
  EXPECT_EQ(c.error().code, ErrorCode::kNotFound);
  EXPECT_NE(c.error().message.find("/no/such/horizond.json"), std::string::npos);
}

}  // namespace
}  // namespace horizon::server
