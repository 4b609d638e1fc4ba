#include "dataset_service.hpp"

#include <algorithm>

#include "call_scope.hpp"
#include "grpc_status.hpp"
#include "translate.hpp"

namespace horizon::server {

std::string encode_page_token(const std::string& last_name) {
  static const char* kHex = "0123456789abcdef";
  const std::string plain = "v1:" + last_name;
  std::string out;
  for (unsigned char c : plain) {
    out += kHex[c >> 4];
    out += kHex[c & 15];
  }
  return out;
}

std::optional<std::string> decode_page_token(const std::string& token) {
  if (token.size() % 2) return std::nullopt;
  std::string plain;
  for (std::size_t i = 0; i < token.size(); i += 2) {
    auto digit = [](char c) -> int {
      if (c >= '0' && c <= '9') return c - '0';
      if (c >= 'a' && c <= 'f') return c - 'a' + 10;
      return -1;
    };
    const int hi = digit(token[i]), lo = digit(token[i + 1]);
    if (hi < 0 || lo < 0) return std::nullopt;
    plain += static_cast<char>(hi * 16 + lo);
  }
  if (!plain.starts_with("v1:")) return std::nullopt;
  return plain.substr(3);
}

grpc::ServerUnaryReactor* DatasetService::ListDatasets(grpc::CallbackServerContext* context,
                                                       const v1::ListDatasetsRequest* request,
                                                       v1::ListDatasetsResponse* response) {
  auto* reactor = context->DefaultReactor();
  CallScope scope(env_, context, "ListDatasets");
  auto finish = [&](const grpc::Status& status) {
    scope.finish(status);
    reactor->Finish(status);
    return reactor;
  };
  if (auto refused = scope.admit(*request)) return finish(*refused);
  if (request->page_size() < 0)
    return finish(to_grpc_status(make_error(ErrorCode::kInvalidArgument, "page_size: must be >= 0", "page_size")));
  const int page_size = request->page_size() == 0 ? 100 : std::min(request->page_size(), 1000);
  std::string after;
  if (!request->page_token().empty()) {
    auto decoded = decode_page_token(request->page_token());
    if (!decoded)
      return finish(to_grpc_status(
          make_error(ErrorCode::kInvalidArgument, "page_token: not a token this server issued", "page_token")));
    after = *decoded;
  }
  const auto set = env_.datasets.snapshot();
  response->set_total_size(static_cast<int>(set->size()));
  auto it = request->page_token().empty() ? set->begin() : set->upper_bound(after);
  for (int n = 0; it != set->end() && n < page_size; ++it, ++n)
    fill_dataset(*it->second, env_.cache, *response->add_datasets());
  if (it != set->end() && response->datasets_size() > 0)
    response->set_next_page_token(encode_page_token(response->datasets(response->datasets_size() - 1).name()));
  return finish(grpc::Status::OK);
}

grpc::ServerUnaryReactor* DatasetService::GetDataset(grpc::CallbackServerContext* context,
                                                     const v1::GetDatasetRequest* request, v1::Dataset* response) {
  auto* reactor = context->DefaultReactor();
  CallScope scope(env_, context, "GetDataset");
  auto finish = [&](const grpc::Status& status) {
    scope.finish(status);
    reactor->Finish(status);
    return reactor;
  };
  if (auto refused = scope.admit(*request)) return finish(*refused);
  auto dataset = scope.dataset(request->name());
  if (!dataset.ok()) {
    Error e = dataset.error();
    if (e.code == ErrorCode::kInvalidArgument) e.field = "name";
    return finish(to_grpc_status(e));
  }
  fill_dataset(**dataset, env_.cache, *response);
  return finish(grpc::Status::OK);
}

}  // namespace horizon::server
