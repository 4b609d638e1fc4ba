// unary_call.hpp — a unary RPC whose work runs on the worker pool.
//
// The reactor is created on a gRPC thread, admits the call (its request
// checked, `message_bytes` reserved for its messages and `work_bytes` for
// what its request alone will make: CallScope::admit), and posts the
// work to the Asio pool; the work fills the response and returns the status,
// and the reactor finishes the call from the pool thread. OnCancel (client
// cancelled, deadline passed, server shutting down past its grace) sets the
// call's cancel token, which the engine polls, and finishes at once a call
// still waiting for a worker (QueueTicket). The reactor deletes itself in
// OnDone, which gRPC calls only after Finish.
#pragma once

#include <cstdint>
#include <functional>
#include <string_view>
#include <utility>

#include <grpcpp/server_context.h>
#include <grpcpp/support/server_callback.h>

#include "call_scope.hpp"
#include "handoff.hpp"

namespace horizon::server {

class UnaryCall final : public grpc::ServerUnaryReactor {
 public:
  using Work = std::function<grpc::Status(CallScope&)>;

  // Starts the call; returns the reactor to hand back to gRPC.
  static grpc::ServerUnaryReactor* start(ServerEnv& env, grpc::CallbackServerContext* context, std::string_view method,
                                         const google::protobuf::Message& request, std::uint64_t message_bytes,
                                         std::uint64_t work_bytes, std::string_view work_what, Work work) {
    auto* call = new UnaryCall(env, context, method);
    if (auto refused = call->scope_.admit(request, message_bytes, work_bytes, work_what)) {
      call->finish(*refused);
      return call;
    }
    call->handoff_.publish();  // gRPC may run OnCancel from now on
    env.pool.post([call, ticket = call->scope_.ticket(), work = std::move(work)]() mutable {
      if (ticket.take()) call->finish(work(call->scope_));  // else finished by OnCancel, perhaps deleted
    });
    return call;
  }

  void OnCancel() override {
    handoff_.from_grpc();
    if (auto dropped = scope_.cancel()) return finish(*dropped);
    handoff_.publish();  // gRPC runs OnDone only after this returns
  }
  void OnDone() override {
    handoff_.from_grpc();
    delete this;
  }

 private:
  UnaryCall(ServerEnv& env, grpc::CallbackServerContext* context, std::string_view method)
      : scope_(env, context, method) {}

  void finish(const grpc::Status& status) {
    scope_.finish(status);
    handoff_.to_grpc([&] { Finish(status); });  // after this, `this` may be deleted at any time
  }

  Handoff handoff_;
  CallScope scope_;
};

}  // namespace horizon::server
