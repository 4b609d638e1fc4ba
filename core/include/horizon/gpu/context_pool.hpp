// horizon/gpu/context_pool.hpp — headless EGL contexts, created once, lent per request.
//
//   auto pool = gpu::ContextPool::create({.contexts = 4});   // ~30 ms + ~6 ms a context
//   if (!pool.ok()) { /* no EGL: run on the CPU */ }
//   {
//     gpu::Lease lease = (*pool)->borrow();   // blocks while all contexts are lent
//     ... GL calls on this thread ...
//     if (something failed) lease.fail("GL_OUT_OF_MEMORY in the propagation pass");
//   }                                         // returned; a failed context is replaced
//
// The display is the EGL device platform (eglQueryDevicesEXT), preferring a
// hardware device over Mesa's software one, with Mesa's surfaceless platform
// as the fallback; no X and no window are ever needed. Each context is a
// desktop OpenGL 4.3 core context (compute shaders, R32F/RG32F targets) bound
// with no surface. A context is current only on the thread holding its lease.
//
// Per-context GL objects (programs, textures, framebuffers) are kept in
// ContextResources the GL code hangs on the context, one per algorithm
// (Lease::resources<R>(): the OHF sweep's and the clip-map trace's side by
// side on the same context), so
// shaders are compiled once per context and images are reallocated only when
// a request needs more room than any before it.
//
// Memory: a context keeps its images (textures and buffers) between leases,
// grown to the largest request it served, so their memory is the pool's to
// bound. PoolOptions::keep_image_bytes caps what a context keeps: a lease
// returned holding more has its images freed (programs stay compiled). On a
// software rasteriser images are process memory; a caller that budgets its
// memory installs an ImageMemory gate (set_image_memory): GL code asks its
// lease for the images it is about to allocate (Lease::hold_images) before
// allocating them, the gate may refuse (the GL code then fails with
// kResourceExhausted and its caller answers on the CPU), and what a context
// keeps stays taken from the gate until it is freed.
//
// Failures: a lease marked failed (a GL error, GL_OUT_OF_MEMORY, a lost
// context) destroys that context and its resources on return and creates a
// fresh one, so one bad request never poisons later ones. counters() tells
// an operator how often that happened.
//
// The pool lends contexts and nothing more: which requests run on the GPU
// (and which GL variant) is engine policy (visibility/backend_policy.hpp).
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <typeindex>

#include "horizon/common/error.hpp"

namespace horizon::gpu {

struct DeviceInfo {
  std::string platform;  // "device" (EGL_EXT_platform_device) or "surfaceless" (EGL_MESA_platform_surfaceless)
  std::string vendor, renderer, version;  // GL_VENDOR, GL_RENDERER, GL_VERSION
  bool software = false;                  // a CPU rasteriser (llvmpipe, softpipe): the CPU path is faster
  int max_texture_size = 0;               // GL_MAX_TEXTURE_SIZE, texels per side
};

enum class EglPlatform {
  kAny,          // the device platform, then Mesa's surfaceless one
  kDevice,       // EGL_EXT_platform_device only
  kSurfaceless,  // EGL_MESA_platform_surfaceless only
};

struct PoolOptions {
  int contexts = 1;  // contexts created up front, [1, 64]: requests that can run on the GPU at once
  EglPlatform platform = EglPlatform::kAny;
  // Images a context keeps between leases; past it they are freed on return.
  std::uint64_t keep_image_bytes = UINT64_MAX;
};

// Where GL images' memory is accounted (a memory budget). Called from the
// borrowing threads, one context's lease at a time each: thread-safe.
class ImageMemory {
 public:
  virtual ~ImageMemory() = default;
  // Takes `bytes` more; false (nothing taken) when they do not fit.
  virtual bool take(std::uint64_t bytes) = 0;
  // Gives back bytes taken before.
  virtual void give(std::uint64_t bytes) = 0;
};

// What the GL code keeps per context; created on first use by the code that
// owns it, destroyed (with the context current) when the context goes.
class ContextResources {
 public:
  virtual ~ContextResources() = default;
  // Bytes of the images (textures, buffers) held; programs and framebuffer
  // objects are not counted.
  virtual std::uint64_t image_bytes() const { return 0; }
  // Frees the images, keeping the programs (the next run re-creates them).
  virtual void release_images() {}
};

class ContextPool;

// One borrowed context, current on the borrowing thread until destruction,
// which must happen on that same thread (EGL binds contexts per thread).
// Movable, not copyable.
class Lease {
 public:
  Lease(Lease&& other) noexcept;
  Lease& operator=(Lease&&) = delete;
  Lease(const Lease&) = delete;
  ~Lease();

  const DeviceInfo& device() const;
  // The context's resources of type R (a ContextResources): each GL
  // algorithm keeps its own on the context, default-constructed the first
  // time that context runs it.
  template <class R>
  R& resources() {
    std::unique_ptr<ContextResources>& slot = resources_of(typeid(R));
    if (!slot) slot = std::make_unique<R>();
    return static_cast<R&>(*slot);
  }
  // The slot of one type's resources (null until set).
  std::unique_ptr<ContextResources>& resources_of(std::type_index type);
  // How many kinds of resources the context holds.
  std::size_t resource_kinds() const;
  // Before GL code allocates images: it is about to grow this context's
  // images by up to `bytes`. Taken from the pool's ImageMemory (if any);
  // kResourceExhausted, naming `what` and the bytes, when it refuses. The
  // account is settled on return against what the context really holds.
  Status hold_images(std::uint64_t bytes, const std::string& what);
  // hold_images for `resources` about to grow to `after` bytes in all: asks
  // for what that adds to its image_bytes() (nothing when it does not grow).
  Status grow_images(const ContextResources& resources, std::uint64_t after, const std::string& what) {
    const std::uint64_t held = resources.image_bytes();
    return after > held ? hold_images(after - held, what) : Status::Ok();
  }
  // Marks the context unusable: it is destroyed when returned and replaced.
  void fail();
  bool failed() const { return failed_; }
  int index() const { return index_; }  // which context of the pool, [0, size)

 private:
  friend class ContextPool;
  Lease(ContextPool* pool, int index) : pool_(pool), index_(index) {}
  ContextPool* pool_ = nullptr;
  int index_ = -1;
  bool failed_ = false;
};

class ContextPool {
 public:
  // Initialises the display and creates every context. Fails (kUnsupported)
  // when no EGL display or OpenGL 4.3 context can be had.
  static Result<std::unique_ptr<ContextPool>> create(const PoolOptions& options);
  ~ContextPool();
  ContextPool(const ContextPool&) = delete;
  ContextPool& operator=(const ContextPool&) = delete;

  const DeviceInfo& device() const;
  int size() const;
  // Accounts every context's images in `memory` from now on (null: none);
  // set before the first borrow, outliving the pool's contexts.
  void set_image_memory(ImageMemory* memory);
  // Image bytes the contexts hold between leases (as last settled).
  std::uint64_t held_image_bytes() const;

  // Waits for a free context and makes it current on this thread. Fails only
  // when a replacement for a failed context cannot be created.
  Result<Lease> borrow();

  struct Counters {
    std::uint64_t leases = 0;    // contexts lent
    std::uint64_t failures = 0;  // leases marked failed
    std::uint64_t replaced = 0;  // contexts re-created after a failure
  };
  Counters counters() const;

 private:
  friend class Lease;
  struct Impl;
  explicit ContextPool(std::unique_ptr<Impl> impl);
  void give_back(int index, bool failed);
  std::unique_ptr<Impl> impl_;
};

}  // namespace horizon::gpu
