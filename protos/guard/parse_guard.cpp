#include "parse_guard.hpp"

#include <algorithm>
#include <atomic>
#include <bit>
#include <unordered_map>
#include <vector>

#include <google/protobuf/descriptor.h>
#include <google/protobuf/io/coded_stream.h>
#include <google/protobuf/io/zero_copy_stream_impl_lite.h>
#include <google/protobuf/message.h>
#include <google/protobuf/stubs/common.h>
#include <google/protobuf/unknown_field_set.h>
#include <google/protobuf/wire_format_lite.h>
#include <grpcpp/impl/codegen/proto_utils.h>
#include <grpcpp/support/byte_buffer.h>
#include <grpcpp/support/status.h>

#include "horizon/v1/datasets.pb.h"
#include "horizon/v1/mesh.pb.h"
#include "horizon/v1/session.pb.h"
#include "horizon/v1/trace.pb.h"
#include "horizon/v1/visibility.pb.h"

namespace horizon::proto {
namespace {

using google::protobuf::Descriptor;
using google::protobuf::FieldDescriptor;
using google::protobuf::internal::WireFormatLite;
using google::protobuf::io::CodedInputStream;

std::atomic<ParseAllowance*> g_allowance{nullptr};

// The unknown fields a refused parse leaves: the largest field numbers protobuf allows.
constexpr int kRefusalField = (1 << 29) - 1, kMalformedField = kRefusalField - 1;
// protobuf's own nesting limit, and the longest length an int holds (a
// longer one cannot be in a message gRPC took).
constexpr int kMaxDepth = 100;
constexpr std::uint32_t kMaxLength = 0x7fffffff;
// What glibc's malloc adds to an allocation of a multiple of 8 bytes (its
// size word, the rounding to 16, the 32-byte least chunk).
constexpr std::uint64_t kMallocOverhead = 24;
// What a heap parse's allocator may hold besides: ThreadSanitizer's runtime
// counted 8 KiB more than glibc's for a parse of one 1 MiB string.
constexpr std::uint64_t kHeapSlack = 16 << 10;
// A std::string as a field holds it: the object (on the arena, or a heap
// allocation) and, past its 15 inline characters, a heap buffer of its
// bytes and their NUL (counted with the bytes).
constexpr std::uint64_t kStringBytes = sizeof(std::string) + 2 * kMallocOverhead;
// An unknown field (a field number the type lacks, or a known one sent in
// another wire type): a 16-byte entry of its set's vector, which doubles as
// it grows and holds old and new while it does (three entries an entry at
// worst); a length-delimited one adds a std::string, a group a set of its own.
constexpr std::uint64_t kUnknownBytes = 3 * 16;
constexpr std::uint64_t kUnknownGroupBytes = 64 + kMallocOverhead;
// A message's unknown fields, once it has any: the container that holds its set.
constexpr std::uint64_t kUnknownSetBytes = 64 + kMallocOverhead;

// What the scan needs of a message type, looked up once per thread.
struct TypeFacts {
  std::uint64_t bytes = 0;  // its object, as an arena allocates it (in steps of 8 bytes)
  // No message, repeated or string field: its parse allocates nothing past
  // its object but its unknown fields, so the scan reads only its tags (the
  // boxes of a 100 000-box CullBoxes call: ~3 ms, a tenth of their parse).
  bool flat = true;
  bool has_messages = false;  // a message field, the only place unknown fields can nest
  // The largest field number it knows, and the wire type each field is sent
  // in when not packed: a field is unknown unless it matches.
  std::vector<std::int8_t> wire_types;  // by field number; -1: none
};

const TypeFacts& facts_of(const Descriptor& type) {
  thread_local std::unordered_map<const Descriptor*, TypeFacts> known;
  auto [it, added] = known.try_emplace(&type);
  if (added) {
    TypeFacts& facts = it->second;
    const google::protobuf::Message* prototype =
        google::protobuf::MessageFactory::generated_factory()->GetPrototype(&type);
    facts.bytes = prototype ? (prototype->SpaceUsedLong() + 7) / 8 * 8 : 256;
    int largest = 0;
    for (int i = 0; i < type.field_count(); ++i) {
      const FieldDescriptor& f = *type.field(i);
      largest = std::max(largest, f.number());
      if (f.is_repeated() || f.cpp_type() == FieldDescriptor::CPPTYPE_MESSAGE ||
          f.cpp_type() == FieldDescriptor::CPPTYPE_STRING)
        facts.flat = false;
      if (f.cpp_type() == FieldDescriptor::CPPTYPE_MESSAGE) facts.has_messages = true;
    }
    facts.wire_types.assign(static_cast<std::size_t>(largest) + 1, -1);
    for (int i = 0; i < type.field_count(); ++i) {
      const FieldDescriptor& f = *type.field(i);
      facts.wire_types[static_cast<std::size_t>(f.number())] = static_cast<std::int8_t>(
          WireFormatLite::WireTypeForFieldType(static_cast<WireFormatLite::FieldType>(f.type())));
    }
  }
  return it->second;
}

// A repeated field's element in its array.
std::uint64_t element_bytes(const FieldDescriptor& f) {
  if (f.cpp_type() == FieldDescriptor::CPPTYPE_MESSAGE || f.cpp_type() == FieldDescriptor::CPPTYPE_STRING)
    return sizeof(void*);
  switch (f.cpp_type()) {
    case FieldDescriptor::CPPTYPE_BOOL:
      return 1;
    case FieldDescriptor::CPPTYPE_INT32:
    case FieldDescriptor::CPPTYPE_UINT32:
    case FieldDescriptor::CPPTYPE_FLOAT:
    case FieldDescriptor::CPPTYPE_ENUM:
      return 4;
    default:
      return 8;
  }
}

// What a walk has counted so far.
struct Tally {
  std::uint64_t used = 0;         // allocated bytes: objects, arrays, strings, unknown fields
  std::uint64_t allocations = 0;  // of those, the ones that are a heap allocation each when not on an arena
  std::uint64_t array_waste = 0;  // on an arena: blocks left part-used when an array did not fit
  std::uint64_t largest_object = 0;
  std::uint64_t messages = 0;
  std::uint64_t unknown_fields = 0;
  const FieldDescriptor* not_utf8 = nullptr;  // a string field whose bytes are not UTF-8
};

// One repeated field's `count` elements of `element` bytes in one message.
// Its array is an 8-byte header and the elements. Each time it grows it at
// least doubles (RepeatedField from 16 bytes, RepeatedPtrField from four
// pointers, either straight to what a packed run needs when that is more),
// so its last is at most twice what it needs, and the arrays it outgrew,
// which stay on an arena, add up to less than the last but for their
// headers. An array that does not fit its arena's block starts a new one,
// leaving at most the smaller of itself and a block unused.
void count_array(std::uint64_t count, std::uint64_t element, Tally& tally) {
  if (count == 0) return;
  const std::uint64_t last = 2 * ((8 + count * element + 7) / 8 * 8);
  tally.used += 2 * last + 8 * static_cast<std::uint64_t>(std::bit_width(count) + 1);
  tally.allocations += 1;
  for (std::uint64_t array = last; array >= 16; array /= 2) tally.array_waste += std::min(array, kArenaBlockBytes);
}

// Repeated fields' element counts of the messages being walked, a frame a
// message (one thread's walk at a time).
thread_local std::vector<std::uint64_t> t_counts;

// Reads the next `length` bytes of `in` and says whether they are UTF-8 as
// protobuf's parse checks a proto3 string; false on a wire fault. Read in
// pieces of 64 KiB, so that a long string is never copied whole: a piece
// holds back an unfinished character for the next.
bool read_utf8(CodedInputStream& in, std::uint32_t length, bool& valid) {
  thread_local std::string piece;
  std::size_t carried = 0;
  valid = true;
  do {
    const std::uint32_t step = std::min<std::uint32_t>(length, 64 << 10);
    piece.resize(carried + step);
    if (step > 0 && !in.ReadRaw(piece.data() + carried, static_cast<int>(step))) return false;
    length -= step;
    std::size_t end = piece.size();
    if (length > 0) {
      std::size_t tail = 0;  // continuation bytes at the end, then their lead byte
      while (tail < 3 && tail < end && (static_cast<unsigned char>(piece[end - 1 - tail]) & 0xC0) == 0x80) ++tail;
      if (tail < end && static_cast<unsigned char>(piece[end - 1 - tail]) >= 0xC0) end -= tail + 1;
    }
    if (!google::protobuf::internal::IsStructurallyValidUTF8(piece.data(), static_cast<int>(end))) valid = false;
    carried = piece.size() - end;
    piece.erase(0, end);
  } while (length > 0 && valid);
  return true;
}

// Counts a string's (or bytes', or a length-delimited unknown field's)
// objects and bytes, its tag read; false on a wire fault, or when `text`
// (a proto3 string field) is not UTF-8, which fails protobuf's parse: it is
// named in the tally.
bool skip_string(CodedInputStream& in, Tally& tally, const FieldDescriptor* text = nullptr) {
  std::uint32_t length = 0;
  if (!in.ReadVarint32(&length) || length > kMaxLength) return false;
  tally.used += kStringBytes + (length + 15) / 8 * 8;
  if (!text) return in.Skip(static_cast<int>(length));
  bool valid = true;
  if (!read_utf8(in, length, valid)) return false;
  if (!valid && !tally.not_utf8) tally.not_utf8 = text;
  return valid;
}

// Counts one unknown field whose tag was read; false on a wire fault.
bool skip_unknown(CodedInputStream& in, std::uint32_t tag, Tally& tally, int depth) {
  tally.used += kUnknownBytes;
  ++tally.unknown_fields;
  switch (WireFormatLite::GetTagWireType(tag)) {
    case WireFormatLite::WIRETYPE_LENGTH_DELIMITED:
      return skip_string(in, tally);
    case WireFormatLite::WIRETYPE_START_GROUP: {
      // Its fields are a set of their own, each counted.
      if (depth > kMaxDepth) return false;
      tally.used += kUnknownGroupBytes;
      while (true) {
        const std::uint32_t inner = in.ReadTag();
        if (inner == 0) return false;
        if (WireFormatLite::GetTagWireType(inner) == WireFormatLite::WIRETYPE_END_GROUP)
          return WireFormatLite::GetTagFieldNumber(inner) == WireFormatLite::GetTagFieldNumber(tag);
        if (!skip_unknown(in, inner, tally, depth + 1)) return false;
      }
    }
    case WireFormatLite::WIRETYPE_END_GROUP:
      return false;  // a group that never started
    default:
      return WireFormatLite::SkipField(&in, tag);
  }
}

// Reads a flat message's fields up to its limit: its known fields are
// scalars inside its object, so only unknown ones count. False on a wire fault.
bool scan_flat(const TypeFacts& facts, CodedInputStream& in, Tally& tally, int depth) {
  bool has_unknown = false;
  while (true) {
    const std::uint32_t tag = in.ReadTag();
    if (tag == 0) return true;
    const std::uint32_t number = WireFormatLite::GetTagFieldNumber(tag);
    const auto wire_type = static_cast<std::int8_t>(WireFormatLite::GetTagWireType(tag));
    if (number < facts.wire_types.size() && facts.wire_types[number] == wire_type) {
      std::uint64_t value = 0;
      std::uint32_t fixed32 = 0;
      const bool ok = wire_type == WireFormatLite::WIRETYPE_FIXED64   ? in.ReadLittleEndian64(&value)
                      : wire_type == WireFormatLite::WIRETYPE_FIXED32 ? in.ReadLittleEndian32(&fixed32)
                                                                      : in.ReadVarint64(&value);
      if (!ok) return false;
      continue;
    }
    if (!has_unknown) tally.used += kUnknownSetBytes;
    has_unknown = true;
    if (!skip_unknown(in, tag, tally, depth)) return false;
  }
}

// Bounds one `type` message read from `in` up to its limit, its object
// included; false on a wire fault (what was read so far stays counted).
bool scan(const Descriptor& type, CodedInputStream& in, Tally& tally, int depth) {
  if (depth > kMaxDepth) return false;
  const TypeFacts& facts = facts_of(type);
  tally.used += facts.bytes;
  tally.allocations += 1;
  tally.largest_object = std::max(tally.largest_object, facts.bytes);
  ++tally.messages;
  if (facts.flat) return scan_flat(facts, in, tally, depth);
  // This message's repeated fields' counts; its arrays are counted at its end.
  const std::size_t frame = t_counts.size();
  t_counts.resize(frame + static_cast<std::size_t>(type.field_count()), 0);
  bool ok = true, has_unknown = false;
  while (ok) {
    const std::uint32_t tag = in.ReadTag();
    if (tag == 0) break;  // the end (of the stream, or of this message's limit)
    const std::uint32_t number = WireFormatLite::GetTagFieldNumber(tag);
    const auto wire_type = static_cast<std::int8_t>(WireFormatLite::GetTagWireType(tag));
    const FieldDescriptor* f = number < facts.wire_types.size() && facts.wire_types[number] >= 0
                                   ? type.FindFieldByNumber(static_cast<int>(number))
                                   : nullptr;
    const bool packed =
        f && f->is_repeated() && f->is_packable() && wire_type == WireFormatLite::WIRETYPE_LENGTH_DELIMITED;
    if (!f || (wire_type != facts.wire_types[number] && !packed)) {
      if (!has_unknown) tally.used += kUnknownSetBytes;
      has_unknown = true;
      ok = skip_unknown(in, tag, tally, depth);
      continue;
    }
    const std::size_t slot = frame + static_cast<std::size_t>(f->index());
    if (f->cpp_type() == FieldDescriptor::CPPTYPE_MESSAGE) {
      std::uint32_t length = 0;
      if (!in.ReadVarint32(&length) || length > kMaxLength) {
        ok = false;
        break;
      }
      if (f->is_repeated()) ++t_counts[slot];
      const CodedInputStream::Limit limit = in.PushLimit(static_cast<int>(length));
      ok = scan(*f->message_type(), in, tally, depth + 1) && in.ConsumedEntireMessage() && in.BytesUntilLimit() == 0;
      in.PopLimit(limit);
      continue;
    }
    if (packed) {
      // Count the elements (fixed-size ones by length, varints by their last bytes).
      std::uint32_t length = 0;
      if (!in.ReadVarint32(&length) || length > kMaxLength) {
        ok = false;
        break;
      }
      const std::int8_t element_wire = facts.wire_types[number];
      if (element_wire == WireFormatLite::WIRETYPE_FIXED64 || element_wire == WireFormatLite::WIRETYPE_FIXED32) {
        t_counts[slot] += length / (element_wire == WireFormatLite::WIRETYPE_FIXED64 ? 8u : 4u);
        ok = in.Skip(static_cast<int>(length));
        continue;
      }
      const CodedInputStream::Limit limit = in.PushLimit(static_cast<int>(length));
      std::uint64_t value = 0;
      while (ok && in.BytesUntilLimit() > 0) {
        ok = in.ReadVarint64(&value);
        ++t_counts[slot];
      }
      in.PopLimit(limit);
      continue;
    }
    if (f->is_repeated()) ++t_counts[slot];
    // Singular scalars are inside their message's object.
    if (f->cpp_type() == FieldDescriptor::CPPTYPE_STRING)
      ok = skip_string(in, tally, f->type() == FieldDescriptor::TYPE_STRING ? f : nullptr);
    else
      ok = WireFormatLite::SkipField(&in, tag);
  }
  for (int i = 0; i < type.field_count(); ++i)
    count_array(t_counts[frame + static_cast<std::size_t>(i)], element_bytes(*type.field(i)), tally);
  t_counts.resize(frame);
  return ok;
}

// The larger of what parsing allocates on the heap (each object, string and
// final array its own allocation, the outgrown arrays freed) and on an arena
// (everything but strings' buffers and unknown fields in its blocks: the
// arrays' waste, each object's at most once a block, and the last block's
// unused tail, which is at most twice what came before it while blocks
// still grow).
ParseBound bound_of(const Descriptor& type, CodedInputStream& in) {
  Tally tally;
  const bool read = scan(type, in, tally, 0) && in.ConsumedEntireMessage();
  const std::uint64_t heap = tally.used + kMallocOverhead * tally.allocations + kHeapSlack;
  const std::uint64_t blocks = 10 + tally.used / (kArenaBlockBytes / 2);  // 4 KiB, 8 KiB, ..., then full blocks
  const std::uint64_t tail = std::min(kArenaBlockBytes, std::max<std::uint64_t>(8 << 10, 2 * tally.used));
  const std::uint64_t arena = tally.used + tally.array_waste + blocks * tally.largest_object + tail;
  ParseBound bound{std::max(heap, arena), heap, tally.messages, tally.unknown_fields, !read};
  if (tally.not_utf8) bound.not_utf8 = tally.not_utf8->full_name();
  return bound;
}

// Frees `message`'s unknown fields and its messages', which the daemon never
// reads: what admission then counts (arena_allocator.hpp's held_bytes) is
// what the request holds. A set swapped out frees its vector; Clear would
// keep it.
void drop_unknown_fields(google::protobuf::Message& message) {
  const google::protobuf::Reflection& reflection = *message.GetReflection();
  google::protobuf::UnknownFieldSet none;
  reflection.MutableUnknownFields(&message)->Swap(&none);
  if (!facts_of(*message.GetDescriptor()).has_messages) return;
  std::vector<const FieldDescriptor*> fields;
  reflection.ListFields(message, &fields);
  for (const FieldDescriptor* f : fields) {
    if (f->cpp_type() != FieldDescriptor::CPPTYPE_MESSAGE) continue;
    if (!f->is_repeated()) {
      drop_unknown_fields(*reflection.MutableMessage(&message, f));
      continue;
    }
    for (int i = 0, n = reflection.FieldSize(message, f); i < n; ++i)
      drop_unknown_fields(*reflection.MutableRepeatedMessage(&message, f, i));
  }
}

template <class T>
grpc::Status guarded_parse(grpc::ByteBuffer* buffer, google::protobuf::MessageLite* msg) {
  ParseAllowance* allowance = g_allowance.load(std::memory_order_acquire);
  if (!allowance || !buffer) return grpc::GenericDeserialize<grpc::ProtoBufferReader, T>(buffer, msg);
  const std::uint64_t wire_bytes = buffer->Length();
  ParseBound bound;
  {
    grpc::ProtoBufferReader reader(buffer);
    if (!reader.status().ok()) return reader.status();
    CodedInputStream in(&reader);
    bound = bound_of(*T::descriptor(), in);
  }
  // What a refused request holds instead of its fields.
  const auto refuse = [&](int field, const std::string& why) {
    auto* message = static_cast<T*>(msg);
    message->Clear();
    message->GetReflection()->MutableUnknownFields(message)->AddLengthDelimited(field, why);
    buffer->Clear();
    return grpc::Status::OK;
  };
  const std::string malformed =
      bound.not_utf8.empty() ? "the request's " + std::to_string(wire_bytes) + " bytes are not a valid " +
                                   T::descriptor()->full_name() + " (cut short, or not its protobuf encoding)"
                             : "the request's " + bound.not_utf8 + " is not UTF-8 text (every string field must be)";
  if (bound.malformed) return refuse(kMalformedField, malformed);
  if (!allowance->take(bound.bytes)) {
    const std::uint64_t mib = (bound.bytes + (1 << 20) - 1) >> 20;
    return refuse(kRefusalField, "this request's " + std::to_string(bound.messages) + " messages would take about " +
                                     std::to_string(mib) +
                                     " MiB to read, more than memory_budget_mb leaves free now; retry later or "
                                     "split the request");
  }
  const grpc::Status status = grpc::GenericDeserialize<grpc::ProtoBufferReader, T>(buffer, msg);
  if (status.ok() && bound.unknown_fields > 0) drop_unknown_fields(*static_cast<T*>(msg));
  allowance->give(bound.bytes);
  if (status.ok()) return status;
  return refuse(kMalformedField, malformed);
}

}  // namespace

void set_parse_allowance(ParseAllowance* allowance) {
  g_allowance.store(allowance, std::memory_order_release);
}

void remove_parse_allowance(ParseAllowance* allowance) {
  g_allowance.compare_exchange_strong(allowance, nullptr, std::memory_order_acq_rel);
}

ParseBound parse_bound(const Descriptor& type, const std::string& wire) {
  google::protobuf::io::ArrayInputStream stream(wire.data(), static_cast<int>(wire.size()));
  CodedInputStream in(&stream);
  return bound_of(type, in);
}

std::optional<ParseRefusal> refused_parse(const google::protobuf::Message& request) {
  const google::protobuf::UnknownFieldSet& unknown = request.GetReflection()->GetUnknownFields(request);
  for (int i = 0; i < unknown.field_count(); ++i) {
    const google::protobuf::UnknownField& f = unknown.field(i);
    if ((f.number() == kRefusalField || f.number() == kMalformedField) &&
        f.type() == google::protobuf::UnknownField::TYPE_LENGTH_DELIMITED)
      return ParseRefusal{f.number() == kMalformedField, f.length_delimited()};
  }
  return std::nullopt;
}

bool is_guarded(const Descriptor& type) {
#define HORIZON_IS_REQUEST(T) &type == horizon::v1::T::descriptor() ||
  return HORIZON_GUARDED_REQUESTS(HORIZON_IS_REQUEST) false;
#undef HORIZON_IS_REQUEST
}

}  // namespace horizon::proto

#define HORIZON_GUARDED_REQUEST(T)                                                                                  \
  grpc::Status grpc::SerializationTraits<horizon::v1::T, void>::Serialize(const google::protobuf::MessageLite& msg, \
                                                                          grpc::ByteBuffer* bb, bool* own_buffer) { \
    return grpc::GenericSerialize<grpc::ProtoBufferWriter, horizon::v1::T>(msg, bb, own_buffer);                    \
  }                                                                                                                 \
  grpc::Status grpc::SerializationTraits<horizon::v1::T, void>::Deserialize(grpc::ByteBuffer* buffer,               \
                                                                            google::protobuf::MessageLite* msg) {   \
    return horizon::proto::guarded_parse<horizon::v1::T>(buffer, msg);                                              \
  }
HORIZON_GUARDED_REQUESTS(HORIZON_GUARDED_REQUEST)
#undef HORIZON_GUARDED_REQUEST
