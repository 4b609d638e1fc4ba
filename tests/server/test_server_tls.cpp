// TLS and bearer tokens on a real daemon, with a CA, server and client
// certificates made at test time (openssl): the right token over TLS is
// served; no token, a wrong one, plaintext to the TLS port and our services
// on the plaintext health port are refused; mutual TLS refuses a client
// without a certificate; the CLI speaks it all with --ca, --client-cert and
// --token-file.
#include <gtest/gtest.h>

#include <fstream>
#include <future>
#include <regex>
#include <sstream>
#include <string>

#include <grpcpp/create_channel.h>
#include <grpcpp/generic/generic_stub.h>
#include <grpcpp/security/credentials.h>
#include <grpcpp/support/byte_buffer.h>

#include "daemon_process.hpp"
#include "rpc_helpers.hpp"

namespace horizon::testing {
namespace {

constexpr const char* kToken = "s3cret-token-for-tests-0123456789";

// A CA, a server certificate for 127.0.0.1 and a client certificate, in `dir`.
bool make_certificates(const TempDir& dir) {
  const std::string d = dir.path().string();
  const std::string key = " -newkey ec -pkeyopt ec_paramgen_curve:prime256v1 -nodes";
  write_file(d + "/server.ext", "subjectAltName=IP:127.0.0.1,DNS:localhost\n");
  const std::string script =
      "cd " + d + " && openssl req -x509" + key + " -keyout ca.key -out ca.pem -days 2 -subj '/CN=horizon test CA'" +
      " && openssl req" + key + " -keyout server.key -out server.csr -subj '/CN=localhost'" +
      " && openssl x509 -req -in server.csr -CA ca.pem -CAkey ca.key -CAcreateserial -out server.pem -days 2" +
      " -extfile server.ext" + " && openssl req" + key +
      " -keyout client.key -out client.csr -subj '/CN=horizon test client'" +
      " && openssl x509 -req -in client.csr -CA ca.pem -CAkey ca.key -CAcreateserial -out client.pem -days 2";
  const CommandResult r = run_command(script);
  if (r.exit_code != 0) ADD_FAILURE() << r.output;
  write_file(d + "/tokens", std::string("# one token a line\n") + kToken + "\n\nanother-token-0123456789\n");
  return r.exit_code == 0;
}

DaemonOptions secured(const TempDir& certs, bool mutual) {
  DaemonOptions o;
  o.plaintext = false;
  const std::string d = certs.path().string();
  o.extra_json = R"("tls": {"cert_file": ")" + d + R"(/server.pem", "key_file": ")" + d + R"(/server.key")" +
                 (mutual ? R"(, "client_ca_file": ")" + d + R"(/ca.pem")" : std::string()) +
                 R"(}, "health_listen": "127.0.0.1:0", "auth_tokens_file": ")" + d + R"(/tokens",)";
  return o;
}

std::shared_ptr<grpc::Channel> tls_channel(const DaemonProcess& daemon, const TempDir& certs, bool with_cert) {
  grpc::SslCredentialsOptions tls;
  tls.pem_root_certs = read_bytes(certs.file("ca.pem"));
  if (with_cert) {
    tls.pem_cert_chain = read_bytes(certs.file("client.pem"));
    tls.pem_private_key = read_bytes(certs.file("client.key"));
  }
  return grpc::CreateChannel(daemon.address(), grpc::SslCredentials(tls));
}

grpc::StatusCode list_datasets(const std::shared_ptr<grpc::Channel>& channel, const std::string& token) {
  auto stub = v1::DatasetService::NewStub(channel);
  auto context = context_with_deadline(std::chrono::seconds(10));
  if (!token.empty()) context->AddMetadata("authorization", "Bearer " + token);
  v1::ListDatasetsRequest request;
  v1::ListDatasetsResponse response;
  const grpc::Status s = stub->ListDatasets(context.get(), request, &response);
  return s.ok() && response.datasets_size() > 0 ? grpc::StatusCode::OK : s.error_code();
}

TEST(ServerTls, TokensOverTlsAreServedAndEverythingElseRefused) {
  TempDir certs;
  ASSERT_TRUE(make_certificates(certs));
  DaemonProcess daemon(secured(certs, /*mutual=*/false));
  ASSERT_TRUE(daemon.ready()) << daemon.error();
  EXPECT_NE(daemon.log().find("\"transport\":\"tls\""), std::string::npos) << daemon.log();
  const auto channel = tls_channel(daemon, certs, false);
  EXPECT_EQ(list_datasets(channel, kToken), grpc::StatusCode::OK);
  EXPECT_EQ(list_datasets(channel, "another-token-0123456789"), grpc::StatusCode::OK);
  EXPECT_EQ(list_datasets(channel, ""), grpc::StatusCode::UNAUTHENTICATED);
  EXPECT_EQ(list_datasets(channel, "s3cret-token-for-tests-0123456788"), grpc::StatusCode::UNAUTHENTICATED);
  // Plaintext to the TLS port: no handshake, no call.
  EXPECT_EQ(list_datasets(daemon.channel(), kToken), grpc::StatusCode::UNAVAILABLE);
  // The plaintext health port answers probes, and refuses our services even with a token.
  std::smatch m;
  const std::string log = daemon.log();
  ASSERT_TRUE(std::regex_search(log, m, std::regex("\"health_port\":([0-9]+)"))) << log;
  const auto health = grpc::CreateChannel("127.0.0.1:" + m[1].str(), grpc::InsecureChannelCredentials());
  EXPECT_EQ(list_datasets(health, kToken), grpc::StatusCode::UNAUTHENTICATED);
  grpc::GenericStub stub(health);
  EXPECT_TRUE(testing::raw_unary_call(stub, "/grpc.health.v1.Health/Check", "", std::chrono::seconds(5)).ok());
  // The request log says who was refused, never the token.
  EXPECT_EQ(daemon.log().find(kToken), std::string::npos);
  EXPECT_NE(daemon.log().find("UNAUTHENTICATED"), std::string::npos);
}

TEST(ServerTls, MutualTlsRefusesAClientWithoutACertificate) {
  TempDir certs;
  ASSERT_TRUE(make_certificates(certs));
  DaemonProcess daemon(secured(certs, /*mutual=*/true));
  ASSERT_TRUE(daemon.ready()) << daemon.error();
  EXPECT_NE(daemon.log().find("\"transport\":\"mutual tls\""), std::string::npos);
  EXPECT_EQ(list_datasets(tls_channel(daemon, certs, true), kToken), grpc::StatusCode::OK);
  EXPECT_EQ(list_datasets(tls_channel(daemon, certs, false), kToken), grpc::StatusCode::UNAVAILABLE);
}

TEST(ServerTls, TheCliSpeaksTlsWithATokenFile) {
  TempDir certs;
  ASSERT_TRUE(make_certificates(certs));
  DaemonProcess daemon(secured(certs, /*mutual=*/true));
  ASSERT_TRUE(daemon.ready()) << daemon.error();
  write_file(certs.file("my.token"), std::string(kToken) + "\n");
  const std::string cli = std::string(HORIZON_CLI_PATH) + " datasets --server " + daemon.address() + " --ca " +
                          certs.file("ca.pem") + " --client-cert " + certs.file("client.pem") + "," +
                          certs.file("client.key");
  const CommandResult ok = run_command(cli + " --token-file " + certs.file("my.token"));
  EXPECT_EQ(ok.exit_code, 0) << ok.output;
  EXPECT_NE(ok.output.find("rainier"), std::string::npos) << ok.output;
  const CommandResult no_token = run_command("env -u HORIZON_TOKEN " + cli);
  EXPECT_EQ(no_token.exit_code, 1) << no_token.output;
  EXPECT_NE(no_token.output.find("UNAUTHENTICATED"), std::string::npos) << no_token.output;
  const CommandResult from_env = run_command(std::string("HORIZON_TOKEN=") + kToken + " " + cli);
  EXPECT_EQ(from_env.exit_code, 0) << from_env.output;
}

}  // namespace
}  // namespace horizon::testing
