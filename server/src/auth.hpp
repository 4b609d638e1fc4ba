// auth.hpp — who may call: bearer tokens from a file, checked on every call
// of horizond's own services (the health service and server reflection stay
// open, for load balancers and tooling).
//
// A client sends the metadata "authorization: Bearer <token>". The daemon
// accepts it when it equals one of the tokens of config auth_tokens_file
// (one a line; blank lines and '#' comments skipped; each at least 16
// characters without spaces). The comparison takes a time that depends on
// the tokens' lengths only, never on how much of a guess was right.
// Without auth_tokens_file every call is accepted (plaintext loopback
// deployments and tests); TLS (config tls) protects the token on the wire.
#pragma once

#include <filesystem>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include <grpcpp/support/status.h>

#include "horizon/common/error.hpp"

namespace horizon::server {

// The tokens of `path`; the error names the file and, for a bad line, its
// number (never the line itself), with `key` as its field.
Result<std::vector<std::string>> read_tokens(const std::filesystem::path& path, const std::string& key);

// Nothing when `authorization` (the metadata's value; empty when absent) is
// "Bearer <t>" with t one of `tokens`, else the UNAUTHENTICATED status to
// finish the call with.
std::optional<grpc::Status> check_bearer(std::string_view authorization, const std::vector<std::string>& tokens);

// a == b in a time that depends on b's length only.
bool same_secret(std::string_view a, std::string_view b);

}  // namespace horizon::server
