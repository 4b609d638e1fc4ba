#include "worker_pool.hpp"

#include <boost/asio/post.hpp>
#include <boost/asio/thread_pool.hpp>

#include "horizon/common/parallel.hpp"

namespace horizon::server {

struct WorkerPool::Impl {
  explicit Impl(unsigned threads) : pool(threads) {}
  boost::asio::thread_pool pool;
  bool joined = false;
};

WorkerPool::WorkerPool(unsigned threads)
    : impl_(std::make_unique<Impl>(resolve_thread_count(threads))), threads_(resolve_thread_count(threads)) {}

WorkerPool::~WorkerPool() { join(); }

void WorkerPool::post(std::function<void()> task) { boost::asio::post(impl_->pool, std::move(task)); }

void WorkerPool::join() {
  if (impl_->joined) return;
  impl_->joined = true;
  impl_->pool.join();
}

}  // namespace horizon::server
