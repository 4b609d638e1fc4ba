// The GL contexts' images under a memory gate (gpu/context_pool.hpp): GL
// code asks for its images before allocating them, a refusal sends the work
// to the CPU with the reason, a context keeps at most keep_image_bytes
// between leases, and what it keeps stays taken until freed. On llvmpipe
// in CI, where images are this process's memory.
#include <gtest/gtest.h>

#include <cstdint>
#include <mutex>
#include <string>

#include "horizon/gpu/context_pool.hpp"
#include "horizon/trace/trace.hpp"
#include "horizon/visibility/viewshed.hpp"
#include "test_support.hpp"

namespace horizon {
namespace {

// A budget of `limit` bytes that records what it lent.
class CountingGate final : public gpu::ImageMemory {
 public:
  explicit CountingGate(std::uint64_t limit) : limit_(limit) {}
  bool take(std::uint64_t bytes) override {
    std::lock_guard lock(mutex_);
    ++asked_;
    if (taken_ + bytes > limit_) return false;
    taken_ += bytes;
    peak_ = std::max(peak_, taken_);
    return true;
  }
  void give(std::uint64_t bytes) override {
    std::lock_guard lock(mutex_);
    EXPECT_LE(bytes, taken_) << "gave back more than was taken";
    taken_ -= bytes;
  }
  std::uint64_t taken() const {
    std::lock_guard lock(mutex_);
    return taken_;
  }
  std::uint64_t peak() const {
    std::lock_guard lock(mutex_);
    return peak_;
  }
  int asked() const {
    std::lock_guard lock(mutex_);
    return asked_;
  }

