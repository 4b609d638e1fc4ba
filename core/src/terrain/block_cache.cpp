// The shared block cache: an LRU map of decoded blocks under a byte budget,
// with decoding on a Boost.Asio thread pool and in-flight decodes joined.
#include "horizon/terrain/block_cache.hpp"

#include <algorithm>
#include <atomic>
#include <boost/asio/post.hpp>
#include <boost/asio/thread_pool.hpp>
#include <chrono>
#include <future>
#include <list>
#include <mutex>
#include <optional>
#include <unordered_map>
#include <utility>

namespace horizon::terrain {
namespace {

struct KeyHash {
  std::size_t operator()(const BlockKey& k) const {
    return std::hash<std::uint64_t>{}(k.source * 0x9E3779B97F4A7C15ull ^ k.block);
  }
};

std::uint64_t bytes_of(const Grid<float>& cells) {
  return static_cast<std::uint64_t>(cells.size()) * sizeof(float);
}

}  // namespace

struct BlockCache::State {
  explicit State(const Options& o) : budget(o.budget_bytes), pool(std::max(1u, o.io_threads)) {}

  using Pending = std::shared_future<Result<Shared>>;
  struct Entry {
    Shared block;                       // set once resident
    std::list<BlockKey>::iterator lru;  // position in `lru` while resident
  };

  const std::uint64_t budget;
  mutable std::mutex mutex;
  std::unordered_map<BlockKey, Entry, KeyHash> resident;
  std::unordered_map<BlockKey, Pending, KeyHash> decoding;     // decodes and builds in flight
  std::list<BlockKey> lru;                                     // front = most recently used
  std::unordered_map<std::uint64_t, std::uint64_t> by_source;  // resident bytes per source
  BlockCacheStats counters;
  // Bytes of every block alive anywhere (the cache's and the evicted ones
  // requests still hold); updated as each block's last owner lets go.
  std::atomic<std::uint64_t> live_bytes{0};
  boost::asio::thread_pool pool;

  // The key's block if resident, made the most recently used. Mutex held.
  const Shared* touch(const BlockKey& key) {
    auto it = resident.find(key);
    if (it == resident.end()) return nullptr;
    lru.splice(lru.begin(), lru, it->second.lru);
    return &it->second.block;
  }
  // The decode or build of `key` in flight, if any. Mutex held.
  const Pending* in_flight(const BlockKey& key) const {
    auto it = decoding.find(key);
    return it == decoding.end() ? nullptr : &it->second;
  }

  // Waits for `pending` to settle, polling `control` (may be null) every
  // 5 ms: Ok once it has, the control's error once it says stop. Mutex not held.
  static Status settled(const Pending& pending, const RunControl* control) {
    while (pending.wait_for(std::chrono::milliseconds(5)) != std::future_status::ready)
      HORIZON_RETURN_IF_ERROR(check_control(control));
    return Status::Ok();
  }

  // Keeps `block` while the budget allows, evicting from the back. Mutex held.
  void keep(const BlockKey& key, const Shared& block) {
    if (block.bytes > budget) return;  // handed to its requesters only
    while (counters.resident_bytes + block.bytes > budget && !lru.empty()) {
      const BlockKey victim = lru.back();
      lru.pop_back();
      auto it = resident.find(victim);
      const std::uint64_t freed = it->second.block.bytes;
      counters.resident_bytes -= freed;
      if ((by_source[victim.source] -= freed) == 0) by_source.erase(victim.source);
      resident.erase(it);
      ++counters.evictions;
    }
    lru.push_front(key);
    resident.emplace(key, Entry{block, lru.begin()});
    counters.resident_bytes += block.bytes;
    by_source[key.source] += block.bytes;
    counters.peak_resident_bytes = std::max(counters.peak_resident_bytes, counters.resident_bytes);
  }

  // `made`, wrapped so that live_bytes counts it until its last owner lets
  // go (the wrapper holds the state weakly: a block may outlive its cache).
  static Shared track(Shared made, const std::shared_ptr<State>& state) {
    struct Tracked {
      Tracked(std::shared_ptr<const void> v, std::uint64_t b, std::weak_ptr<State> s)
          : value(std::move(v)), bytes(b), state(std::move(s)) {}
      Tracked(const Tracked&) = delete;
      Tracked& operator=(const Tracked&) = delete;
      ~Tracked() {
        if (auto s = state.lock()) s->live_bytes.fetch_sub(bytes);
      }
      std::shared_ptr<const void> value;
      std::uint64_t bytes;
      std::weak_ptr<State> state;
    };
    state->live_bytes.fetch_add(made.bytes);
    auto owner = std::make_shared<const Tracked>(std::move(made.value), made.bytes, state);
    const void* object = owner->value.get();
    return Shared{std::shared_ptr<const void>(owner, object), owner->bytes};
  }

