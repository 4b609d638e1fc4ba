// The budget's per-message figures (memory_budget.hpp) against the messages
// themselves: a call reserves what its messages will really hold. And when
// the heap trimmer (allocator.hpp) gives freed memory back.
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <cstdint>
#include <string>
#include <thread>
#include <utility>

#include <google/protobuf/arena.h>
#include <grpcpp/support/byte_buffer.h>

#include "allocator.hpp"
#include "arena_allocator.hpp"
#include "horizon/v1/datasets.pb.h"
#include "horizon/v1/mesh.pb.h"
#include "horizon/v1/session.pb.h"
#include "horizon/v1/trace.pb.h"
#include "horizon/v1/visibility.pb.h"
#include "memory_budget.hpp"

namespace horizon::server {
namespace {

// A CullBoxes answer of n boxes on the call's arena, every field set.
std::uint64_t answer_bytes(int n) {
  ArenaAllocator<v1::CullBoxesRequest, v1::CullBoxesResponse> allocator;
  auto* holder = allocator.AllocateMessages();
  const std::uint64_t before = held_bytes(*holder->response());
  v1::CullBoxesResponse& response = *holder->response();
  response.mutable_boxes()->Reserve(n);  // as cull_call does
  for (int i = 0; i < n; ++i) {
    v1::BoxVisibility* b = response.add_boxes();
    b->set_visible(i % 2 == 0);
    b->set_ohf_min(1234.5 + i);
    b->set_state(v1::BOX_STATE_UNDETERMINED);
  }
  const std::uint64_t after = held_bytes(response);
  holder->Release();
  return after - before;
}

TEST(ServerBudget, ACullAnswerHoldsNoMoreThanItsReservation) {
  for (int n : {1'000, 10'000, 100'000}) {
    const std::uint64_t bytes = answer_bytes(n);
    EXPECT_LE(bytes, static_cast<std::uint64_t>(n) * MemoryBudget::kResponseBytesPerBox) << n << " boxes";
    // And the figure is not wildly above it: the reservation refuses calls it need not.
    EXPECT_GE(bytes * 2, static_cast<std::uint64_t>(n) * MemoryBudget::kResponseBytesPerBox) << n << " boxes";
  }
}

TEST(ServerBudget, AReceivedRequestIsCountedAtLeastAsItsWireSize) {
  ArenaAllocator<v1::CullBoxesRequest, v1::CullBoxesResponse> allocator;
  auto* holder = allocator.AllocateMessages();
  v1::CullBoxesRequest& request = *holder->request();
  request.set_dataset("ecuador");
  for (int i = 0; i < 50'000; ++i) {
    v1::Box* b = request.add_boxes();
    b->set_x_min(700000.0 + i);
    b->set_x_max(700010.0 + i);
    b->set_y_min(9500000.0 + i);
    b->set_y_max(9500010.0 + i);
    b->set_z_min(2000);
    b->set_z_max(2100);
  }
  EXPECT_GE(held_bytes(request), request.ByteSizeLong());
  // A message off any arena is counted by its own footprint.
  v1::CullBoxesRequest copy = request;
  EXPECT_GE(held_bytes(copy), copy.ByteSizeLong());
  holder->Release();
}

// A call that reserves in steps (CallScope::reserve) holds one reservation:
// absorbing another adds its bytes, and releasing gives both back.
TEST(ServerBudget, AReservationAbsorbsAnotherOfTheSameBudget) {
  MemoryBudget budget(MemoryBudget::kBaseBytes + 100);
  Reservation first, second, empty;
  ASSERT_TRUE(budget.try_reserve(40, first));
  ASSERT_TRUE(budget.try_reserve(50, second));
  EXPECT_FALSE(budget.try_reserve(11, empty));  // 90 of 100 held
  first.absorb(std::move(second));
  EXPECT_EQ(first.bytes(), 90u);
  EXPECT_EQ(second.bytes(), 0u);  // NOLINT(bugprone-use-after-move): absorb leaves it empty
  EXPECT_EQ(budget.reserved(), 90u);
  second.release();  // empty: gives nothing back
  EXPECT_EQ(budget.reserved(), 90u);
  Reservation taker;  // an empty one takes the other over whole
  taker.absorb(std::move(first));
  EXPECT_EQ(taker.bytes(), 90u);
  taker.release();
  EXPECT_EQ(budget.reserved(), 0u);
  EXPECT_TRUE(budget.try_reserve(100, empty));
}

// A worker keeping a call's buffers takes their bytes out of the call's
// reservation (WorkspaceLease): the budget's total does not move, and each
// part gives back its own share.
TEST(ServerBudget, AReservationSplitsInTwoThatGiveBackTheirOwnShares) {
  MemoryBudget budget(MemoryBudget::kBaseBytes + 100);
  Reservation call;
  ASSERT_TRUE(budget.try_reserve(70, call));
  Reservation kept = call.split(30);
  EXPECT_EQ(call.bytes(), 40u);
  EXPECT_EQ(kept.bytes(), 30u);
  EXPECT_EQ(budget.reserved(), 70u);
  Reservation rest = call.split(1000);  // no more than it holds
  EXPECT_EQ(rest.bytes(), 40u);
  EXPECT_EQ(call.bytes(), 0u);
  EXPECT_EQ(Reservation().split(5).bytes(), 0u);  // an empty one has nothing to give
  rest.release();
  EXPECT_EQ(budget.reserved(), 30u);
  kept.release();
  EXPECT_EQ(budget.reserved(), 0u);
}

// What parsing `wire` as a T on an arena (as the batched calls do) holds,
// next to the guard's bound of it (protos/guard/parse_guard.hpp).
template <class T>
std::pair<std::uint64_t, std::uint64_t> held_and_bound(const std::string& wire) {
  google::protobuf::Arena arena;
  T* message = google::protobuf::Arena::CreateMessage<T>(&arena);
  const std::uint64_t empty = arena.SpaceAllocated();
  EXPECT_TRUE(message->ParseFromString(wire));
  return {arena.SpaceAllocated() - empty, proto::parse_bound(*T::descriptor(), wire).bytes};
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
  const std::pair<std::uint64_t, std::uint64_t> cases[] = {
      held_and_bound<v1::CullBoxesRequest>(real.SerializeAsString()),
      held_and_bound<v1::CullBoxesRequest>(empty.SerializeAsString()),
      held_and_bound<v1::LineOfSightRequest>(lines.SerializeAsString()),
      held_and_bound<v1::SessionRequest>(removes.SerializeAsString()),
      held_and_bound<v1::ViewshedRequest>(observers.SerializeAsString()),
  };
  for (const auto& [held, bound] : cases) {
    EXPECT_GE(bound, held);
    EXPECT_LE(bound, 3 * held + (1 << 20));
  }
  // The empty boxes: 200 kB on the wire, megabytes parsed.
  EXPECT_GT(cases[1].first, 30 * empty.ByteSizeLong());
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

// An allowance that counts its takes and refuses none.
struct CountingAllowance final : proto::ParseAllowance {
  int takes = 0;
  bool take(std::uint64_t) override { return ++takes > 0; }
  void give(std::uint64_t) override {}
};

// Parses a GetDatasetRequest through its gRPC serialisation, as a daemon does.
void parse_through_grpc() {
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
  parse_through_grpc();
  EXPECT_EQ(first.takes, 0);
  EXPECT_EQ(second.takes, 1);
  proto::remove_parse_allowance(&second);
  parse_through_grpc();
  EXPECT_EQ(second.takes, 1);
}

// A wire that does not parse is bounded as far as it goes, plus its bytes.
TEST(ParseGuard, ABrokenWireIsBoundedByWhatItHolds) {
  v1::CullBoxesRequest request;
  for (int i = 0; i < 1000; ++i) request.add_boxes()->set_z_max(i);
  std::string wire = request.SerializeAsString();
  wire.resize(wire.size() / 2);
  wire += "\xff\xff\xff";  // a tag whose varint never ends
  const proto::ParseBound bound = proto::parse_bound(*v1::CullBoxesRequest::descriptor(), wire);
  EXPECT_GT(bound.messages, 400u);
  EXPECT_LT(bound.messages, 600u);
  EXPECT_GE(bound.bytes, wire.size());
  // A box whose length is 2^32 - 1 (no int holds it): the walk stops there.
  const std::string huge = request.SerializeAsString() + std::string("\x1a\xff\xff\xff\xff\x0f", 6);
  const proto::ParseBound at_huge = proto::parse_bound(*v1::CullBoxesRequest::descriptor(), huge);
  EXPECT_EQ(at_huge.messages, 1001u);
  EXPECT_GE(at_huge.bytes, huge.size());
}

// Trims wait for the daemon to be idle at the end of the delay, and come at
// most once an interval however often it falls idle. (Bounds are generous:
// each waits several times the delay the trimmer is given.)
TEST(HeapTrimmer, TrimsOnlyWhenStillIdleAndAtMostOnceAnInterval) {
  using namespace std::chrono_literals;
  std::atomic<std::uint32_t> live{1};
  HeapTrimmer trimmer(live);
  trimmer.idle();  // told idle, but a call is live again
  std::this_thread::sleep_for(HeapTrimmer::kDelay * 4);
  EXPECT_EQ(trimmer.trims(), 0u);

  live = 0;
  trimmer.idle();
  const auto until = std::chrono::steady_clock::now() + 5s;
  while (trimmer.trims() == 0 && std::chrono::steady_clock::now() < until) std::this_thread::sleep_for(10ms);
  EXPECT_EQ(trimmer.trims(), 1u);
  // A client falling idle between calls 60 times a second: no second trim within the interval.
  for (int i = 0; i < 30; ++i) {
    trimmer.idle();
    std::this_thread::sleep_for(16ms);
  }
  EXPECT_LE(trimmer.trims(), 2u);  // 480 ms of idles: the first trim's interval covers them, at most one more
}

}  // namespace
}  // namespace horizon::server
