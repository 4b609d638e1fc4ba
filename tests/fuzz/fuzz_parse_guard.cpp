// libFuzzer target: the parse guard (protos/guard/parse_guard.hpp) on any
// wire bytes of any horizon.v1 request. The first byte picks the request
// type (HORIZON_GUARDED_REQUESTS' order); the rest is its wire. What must
// hold, or the target aborts:
//   - the walk's bound of a parse on the heap covers what protobuf's parse
//     holds on the heap, and its bound covers a parse on the daemon's call
//     arena (arena_allocator.hpp), the arena's blocks included;
//   - a wire the walk cannot read (malformed) is one protobuf cannot parse;
//   - a guarded parse (as the daemon's gRPC serialisation does it, under an
//     allowance) leaves no unknown field at any depth, and a wire the walk
//     could not read is refused unparsed, the message holding the refusal.
#include <malloc.h>

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include <google/protobuf/arena.h>
#include <google/protobuf/message.h>
#include <google/protobuf/stubs/logging.h>
#include <google/protobuf/unknown_field_set.h>
#include <grpcpp/support/byte_buffer.h>
#include <grpcpp/support/slice.h>

#if defined(__SANITIZE_ADDRESS__)
#include <sanitizer/allocator_interface.h>
#endif

#include "arena_allocator.hpp"
#include "horizon/v1/datasets.pb.h"
#include "horizon/v1/mesh.pb.h"
#include "horizon/v1/session.pb.h"
#include "horizon/v1/trace.pb.h"
#include "horizon/v1/visibility.pb.h"
#include "parse_guard.hpp"

namespace {

// Bytes the heap has handed out (arena blocks included).
std::uint64_t heap_in_use() {
#if defined(__SANITIZE_ADDRESS__)
  return __sanitizer_get_current_allocated_bytes();
#else
  const struct mallinfo2 info = mallinfo2();
  return info.uordblks + info.hblkhd;
#endif
}

[[noreturn]] void fail(const std::string& type, const std::string& what) {
  std::fprintf(stderr, "parse guard: %s: %s\n", type.c_str(), what.c_str());
  std::abort();
}

// A parse that held more than its bound.
void check_held(const std::string& type, const char* where, std::uint64_t before, std::uint64_t bound) {
  const std::uint64_t held = heap_in_use() - before;
  if (held > bound)
    fail(type, std::string(where) + " it held " + std::to_string(held) + " bytes, its bound " + std::to_string(bound));
}

// Whether `message` or any message in it has unknown fields.
bool has_unknown_fields(const google::protobuf::Message& message) {
  const google::protobuf::Reflection& reflection = *message.GetReflection();
  if (!reflection.GetUnknownFields(message).empty()) return true;
  std::vector<const google::protobuf::FieldDescriptor*> fields;
  reflection.ListFields(message, &fields);
  for (const google::protobuf::FieldDescriptor* f : fields) {
    if (f->cpp_type() != google::protobuf::FieldDescriptor::CPPTYPE_MESSAGE) continue;
    if (!f->is_repeated()) {
      if (has_unknown_fields(reflection.GetMessage(message, f))) return true;
      continue;
    }
    for (int i = 0, n = reflection.FieldSize(message, f); i < n; ++i)
      if (has_unknown_fields(reflection.GetRepeatedMessage(message, f, i))) return true;
  }
  return false;
}

// Refuses nothing: the guard's walk and parse run in full.
struct Unlimited final : horizon::proto::ParseAllowance {
  bool take(std::uint64_t) override { return true; }
  void give(std::uint64_t) override {}
};

template <class T>
void check(const std::string& wire) {
  const horizon::proto::ParseBound bound = horizon::proto::parse_bound(*T::descriptor(), wire);
  const std::string& type = T::descriptor()->full_name();
  if (bound.malformed) {
    // The walk refuses only what protobuf's parse refuses too.
    T message;
    if (message.ParseFromString(wire)) fail(type, "the walk refused a wire protobuf parses");
  } else {
    {
      T message;
      const std::uint64_t before = heap_in_use();
      if (message.ParseFromString(wire)) check_held(type, "on the heap", before, bound.heap_bytes);
    }
    {
      google::protobuf::Arena arena(horizon::server::call_arena_options());
      T* message = google::protobuf::Arena::CreateMessage<T>(&arena);
      const std::uint64_t before = heap_in_use();
      if (message->ParseFromString(wire)) check_held(type, "on the call arena", before, bound.bytes);
    }
  }
  static Unlimited allowance;
  horizon::proto::set_parse_allowance(&allowance);
  grpc::Slice slice(wire);
  grpc::ByteBuffer buffer(&slice, 1);
  T guarded;
  const bool parsed = grpc::SerializationTraits<T>::Deserialize(&buffer, &guarded).ok();
  horizon::proto::remove_parse_allowance(&allowance);
  const auto refusal = horizon::proto::refused_parse(guarded);
  if (!parsed) return;
  if (bound.malformed && !(refusal && refusal->malformed)) fail(type, "a wire the walk could not read was parsed");
  if (!refusal && has_unknown_fields(guarded)) fail(type, "a guarded parse kept unknown fields");
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const bool quiet = [] {
    google::protobuf::SetLogHandler(nullptr);  // invalid UTF-8 in a string field is an expected input
    return true;
  }();
  (void)quiet;
  if (size < 1) return 0;
  const std::string wire(reinterpret_cast<const char*>(data) + 1, size - 1);
  int pick = data[0] % 11, index = 0;
#define HORIZON_FUZZ_REQUEST(T) \
  if (index++ == pick) check<horizon::v1::T>(wire);
  HORIZON_GUARDED_REQUESTS(HORIZON_FUZZ_REQUEST)
#undef HORIZON_FUZZ_REQUEST
  return 0;
}