  // Settles an in-flight key: out of `decoding`, into the cache when it
  // succeeded. Mutex held. Returns what its waiters get.
  Result<Shared> settle(const BlockKey& key, Result<Shared> made, const std::shared_ptr<State>& self, bool decoded) {
    decoding.erase(key);
    if (!made.ok()) {
      ++counters.failures;
      return made.error();
    }
    Shared block = track(std::move(*made), self);
    if (decoded)
      counters.bytes_decoded += block.bytes;
    else
      ++counters.builds;
    keep(key, block);
    return block;
  }
};

BlockCache::BlockCache(Options options) : state_(std::make_shared<State>(options)) {}

BlockCache::~BlockCache() {
  state_->pool.join();
}

std::uint64_t BlockCache::next_source_id() {
  static std::atomic<std::uint64_t> next{1};
  return next.fetch_add(1);
}

std::uint64_t BlockCache::budget_bytes() const {
  return state_->budget;
}

std::uint64_t BlockCache::resident_bytes_of(std::uint64_t source) const {
  std::lock_guard lock(state_->mutex);
  auto it = state_->by_source.find(source);
  return it == state_->by_source.end() ? 0 : it->second;
}

BlockCacheStats BlockCache::stats() const {
  std::lock_guard lock(state_->mutex);
  BlockCacheStats s = state_->counters;
  s.budget_bytes = state_->budget;
  s.resident_blocks = state_->resident.size();
  const std::uint64_t live = state_->live_bytes.load();
  s.held_bytes = live > s.resident_bytes ? live - s.resident_bytes : 0;
  return s;
}

Result<std::vector<Block>> BlockCache::fetch(std::span<const Want> wants, const RunControl* control,
                                             FetchStats* stats) {
  FetchStats local;
  local.blocks = wants.size();
  std::vector<Block> blocks(wants.size());
  std::vector<std::optional<State::Pending>> pending(wants.size());
  std::vector<bool> own(wants.size(), false);  // this fetch started the decode
  {
    std::lock_guard lock(state_->mutex);
    for (std::size_t i = 0; i < wants.size(); ++i) {
      const BlockKey key = wants[i].key;
      if (const Shared* hit = state_->touch(key)) {
        blocks[i] = std::static_pointer_cast<const Grid<float>>(hit->value);
        ++local.hits;
        continue;
      }
      if (const State::Pending* flight = state_->in_flight(key)) {
        pending[i] = *flight;
        ++local.joins;
        continue;
      }
      // A decode of our own, posted once the map knows it (so a second want
      // of the same key, in this fetch or another, joins it).
      auto promise = std::make_shared<std::promise<Result<Shared>>>();
      State::Pending future = promise->get_future().share();
      state_->decoding.emplace(key, future);
      pending[i] = future;
      own[i] = true;
      ++local.misses;
      std::weak_ptr<State> weak = state_;
      boost::asio::post(state_->pool, [weak, key, load = wants[i].load, promise] {
        std::shared_ptr<State> state = weak.lock();
        if (!state) return promise->set_value(make_error(ErrorCode::kCancelled, "the block cache was closed"));
        Result<Grid<float>> cells = load();
        Result<Shared> made = Error{};
        if (cells.ok()) {
          const std::uint64_t bytes = bytes_of(*cells);
          made = Shared{std::make_shared<const Grid<float>>(std::move(*cells)), bytes};
        } else {
          made = cells.error();
        }
        std::lock_guard inner(state->mutex);
        promise->set_value(state->settle(key, std::move(made), state, /*decoded=*/true));
      });
    }
    state_->counters.hits += local.hits;
    state_->counters.joins += local.joins;
    state_->counters.misses += local.misses;
  }

  // Wait for every pending block, in order, polling the control.
  const auto start = std::chrono::steady_clock::now();
  std::optional<Error> failure;
  for (std::size_t i = 0; i < wants.size(); ++i) {
    if (!pending[i]) continue;
    if (auto s = State::settled(*pending[i], control); !s.ok()) return s.error();
    const Result<Shared>& got = pending[i]->get();
    if (!got.ok()) {
      if (!failure) failure = got.error();
      continue;
    }
    blocks[i] = std::static_pointer_cast<const Grid<float>>(got->value);
    if (own[i]) local.bytes_decoded += got->bytes;
  }
  local.wait_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  if (stats) *stats = local;
  if (failure) return *failure;
  return blocks;
}

Result<BlockCache::Shared> BlockCache::build_shared(BlockKey key, const std::function<Result<Shared>()>& make,
                                                    const RunControl* control, FetchStats* stats) {
  FetchStats local;
  local.blocks = 1;
  std::optional<State::Pending> joined;
  std::promise<Result<Shared>> promise;
  {
    std::lock_guard lock(state_->mutex);
    if (const Shared* hit = state_->touch(key)) {
      ++state_->counters.hits;
      local.hits = 1;
      if (stats) *stats = local;
      return *hit;
    }
    if (const State::Pending* flight = state_->in_flight(key)) {
      joined = *flight;
      ++state_->counters.joins;
      local.joins = 1;
    } else {
      state_->decoding.emplace(key, promise.get_future().share());
      ++state_->counters.misses;
      local.misses = 1;
    }
  }
  const auto start = std::chrono::steady_clock::now();
  const auto finish = [&](Result<Shared> r) {
    local.wait_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    if (stats) *stats = local;
    return r;
  };
  if (joined) {
    if (auto s = State::settled(*joined, control); !s.ok()) return finish(s.error());
    return finish(joined->get());
  }
  // Ours to build, here. Whatever happens, the key is settled, so that
  // no joiner waits forever.
  Result<Shared> made = Error{};
  try {
    made = make();
  } catch (...) {
    std::lock_guard lock(state_->mutex);
    promise.set_value(state_->settle(key, make_error(ErrorCode::kInternal, "building a cached block failed"), state_,
                                     /*decoded=*/false));
    throw;
  }
  std::lock_guard lock(state_->mutex);
  Result<Shared> settled = state_->settle(key, std::move(made), state_, /*decoded=*/false);
  promise.set_value(settled);
  return finish(std::move(settled));
}

}  // namespace horizon::terrain
