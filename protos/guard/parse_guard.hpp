// parse_guard.hpp — every horizon.v1 request is weighed before it is parsed.
//
// gRPC parses a request before any handler sees it, so the daemon's
// admission (server/src/call_scope.hpp) used to count a request's memory
// only once it was built. Small elements make the built message many times
// its wire size: 1 000 000 empty boxes are 2 MB on the wire and ~94 MB
// parsed, and gRPC takes messages up to the limits' largest (10 MB by
// default). Here each request type's gRPC serialisation
// (grpc::SerializationTraits, gRPC's extension point for it) first walks
// the wire bytes and bounds what parsing will allocate, on the heap or on
// an arena whose blocks are at most kArenaBlockBytes:
//   - every message it holds at its C++ size;
//   - a repeated field's arrays: each doubles in bytes as it grows, and on
//     an arena the arrays it outgrew stay, and one that does not fit its
//     block leaves that block part-used;
//   - strings, and unknown fields (numbers the type lacks, or a known
//     field in another wire type): their bytes, and a few dozen bytes each
//     for the objects that hold them, counted field by field (a million
//     3-byte unknown fields hold ~17 MB, and half as much again while
//     their vector grows);
//   - malloc's overhead per allocation on the heap; on an arena, an object
//     too large for what is left of its block, and the last block's tail.
//
// A process that installs a ParseAllowance (the daemon: its memory budget)
// takes that bound from it for the parse and gives it back after, and drops
// the unknown fields of what it parsed (nothing reads them), so that what
// the request holds is what its handler's admission counts. When the
// allowance refuses, or the walk cannot read the bytes, nothing is parsed;
// when protobuf cannot parse them, what was parsed is dropped. Either way
// the message is left empty but for a refusal that refused_parse() reads,
// and the handler answers with it (RESOURCE_EXHAUSTED, INVALID_ARGUMENT):
// gRPC's callback API would answer a failed parse UNIMPLEMENTED, with no
// message. Without an allowance (the
// CLI, the clients, tests) messages parse as gRPC's default does.
//
// The specialisations must be seen before any use of the types'
// serialisation in every translation unit, so horizon_proto gives this
// header to each of its users' C++ sources as a forced include
// (protos/CMakeLists.txt); their definitions are in parse_guard.cpp, once.
#pragma once

#include <cstdint>
#include <optional>
#include <string>

#include <grpcpp/impl/codegen/serialization_traits.h>

namespace google::protobuf {
class Descriptor;
class Message;
class MessageLite;
}  // namespace google::protobuf

namespace grpc {
class ByteBuffer;
class Status;
}  // namespace grpc

// Every request type of the horizon.v1 services, the guarded ones.
#define HORIZON_GUARDED_REQUESTS(X) \
  X(ListDatasetsRequest)            \
  X(GetDatasetRequest)              \
  X(ListMeshesRequest)              \
  X(DescribeMeshRequest)            \
  X(CullMeshRequest)                \
  X(SessionRequest)                 \
  X(TraceRequest)                   \
  X(ViewshedRequest)                \
  X(LineOfSightRequest)             \
  X(CullBoxesRequest)               \
  X(RegionVisibilityRequest)

namespace horizon::v1 {
#define HORIZON_DECLARE_REQUEST(T) class T;
HORIZON_GUARDED_REQUESTS(HORIZON_DECLARE_REQUEST)
#undef HORIZON_DECLARE_REQUEST
}  // namespace horizon::v1

namespace horizon::proto {

// The largest block of an arena the bound holds for (ArenaAllocator's, in
// the daemon). A larger block leaves a larger tail unused.
inline constexpr std::uint64_t kArenaBlockBytes = 1 << 20;

// What a process lets its requests' parsing hold at once.
class ParseAllowance {
 public:
  virtual ~ParseAllowance() = default;
  // Takes `bytes` for a parse, or nothing (false).
  virtual bool take(std::uint64_t bytes) = 0;
  virtual void give(std::uint64_t bytes) = 0;
};

// Installs `allowance` for every later parse of the process; it must outlive
// them (the daemon installs it before it listens). One at a time: a later
// install replaces an earlier one.
void set_parse_allowance(ParseAllowance* allowance);
// Removes `allowance` if it is the one installed (the daemon, after its
// server has stopped: a daemon that stops never removes another's).
void remove_parse_allowance(ParseAllowance* allowance);

// An upper bound of the bytes parsing `wire` as a `type` allocates (see the
// header's comment), and the messages it holds, itself included.
struct ParseBound {
  std::uint64_t bytes = 0;
  std::uint64_t heap_bytes = 0;  // the bound of a parse on the heap alone (no arena), at most `bytes`
  std::uint64_t messages = 0;
  // Unknown fields on the wire. A guarded parse drops them once parsed
  // (nothing reads them), so what the request holds after is its fields'.
  std::uint64_t unknown_fields = 0;
  // The walk could not read the wire to its end (cut short, a length past
  // its end, a group never closed, nesting past protobuf's limit, a string
  // field that is not UTF-8): `bytes` and `messages` count what it read. A
  // guarded parse refuses such a request unparsed, so nothing the walk did
  // not see is ever parsed (and protobuf logs nothing of it).
  bool malformed = false;
  std::string not_utf8;  // the full name of the first string field that was not UTF-8
};
ParseBound parse_bound(const google::protobuf::Descriptor& type, const std::string& wire);

// What a guarded parse left in a request instead of its fields.
struct ParseRefusal {
  bool malformed = false;  // the bytes do not parse; else the allowance refused them
  std::string message;     // in the user's words, for the status
};
std::optional<ParseRefusal> refused_parse(const google::protobuf::Message& request);

// Whether `type` is one of HORIZON_GUARDED_REQUESTS (a test holds every
// service's request types to it).
bool is_guarded(const google::protobuf::Descriptor& type);

}  // namespace horizon::proto

#define HORIZON_GUARDED_REQUEST(T)                                                                                   \
  template <>                                                                                                        \
  class grpc::SerializationTraits<horizon::v1::T, void> {                                                            \
   public:                                                                                                           \
    static grpc::Status Serialize(const google::protobuf::MessageLite& msg, grpc::ByteBuffer* bb, bool* own_buffer); \
    static grpc::Status Deserialize(grpc::ByteBuffer* buffer, google::protobuf::MessageLite* msg);                   \
  };
HORIZON_GUARDED_REQUESTS(HORIZON_GUARDED_REQUEST)
#undef HORIZON_GUARDED_REQUEST
