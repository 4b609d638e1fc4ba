#include "auth.hpp"

#include <fstream>

namespace horizon::server {

Result<std::vector<std::string>> read_tokens(const std::filesystem::path& path, const std::string& key) {
  std::ifstream in(path);
  if (!in) return make_error(ErrorCode::kNotFound, "cannot read '" + path.string() + "'", key);
  std::vector<std::string> tokens;
  std::string line;
  for (int number = 1; std::getline(in, line); ++number) {
    const auto first = line.find_first_not_of(" \t\r");
    if (first == std::string::npos || line[first] == '#') continue;
    const auto last = line.find_last_not_of(" \t\r");
    const std::string token = line.substr(first, last - first + 1);
    if (token.size() < 16 || token.find_first_of(" \t") != std::string::npos)
      return make_error(ErrorCode::kInvalidArgument,
                        "line " + std::to_string(number) + " of '" + path.string() +
                            "' is not a token (at least 16 characters, no spaces)",
                        key);
    tokens.push_back(token);
  }
  if (tokens.empty()) return make_error(ErrorCode::kInvalidArgument, "no token in '" + path.string() + "'", key);
  return tokens;
}

bool same_secret(std::string_view a, std::string_view b) {
  unsigned diff = a.size() == b.size() ? 0u : 1u;
  for (std::size_t i = 0; i < b.size(); ++i)
    diff |= static_cast<unsigned char>(b[i]) ^ static_cast<unsigned char>(i < a.size() ? a[i] : 0);
  return diff == 0;
}

std::optional<grpc::Status> check_bearer(std::string_view authorization, const std::vector<std::string>& tokens) {
  constexpr std::string_view kScheme = "Bearer ";
  if (authorization.substr(0, kScheme.size()) != kScheme)
    return grpc::Status(grpc::StatusCode::UNAUTHENTICATED,
                        "this daemon needs a bearer token: metadata 'authorization: Bearer <token>'");
  const std::string_view given = authorization.substr(kScheme.size());
  bool accepted = false;
  for (const std::string& token : tokens) accepted |= same_secret(given, token);  // every token, always
  if (!accepted) return grpc::Status(grpc::StatusCode::UNAUTHENTICATED, "the bearer token is not accepted");
  return std::nullopt;
}

}  // namespace horizon::server
