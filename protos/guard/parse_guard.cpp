#include "parse_guard.hpp"

#include <atomic>
#include <unordered_map>

#include <google/protobuf/descriptor.h>
#include <google/protobuf/io/coded_stream.h>
#include <google/protobuf/io/zero_copy_stream_impl_lite.h>
#include <google/protobuf/message.h>
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
// A repeated field's array per element, in elements: it doubles as it grows
// (up to twice the elements), and on an arena the arrays it outgrew stay.
constexpr std::uint64_t kGrowth = 4;

// What the scan needs of a message type, looked up once per thread.
struct TypeFacts {
  std::uint64_t bytes = 0;  // its object, as an arena allocates it (in steps of 8 bytes)
  // No message or repeated field: its parse allocates nothing past its
  // object but its strings and unknown fields (the wire's bytes), so the
  // scan skips its bytes without reading its fields (a box of a CullBoxes
  // call: 100 000 of them scan in a fraction of their parse's time).
  bool flat = true;
};

const TypeFacts& facts_of(const Descriptor& type) {
  thread_local std::unordered_map<const Descriptor*, TypeFacts> known;
  auto [it, added] = known.try_emplace(&type);
  if (added) {
    const google::protobuf::Message* prototype =
        google::protobuf::MessageFactory::generated_factory()->GetPrototype(&type);
    it->second.bytes = prototype ? (prototype->SpaceUsedLong() + 7) / 8 * 8 : 256;
    for (int i = 0; i < type.field_count(); ++i)
      if (type.field(i)->is_repeated() || type.field(i)->cpp_type() == FieldDescriptor::CPPTYPE_MESSAGE)
        it->second.flat = false;
  }
  return it->second;
}

// A repeated scalar's element in memory.
std::uint64_t element_bytes(const FieldDescriptor& f) {
  switch (f.cpp_type()) {
    case FieldDescriptor::CPPTYPE_BOOL:
      return 1;
    case FieldDescriptor::CPPTYPE_INT32:
    case FieldDescriptor::CPPTYPE_UINT32:
    case FieldDescriptor::CPPTYPE_FLOAT:
    case FieldDescriptor::CPPTYPE_ENUM:
      return 4;
    case FieldDescriptor::CPPTYPE_STRING:
      return sizeof(std::string) + sizeof(void*);  // the string and its slot; its bytes are the wire's
    default:
      return 8;
  }
}

// Bounds the fields of one `type` message read from `in` up to its limit;
// false on a wire fault (what was read so far stays counted).
bool scan(const Descriptor& type, CodedInputStream& in, ParseBound& bound, int depth) {
  if (depth > kMaxDepth) return false;
  while (true) {
    const std::uint32_t tag = in.ReadTag();
    if (tag == 0) return true;  // the end (of the stream, or of this message's limit)
    const FieldDescriptor* f = type.FindFieldByNumber(static_cast<int>(WireFormatLite::GetTagFieldNumber(tag)));
    const auto wire_type = WireFormatLite::GetTagWireType(tag);
    if (f && f->cpp_type() == FieldDescriptor::CPPTYPE_MESSAGE &&
        wire_type == WireFormatLite::WIRETYPE_LENGTH_DELIMITED) {
      std::uint32_t length = 0;
      if (!in.ReadVarint32(&length) || length > kMaxLength) return false;
      // Its object, and for a repeated field its pointers (kGrowth).
      const TypeFacts& facts = facts_of(*f->message_type());
      bound.bytes += facts.bytes + (f->is_repeated() ? kGrowth * sizeof(void*) : 0);
      ++bound.messages;
      if (facts.flat) {
        if (!in.Skip(static_cast<int>(length))) return false;
        continue;
      }
      const CodedInputStream::Limit limit = in.PushLimit(static_cast<int>(length));
      if (!scan(*f->message_type(), in, bound, depth + 1)) return false;
      if (in.BytesUntilLimit() != 0) return false;
      in.PopLimit(limit);
      continue;
    }
    if (f && f->is_repeated() && wire_type == WireFormatLite::WIRETYPE_LENGTH_DELIMITED && f->is_packable()) {
      // Packed: count the elements (fixed-size ones by length, varints by their last bytes).
      std::uint32_t length = 0;
      if (!in.ReadVarint32(&length) || length > kMaxLength) return false;
      const CodedInputStream::Limit limit = in.PushLimit(static_cast<int>(length));
      std::uint64_t count = 0;
      const int fixed = f->type() == FieldDescriptor::TYPE_DOUBLE || f->type() == FieldDescriptor::TYPE_FIXED64 ||
                                f->type() == FieldDescriptor::TYPE_SFIXED64
                            ? 8
                        : f->type() == FieldDescriptor::TYPE_FLOAT || f->type() == FieldDescriptor::TYPE_FIXED32 ||
                                f->type() == FieldDescriptor::TYPE_SFIXED32
                            ? 4
                            : 0;
      if (fixed > 0) {
        count = length / static_cast<std::uint32_t>(fixed);
        if (!in.Skip(static_cast<int>(length))) return false;
      } else {
        std::uint64_t value = 0;
        while (in.BytesUntilLimit() > 0) {
          if (!in.ReadVarint64(&value)) return false;
          ++count;
        }
      }
      in.PopLimit(limit);
      bound.bytes += kGrowth * count * element_bytes(*f);
      continue;
    }
    if (f && f->is_repeated()) bound.bytes += kGrowth * element_bytes(*f);  // one element, unpacked
    // Singular scalars are inside their message's object; strings and unknown fields are their wire bytes.
    if (!WireFormatLite::SkipField(&in, tag)) return false;
  }
}

