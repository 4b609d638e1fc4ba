// The parse guard (protos/guard/parse_guard.hpp) against protobuf's own
// parse: its bound covers what a request holds parsed, on the daemon's call
// arena and on the heap, however the wire is made; it guards every service's
// requests; and under an allowance it drops what nothing reads.
#include <gtest/gtest.h>
#include <malloc.h>

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>
#include <utility>

#include <google/protobuf/arena.h>
#include <google/protobuf/unknown_field_set.h>
#include <grpcpp/support/byte_buffer.h>
#include <grpcpp/support/slice.h>

#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)
// The sanitizers' allocators count what they hand out (GCC ships no header
// declaring it; the runtimes of both define it).
extern "C" std::size_t __sanitizer_get_current_allocated_bytes();
#endif

#include "arena_allocator.hpp"
#include "horizon/v1/datasets.pb.h"
#include "horizon/v1/mesh.pb.h"
#include "horizon/v1/session.pb.h"
#include "horizon/v1/trace.pb.h"
#include "horizon/v1/visibility.pb.h"
#include "parse_guard.hpp"

namespace horizon::server {
namespace {

// Bytes the heap has handed out, overhead included (arena blocks are heap
// allocations too).
std::uint64_t heap_in_use() {
#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)
  return __sanitizer_get_current_allocated_bytes();
#else
  const struct mallinfo2 info = mallinfo2();
  return info.uordblks + info.hblkhd;
#endif
}

// What parsing `wire` as a T holds, on the arena of the daemon's batched
// calls (arena_allocator.hpp) and on the heap (the other calls), next to the
// guard's bound of it (protos/guard/parse_guard.hpp).
struct Held {
  std::uint64_t arena = 0, heap = 0, bound = 0, heap_bound = 0;
};
template <class T>
Held held_and_bound(const std::string& wire) {
  Held held;
  {
    google::protobuf::Arena arena(call_arena_options());
    T* message = google::protobuf::Arena::CreateMessage<T>(&arena);
    const std::uint64_t empty = heap_in_use();
    EXPECT_TRUE(message->ParseFromString(wire));
    held.arena = heap_in_use() - empty;
  }
  {
    auto message = std::make_unique<T>();
    const std::uint64_t empty = heap_in_use();
    EXPECT_TRUE(message->ParseFromString(wire));
    held.heap = heap_in_use() - empty;
  }
  const proto::ParseBound bound = proto::parse_bound(*T::descriptor(), wire);
  held.bound = bound.bytes;
  held.heap_bound = bound.heap_bytes;
  return held;
}

// The bound is never below what parsing holds, whatever the elements' size
// on the wire (empty boxes are 2 bytes each, packed ids 1), and within a
// small factor of it for real requests, so that a legitimate request is not
// refused for its bound.
TEST(ParseGuard, TheBoundCoversWhatParsingHolds) {
  v1::CullBoxesRequest real, empty;
  real.set_dataset("ecuador");
  for (int i = 0; i < 100'000; ++i) {
    v1::Box* b = real.add_boxes();
    b->set_x_min(700000 + i);
    b->set_x_max(700010 + i);
    b->set_y_min(9500000);
    b->set_y_max(9500010);
    b->set_z_min(2000);
    b->set_z_max(2100);
    b->set_id(static_cast<std::uint64_t>(i));
    empty.add_boxes();
  }
  v1::LineOfSightRequest lines;
  for (int i = 0; i < 10'000; ++i) {
    v1::SightLine* l = lines.add_lines();
    l->mutable_from()->set_x(i);
    l->mutable_to()->set_y(i);
  }
  v1::SessionRequest removes;
  for (int i = 0; i < 1'000'000; ++i) removes.mutable_boxes()->add_remove(static_cast<std::uint64_t>(i % 100));
  v1::ViewshedRequest observers;
  for (int i = 0; i < 100'000; ++i) observers.add_observers();
  v1::GetDatasetRequest name;
  name.set_name(std::string(1 << 20, 'n'));
  const Held cases[] = {
      held_and_bound<v1::CullBoxesRequest>(real.SerializeAsString()),
      held_and_bound<v1::CullBoxesRequest>(empty.SerializeAsString()),
      held_and_bound<v1::LineOfSightRequest>(lines.SerializeAsString()),
      held_and_bound<v1::SessionRequest>(removes.SerializeAsString()),
      held_and_bound<v1::ViewshedRequest>(observers.SerializeAsString()),
      held_and_bound<v1::GetDatasetRequest>(name.SerializeAsString()),
  };
  for (const Held& held : cases) {
    EXPECT_GE(held.bound, held.arena);
    EXPECT_GE(held.heap_bound, held.heap);
    EXPECT_LE(held.bound, 3 * std::max(held.arena, held.heap) + (1 << 20));
  }
  // The empty boxes: 200 kB on the wire, megabytes parsed.
  EXPECT_GT(cases[1].arena, 30 * empty.ByteSizeLong());
}

// Fields a type does not know are kept as unknown fields, each an entry of a
// vector that doubles as it grows: a million 3-byte ones hold tens of
// megabytes, in the request or inside its boxes, and so do fields sent in
// another wire type than their own, and fields inside an unknown group.
TEST(ParseGuard, TheBoundCoversUnknownFields) {
  std::string top;  // field 1000, a varint, a million times
  for (int i = 0; i < 1'000'000; ++i) top += std::string("\xc0\x3e\x01", 3);
  std::string boxes;  // 10 000 boxes of 100 unknown varints each, then their x_min (a double) sent as a varint
  for (int i = 0; i < 10'000; ++i) {
    std::string box;
    for (int k = 0; k < 100; ++k) box += std::string("\xc0\x3e\x01", 3);
    for (int k = 0; k < 100; ++k) box += std::string("\x10\x01", 2);
    boxes += "\x1a";  // CullBoxesRequest.boxes, length-delimited
    boxes += static_cast<char>(0x80 | (box.size() & 0x7f));
    boxes += static_cast<char>(box.size() >> 7);
    boxes += box;
  }
  std::string group = "\xc3\x3e";  // field 1000, a group of 100 000 unknown varints
  for (int i = 0; i < 100'000; ++i) group += "\x10\x01";
  group += "\xc4\x3e";
  const std::pair<std::string, std::uint64_t> cases[] = {{top, 1'000'000}, {boxes, 2'000'000}, {group, 100'001}};
  for (const auto& [wire, unknown_fields] : cases) {
    const Held held = held_and_bound<v1::CullBoxesRequest>(wire);
    EXPECT_GT(held.heap, 5 * wire.size());
    EXPECT_GE(held.bound, held.arena);
    EXPECT_GE(held.heap_bound, held.heap);
    EXPECT_EQ(proto::parse_bound(*v1::CullBoxesRequest::descriptor(), wire).unknown_fields, unknown_fields);
  }
}

// An allowance that counts its takes and refuses none.
struct CountingAllowance final : proto::ParseAllowance {
  int takes = 0;
  bool take(std::uint64_t) override { return ++takes > 0; }
  void give(std::uint64_t) override {}
};

// Parses `wire` as a T through its gRPC serialisation, as a daemon does.
template <class T>
void parse_through_grpc(const std::string& wire, T& out) {
  grpc::Slice slice(wire);
  grpc::ByteBuffer buffer(&slice, 1);
  ASSERT_TRUE(grpc::SerializationTraits<T>::Deserialize(&buffer, &out).ok());
}

// Under an allowance, a parse drops the unknown fields it kept, at every
// depth, and keeps every known one: what admission then counts is the
// request's own fields.
TEST(ParseGuard, AGuardedParseDropsUnknownFields) {
  v1::CullBoxesRequest request;
  request.set_dataset("ecuador");
  for (int i = 0; i < 3; ++i) {
    v1::Box* b = request.add_boxes();
    b->set_x_min(i);
    b->set_id(static_cast<std::uint64_t>(i) + 7);
  }
  std::string wire = request.SerializeAsString() + std::string("\xc0\x3e\x01", 3);
  std::string box = std::string("\xc0\x3e\x05", 3) + std::string("\x40\x09", 2);  // an unknown field, then id 9
  wire += '\x1a';
  wire += static_cast<char>(box.size());
  wire += box;
  CountingAllowance allowance;
  proto::set_parse_allowance(&allowance);
  v1::CullBoxesRequest parsed;
  parse_through_grpc(wire, parsed);
  proto::remove_parse_allowance(&allowance);
  EXPECT_EQ(allowance.takes, 1);
  EXPECT_EQ(parsed.dataset(), "ecuador");
  ASSERT_EQ(parsed.boxes_size(), 4);
  EXPECT_EQ(parsed.boxes(2).x_min(), 2.0);
  EXPECT_EQ(parsed.boxes(3).id(), 9u);
  EXPECT_TRUE(parsed.GetReflection()->GetUnknownFields(parsed).empty());
  for (const v1::Box& b : parsed.boxes()) EXPECT_TRUE(b.GetReflection()->GetUnknownFields(b).empty());
  // Without an allowance (a client) they are kept, as protobuf does.
  v1::CullBoxesRequest kept;
  parse_through_grpc(wire, kept);
  EXPECT_FALSE(kept.GetReflection()->GetUnknownFields(kept).empty());
  EXPECT_FALSE(kept.boxes(3).GetReflection()->GetUnknownFields(kept.boxes(3)).empty());
}

// A proto3 string field that is not UTF-8 fails protobuf's parse. The walk
// finds it first and names it (the daemon's refusal says which field, and
// protobuf logs nothing); a long string is read in pieces, whose ends may
// split a character.
TEST(ParseGuard, AStringThatIsNotUtf8IsNamed) {
  v1::CullBoxesRequest request;
  request.add_boxes()->set_z_max(1);
  const std::string bad = request.SerializeAsString() + std::string(
                                                            "\x0a\x03"
                                                            "a\xff"
                                                            "b",
                                                            5);  // dataset: a, 0xff, b
  const proto::ParseBound bound = proto::parse_bound(*v1::CullBoxesRequest::descriptor(), bad);
  EXPECT_TRUE(bound.malformed);
  EXPECT_EQ(bound.not_utf8, "horizon.v1.CullBoxesRequest.dataset");

  std::string euros;  // 50 000 three-byte characters: 150 000 bytes, pieces of 65 536 end inside one
  for (int i = 0; i < 50'000; ++i) euros += "\xe2\x82\xac";
  request.set_dataset(euros);
  const std::string good = request.SerializeAsString();
  ASSERT_TRUE(v1::CullBoxesRequest().ParseFromString(good));
  EXPECT_FALSE(proto::parse_bound(*v1::CullBoxesRequest::descriptor(), good).malformed);
  euros[100'000] = 'x';  // a character cut after its first byte, in the second piece
  request.set_dataset(euros);
  const proto::ParseBound cut = proto::parse_bound(*v1::CullBoxesRequest::descriptor(), request.SerializeAsString());
  EXPECT_TRUE(cut.malformed);
  EXPECT_EQ(cut.not_utf8, "horizon.v1.CullBoxesRequest.dataset");

  CountingAllowance allowance;
  proto::set_parse_allowance(&allowance);
  v1::CullBoxesRequest parsed;
  parse_through_grpc(bad, parsed);
  proto::remove_parse_allowance(&allowance);
  const auto refusal = proto::refused_parse(parsed);
  ASSERT_TRUE(refusal.has_value());
  EXPECT_TRUE(refusal->malformed);
  EXPECT_NE(refusal->message.find("horizon.v1.CullBoxesRequest.dataset is not UTF-8 text"), std::string::npos)
      << refusal->message;
}

// Every method of every horizon.v1 service takes a guarded request: an RPC
// added without its request in HORIZON_GUARDED_REQUESTS fails here.
TEST(ParseGuard, EveryServiceRequestIsGuarded) {
  int methods = 0;
  for (const google::protobuf::FileDescriptor* file :
       {v1::ListDatasetsRequest::descriptor()->file(), v1::CullMeshRequest::descriptor()->file(),
        v1::SessionRequest::descriptor()->file(), v1::TraceRequest::descriptor()->file(),
        v1::CullBoxesRequest::descriptor()->file()})
    for (int s = 0; s < file->service_count(); ++s)
      for (int m = 0; m < file->service(s)->method_count(); ++m, ++methods)
        EXPECT_TRUE(proto::is_guarded(*file->service(s)->method(m)->input_type()))
            << file->service(s)->method(m)->full_name();
  EXPECT_EQ(methods, 11);
  EXPECT_FALSE(proto::is_guarded(*v1::CullBoxesResponse::descriptor()));
}

// Parses a GetDatasetRequest through its gRPC serialisation, as a daemon does.
void parse_a_name_through_grpc() {
  v1::GetDatasetRequest in;
  in.set_name("rainier");
  grpc::ByteBuffer buffer;
  bool own = false;
  ASSERT_TRUE(grpc::SerializationTraits<v1::GetDatasetRequest>::Serialize(in, &buffer, &own).ok());
  v1::GetDatasetRequest out;
  ASSERT_TRUE(grpc::SerializationTraits<v1::GetDatasetRequest>::Deserialize(&buffer, &out).ok());
  EXPECT_EQ(out.name(), "rainier");
}

// A daemon that stops removes its own allowance, never one installed since.
TEST(ParseGuard, ADaemonRemovesOnlyItsOwnAllowance) {
  CountingAllowance first, second;
  proto::set_parse_allowance(&first);
  proto::set_parse_allowance(&second);
  proto::remove_parse_allowance(&first);  // not the one installed: nothing changes
  parse_a_name_through_grpc();
  EXPECT_EQ(first.takes, 0);
  EXPECT_EQ(second.takes, 1);
  proto::remove_parse_allowance(&second);
  parse_a_name_through_grpc();
  EXPECT_EQ(second.takes, 1);
}

// A wire the walk cannot read is malformed, counted as far as it goes; under
// an allowance such a request is refused unparsed, its message empty but
// for the refusal. An unknown group that is never closed is one.
TEST(ParseGuard, AWireTheWalkCannotReadIsRefusedUnparsed) {
  v1::CullBoxesRequest request;
  for (int i = 0; i < 1000; ++i) request.add_boxes()->set_z_max(i);
  std::string cut = request.SerializeAsString();
  cut.resize(cut.size() / 2);
  cut += "\xff\xff\xff";  // a tag whose varint never ends
  const proto::ParseBound bound = proto::parse_bound(*v1::CullBoxesRequest::descriptor(), cut);
  EXPECT_TRUE(bound.malformed);
  EXPECT_GT(bound.messages, 400u);
  EXPECT_LT(bound.messages, 600u);
  // A box whose length is 2^32 - 1 (no int holds it): the walk stops there.
  const std::string huge = request.SerializeAsString() + std::string("\x1a\xff\xff\xff\xff\x0f", 6);
  const proto::ParseBound at_huge = proto::parse_bound(*v1::CullBoxesRequest::descriptor(), huge);
  EXPECT_TRUE(at_huge.malformed);
  EXPECT_EQ(at_huge.messages, 1001u);
  const std::string open_group = request.SerializeAsString() + "\xc3\x3e\x10\x01";
  EXPECT_TRUE(proto::parse_bound(*v1::CullBoxesRequest::descriptor(), open_group).malformed);
  EXPECT_FALSE(proto::parse_bound(*v1::CullBoxesRequest::descriptor(), request.SerializeAsString()).malformed);

  CountingAllowance allowance;
  proto::set_parse_allowance(&allowance);
  for (const std::string& wire : {cut, huge, open_group}) {
    v1::CullBoxesRequest parsed;
    parse_through_grpc(wire, parsed);
    EXPECT_EQ(parsed.boxes_size(), 0);
    const auto refusal = proto::refused_parse(parsed);
    ASSERT_TRUE(refusal.has_value());
    EXPECT_TRUE(refusal->malformed);
    EXPECT_NE(refusal->message.find("bytes are not a valid horizon.v1.CullBoxesRequest"), std::string::npos);
  }
  proto::remove_parse_allowance(&allowance);
  EXPECT_EQ(allowance.takes, 0);
}

}  // namespace
}  // namespace horizon::server
