// arena_allocator.hpp — request and response of a unary call on one protobuf
// Arena. A CullBoxes call carries up to 100 000 boxes each way; with the
// default allocator every Box and BoxResult is its own heap allocation (malloc
// and free were 12 % of a 10 000-box call's server time), with an arena they
// are bumps in a few blocks, freed at once when gRPC releases the call.
#pragma once

#include <cstddef>
#include <cstdint>

#include <google/protobuf/arena.h>
#include <google/protobuf/message.h>
#include <grpcpp/support/message_allocator.h>

#include "parse_guard.hpp"

namespace horizon::server {

// The bytes a received message holds: its arena's blocks when it lives on
// one (the request, and its response as far as it is filled), else its own
// heap footprint.
inline std::uint64_t held_bytes(const google::protobuf::Message& message) {
  if (google::protobuf::Arena* arena = message.GetArena()) return arena->SpaceAllocated();
  return message.SpaceUsedLong();
}

// The arena a call's messages live on. Blocks grow from 4 KiB (a small call
// stays small) to 1 MiB, so a large call's blocks are mapped pages that go
// back to the system when it ends (allocator.hpp) rather than heap that
// stays fragmented. The parse guard's bound holds for blocks up to its
// kArenaBlockBytes.
inline constexpr std::size_t kCallArenaBlockBytes = 1 << 20;
static_assert(kCallArenaBlockBytes <= proto::kArenaBlockBytes, "the parse guard's bound covers the call arena");
inline google::protobuf::ArenaOptions call_arena_options() {
  google::protobuf::ArenaOptions o;
  o.start_block_size = 4 << 10;
  o.max_block_size = kCallArenaBlockBytes;
  return o;
}

template <class Request, class Response>
class ArenaAllocator final : public grpc::MessageAllocator<Request, Response> {
 public:
  grpc::MessageHolder<Request, Response>* AllocateMessages() override { return new Holder; }

 private:
  class Holder final : public grpc::MessageHolder<Request, Response> {
   public:
    Holder() {
      this->set_request(google::protobuf::Arena::CreateMessage<Request>(&arena_));
      this->set_response(google::protobuf::Arena::CreateMessage<Response>(&arena_));
    }
    void Release() override { delete this; }

   private:
    google::protobuf::Arena arena_{call_arena_options()};
  };
};

}  // namespace horizon::server