ParseBound bound_of(const Descriptor& type, CodedInputStream& in, std::uint64_t wire_bytes) {
  ParseBound bound;
  bound.bytes = facts_of(type).bytes;
  bound.messages = 1;
  scan(type, in, bound, 0);
  // Strings, bytes and unknown fields hold at most their wire bytes; and an
  // arena's last block, partly used.
  bound.bytes += wire_bytes + (64 << 10);
  return bound;
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
    bound = bound_of(*T::descriptor(), in, wire_bytes);
  }
  // What a refused request holds instead of its fields.
  const auto refuse = [&](int field, const std::string& why) {
    auto* message = static_cast<T*>(msg);
    message->Clear();
    message->GetReflection()->MutableUnknownFields(message)->AddLengthDelimited(field, why);
    buffer->Clear();
    return grpc::Status::OK;
  };
  if (!allowance->take(bound.bytes)) {
    const std::uint64_t mib = (bound.bytes + (1 << 20) - 1) >> 20;
    return refuse(kRefusalField, "this request's " + std::to_string(bound.messages) + " messages would take about " +
                                     std::to_string(mib) +
                                     " MiB to read, more than memory_budget_mb leaves free now; retry later or "
                                     "split the request");
  }
  const grpc::Status status = grpc::GenericDeserialize<grpc::ProtoBufferReader, T>(buffer, msg);
  allowance->give(bound.bytes);
  if (status.ok()) return status;
  return refuse(kMalformedField, "the request's " + std::to_string(wire_bytes) + " bytes are not a valid " +
                                     T::descriptor()->full_name() + " (cut short, or not its protobuf encoding)");
}

}  // namespace

void set_parse_allowance(ParseAllowance* allowance) {
  g_allowance.store(allowance, std::memory_order_release);
}

void remove_parse_allowance(ParseAllowance* allowance) {
  g_allowance.compare_exchange_strong(allowance, nullptr, std::memory_order_acq_rel);
}

ParseBound parse_bound(const Descriptor& type, google::protobuf::io::ZeroCopyInputStream& wire,
                       std::uint64_t wire_bytes) {
  CodedInputStream in(&wire);
  return bound_of(type, in, wire_bytes);
}

ParseBound parse_bound(const Descriptor& type, const std::string& wire) {
  google::protobuf::io::ArrayInputStream stream(wire.data(), static_cast<int>(wire.size()));
  return parse_bound(type, stream, wire.size());
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