 private:
  mutable std::mutex mutex_;
  std::uint64_t limit_, taken_ = 0, peak_ = 0;
  int asked_ = 0;
};

geodesy::GridPoint centre_eye(const terrain::Dem& dem) {
  geodesy::PointSpec spec;
  spec.x = dem.georef.transform.x_at(dem.width() / 2.0 + 0.3);
  spec.y = dem.georef.transform.y_at(dem.height() / 2.0 + 0.6);
  spec.height = 2.0;
  auto eye = geodesy::resolve_point(dem, spec, "observer");
  EXPECT_TRUE(eye.ok()) << eye.error().message;
  return *eye;
}

visibility::ViewshedResult on_gpu(const terrain::Dem& dem, gpu::ContextPool& pool) {
  visibility::ViewshedOptions o;
  o.backend = visibility::Backend::kGpu;
  auto r = visibility::compute_viewshed(dem, centre_eye(dem), o, nullptr, &pool);
  EXPECT_TRUE(r.ok()) << r.error().message;
  return std::move(*r);
}

// The sweep's images of a 300 x 260 window: terrain (4 B a cell) and target
// (8 B a cell) alone are 936 000 bytes, the ray disks more.
TEST(GpuImages, ARefusedSweepRunsOnTheCpuAndTakesNothing) {
  auto pool = gpu::ContextPool::create({.contexts = 1});
  ASSERT_TRUE(pool.ok()) << pool.error().message;
  CountingGate gate(900'000);
  (*pool)->set_image_memory(&gate);
  const auto dem = testing::make_random_terrain(300, 260, 3, 200.0);
  const auto refused = on_gpu(dem, **pool);
  EXPECT_EQ(refused.stats.backend, "cpu");
  EXPECT_NE(refused.stats.gpu_fallback.find("MiB of GL images"), std::string::npos) << refused.stats.gpu_fallback;
  EXPECT_EQ(gate.asked(), 1);
  EXPECT_EQ(gate.taken(), 0u);
  EXPECT_EQ((*pool)->held_image_bytes(), 0u);
  EXPECT_EQ((*pool)->counters().failures, 0u) << "a refusal is not a GL failure";

  // The CPU's answer is the answer a CPU request gets.
  visibility::ViewshedOptions cpu;
  auto c = visibility::compute_viewshed(dem, centre_eye(dem), cpu);
  ASSERT_TRUE(c.ok());
  ASSERT_EQ(c->ohf.size(), refused.ohf.size());
  for (std::size_t i = 0; i < c->ohf.size(); ++i)
    ASSERT_TRUE(c->ohf.values()[i] == refused.ohf.values()[i] ||
                (std::isnan(c->ohf.values()[i]) && std::isnan(refused.ohf.values()[i])))
        << "cell " << i;
}

// Allowed, the context keeps its images, taken from the gate for as long as
// it keeps them; a smaller request allocates (and takes) nothing more.
TEST(GpuImages, AKeptContextHoldsWhatItTookAndNoMore) {
  auto pool = gpu::ContextPool::create({.contexts = 1});
  ASSERT_TRUE(pool.ok()) << pool.error().message;
  CountingGate gate(1ull << 30);
  (*pool)->set_image_memory(&gate);
  const auto dem = testing::make_random_terrain(300, 260, 3, 200.0);
  EXPECT_EQ(on_gpu(dem, **pool).stats.backend, "gpu");
  const std::uint64_t held = gate.taken();
  EXPECT_GE(held, 300u * 260u * 12u) << "terrain and target at least";
  EXPECT_EQ((*pool)->held_image_bytes(), held);
  EXPECT_EQ(gate.peak(), held) << "asked for exactly what it allocated";
  const int asked = gate.asked();
  const auto small = testing::make_random_terrain(120, 100, 4, 200.0);
  EXPECT_EQ(on_gpu(small, **pool).stats.backend, "gpu");
  EXPECT_EQ(gate.asked(), asked) << "images of a size seen before: nothing asked";
  EXPECT_EQ(gate.taken(), held);
  // A failed context's images go with it, and back to the gate.
  {
    auto lease = (*pool)->borrow();
    ASSERT_TRUE(lease.ok());
    lease->fail();
  }
  EXPECT_EQ(gate.taken(), 0u);
  EXPECT_EQ((*pool)->held_image_bytes(), 0u);
}

// keep_image_bytes: a context returned holding more frees its images (its
// programs stay); the next request re-creates them and asks again.
TEST(GpuImages, PastTheKeepLimitImagesAreFreedOnReturn) {
  auto pool = gpu::ContextPool::create({.contexts = 1, .keep_image_bytes = 1u << 20});
  ASSERT_TRUE(pool.ok()) << pool.error().message;
  CountingGate gate(1ull << 30);
  (*pool)->set_image_memory(&gate);
  const auto big = testing::make_random_terrain(300, 260, 3, 200.0);
  EXPECT_EQ(on_gpu(big, **pool).stats.backend, "gpu");
  EXPECT_GT(gate.peak(), 1u << 20);
  EXPECT_EQ(gate.taken(), 0u) << "freed on return: over 1 MiB";
  const int asked = gate.asked();
  EXPECT_EQ(on_gpu(big, **pool).stats.backend, "gpu");
  EXPECT_EQ(gate.asked(), asked + 1);
  EXPECT_EQ(gate.taken(), 0u);
  // Under the limit, kept.
  const auto small = testing::make_random_terrain(40, 30, 5, 200.0);
  EXPECT_EQ(on_gpu(small, **pool).stats.backend, "gpu");
  EXPECT_GT(gate.taken(), 0u);
  EXPECT_LE(gate.taken(), 1u << 20);
}

// The camera trace asks the same gate: refused, the CPU traces the frame.
TEST(GpuImages, ARefusedCameraFrameIsTracedOnTheCpu) {
  auto pool = gpu::ContextPool::create({.contexts = 1});
  ASSERT_TRUE(pool.ok()) << pool.error().message;
  CountingGate gate(100'000);
  (*pool)->set_image_memory(&gate);
  terrain::Dem dem = testing::make_random_terrain(200, 180, 7, 300.0, 30.0);
  dem.georef.transform = {500000.0, 30.0, 5000000.0, -30.0};
  trace::CameraSpec spec;
  spec.position.x = dem.georef.transform.x_at(100.5);
  spec.position.y = dem.georef.transform.y_at(90.5);
  spec.position.height = 50.0;
  spec.yaw = 30.0;
  spec.hfov = 60.0;
  spec.width = 160;
  spec.height = 120;
  auto camera = trace::resolve_camera(dem, spec);
  ASSERT_TRUE(camera.ok()) << camera.error().message;
  const terrain::HeightView view(dem.elevation);
  auto lease = (*pool)->borrow();
  ASSERT_TRUE(lease.ok());
  auto frame = trace::trace_frame(view, *camera, {}, nullptr, &*lease);
  ASSERT_TRUE(frame.ok()) << frame.error().message;
  EXPECT_EQ(frame->stats.backend, "cpu");
  EXPECT_NE(frame->stats.gpu_fallback.find("MiB of GL images"), std::string::npos) << frame->stats.gpu_fallback;
  EXPECT_EQ(gate.taken(), 0u);
  auto cpu = trace::trace_frame(view, *camera, {});
  ASSERT_TRUE(cpu.ok());
  EXPECT_EQ(frame->image.line, cpu->image.line);
}

}  // namespace
}  // namespace horizon
