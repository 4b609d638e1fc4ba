// dataset_service.hpp — horizon.v1.DatasetService: answered from memory on
// gRPC's threads (no computation, so no pool hop).
#pragma once

#include "horizon/v1/datasets.grpc.pb.h"
#include "server_env.hpp"

namespace horizon::server {

class DatasetService final : public v1::DatasetService::CallbackService {
 public:
  explicit DatasetService(ServerEnv& env) : env_(env) {}

  grpc::ServerUnaryReactor* ListDatasets(grpc::CallbackServerContext* context, const v1::ListDatasetsRequest* request,
                                         v1::ListDatasetsResponse* response) override;
  grpc::ServerUnaryReactor* GetDataset(grpc::CallbackServerContext* context, const v1::GetDatasetRequest* request,
                                       v1::Dataset* response) override;

 private:
  ServerEnv& env_;
};

// Page tokens: opaque to clients; here "v1:" + the last name returned, hex-encoded.
std::string encode_page_token(const std::string& last_name);
std::optional<std::string> decode_page_token(const std::string& token);

}  // namespace horizon::server
