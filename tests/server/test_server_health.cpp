// The standard gRPC health service of an in-process Daemon: NOT_SERVING from
// the moment the port is bound until the datasets are loaded, SERVING after,
// for the whole server ("") and for each of our services. Called with raw
// bytes (grpc.health.v1 is not among our protos): HealthCheckRequest{service}
// and HealthCheckResponse{status}, where 1 = SERVING and 2 = NOT_SERVING.
#include <gtest/gtest.h>

#include <chrono>
#include <future>
#include <string>

#include <grpcpp/create_channel.h>
#include <grpcpp/generic/generic_stub.h>
#include <grpcpp/support/byte_buffer.h>

#include "config.hpp"
#include "daemon.hpp"
#include "rpc_helpers.hpp"

namespace horizon::server {
namespace {

// Returns the status byte of a HealthCheckResponse (-1 on an RPC error).
int health_status(grpc::GenericStub& stub, const std::string& service) {
  std::string request;
  if (!service.empty()) request = std::string("\x0a", 1) + static_cast<char>(service.size()) + service;
  std::string bytes;
  if (!testing::raw_unary_call(stub, "/grpc.health.v1.Health/Check", request, std::chrono::seconds(5), &bytes).ok())
    return -1;
  // field 1 (status), varint: 0x08 <value>
  return bytes.size() == 2 && bytes[0] == '\x08' ? bytes[1] : -1;
}

TEST(ServerHealth, NotServingUntilTheDatasetsAreLoaded) {
  const std::string text = R"({"listen": "127.0.0.1:0", "plaintext": true, "data_root": ")" +
                           std::string(HORIZON_DATA_DIR) +
                           R"(", "datasets": {"rainier": "rainier_summit_srtm3_400x400.tif"},
                               "memory_budget_mb": 128, "shutdown_grace_ms": 0})";
  auto config = parse_config(text, "health.json", "/");
  ASSERT_TRUE(config.ok()) << config.error().message;
  Daemon daemon(*config);
  ASSERT_TRUE(daemon.start().ok());
  ASSERT_GT(daemon.port(), 0);
  grpc::GenericStub stub(
      grpc::CreateChannel("127.0.0.1:" + std::to_string(daemon.port()), grpc::InsecureChannelCredentials()));

  for (const char* service : {"", "horizon.v1.DatasetService", "horizon.v1.VisibilityService"})
    EXPECT_EQ(health_status(stub, service), 2) << "before load: '" << service << "'";

  ASSERT_TRUE(daemon.load_datasets().ok());
  for (const char* service : {"", "horizon.v1.DatasetService", "horizon.v1.VisibilityService"})
    EXPECT_EQ(health_status(stub, service), 1) << "after load: '" << service << "'";
  EXPECT_EQ(health_status(stub, "horizon.v1.NoSuchService"), -1);  // NOT_FOUND
  daemon.shutdown();
}

}  // namespace
}  // namespace horizon::server
