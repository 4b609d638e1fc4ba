// EGL display and context pool (see context_pool.hpp).
#include "horizon/gpu/context_pool.hpp"

#include <EGL/egl.h>
#include <EGL/eglext.h>
#include <GL/gl.h>

#include <algorithm>
#include <condition_variable>
#include <cstdio>
#include <iterator>
#include <mutex>
#include <string_view>
#include <utility>
#include <vector>

namespace horizon::gpu {
namespace {

#ifndef EGL_PLATFORM_SURFACELESS_MESA
#define EGL_PLATFORM_SURFACELESS_MESA 0x31DD
#endif

bool has_extension(const char* list, std::string_view name) {
  if (list == nullptr) return false;
  std::string_view rest(list);
  while (!rest.empty()) {
    const auto space = rest.find(' ');
    if (rest.substr(0, space) == name) return true;
    if (space == std::string_view::npos) break;
    rest.remove_prefix(space + 1);
  }
  return false;
}

std::string egl_error_text(EGLint error) {
  char buffer[32];
  std::snprintf(buffer, sizeof buffer, "EGL error 0x%04X", static_cast<unsigned>(error));
  return buffer;
}

// EGL hands every pool of a process the same display for the same device,
// and eglTerminate ends it for all of them: pools count their displays here,
// and the last one out terminates.
std::mutex display_users_mutex;
std::vector<std::pair<EGLDisplay, int>> display_users;

void add_display_user(EGLDisplay display) {
  std::lock_guard lock(display_users_mutex);
  for (auto& [d, n] : display_users)
    if (d == display) {
      ++n;
      return;
    }
  display_users.push_back({display, 1});
}

// True when the caller was the display's last user.
bool remove_display_user(EGLDisplay display) {
  std::lock_guard lock(display_users_mutex);
  for (auto it = display_users.begin(); it != display_users.end(); ++it)
    if (it->first == display) {
      if (--it->second > 0) return false;
      display_users.erase(it);
      return true;
    }
  return false;
}

struct Display {
  EGLDisplay display = EGL_NO_DISPLAY;
  std::string platform;
  bool software_device = false;  // EGL_MESA_device_software
};

// The EGL device platform, hardware devices first; then Mesa's surfaceless platform.
Result<Display> open_display(EglPlatform platform) {
  const char* client = eglQueryString(EGL_NO_DISPLAY, EGL_EXTENSIONS);
  std::string tried;
  if (platform != EglPlatform::kSurfaceless && has_extension(client, "EGL_EXT_device_enumeration") &&
      has_extension(client, "EGL_EXT_platform_device")) {
    auto query_devices = reinterpret_cast<PFNEGLQUERYDEVICESEXTPROC>(eglGetProcAddress("eglQueryDevicesEXT"));
    auto query_string = reinterpret_cast<PFNEGLQUERYDEVICESTRINGEXTPROC>(eglGetProcAddress("eglQueryDeviceStringEXT"));
    auto platform_display =
        reinterpret_cast<PFNEGLGETPLATFORMDISPLAYEXTPROC>(eglGetProcAddress("eglGetPlatformDisplayEXT"));
    EGLint count = 0;
    if (query_devices && query_string && platform_display && query_devices(0, nullptr, &count) && count > 0) {
      std::vector<EGLDeviceEXT> devices(static_cast<std::size_t>(count));
      query_devices(count, devices.data(), &count);
      // Hardware devices first (stable order otherwise).
      std::stable_sort(devices.begin(), devices.begin() + count, [&](EGLDeviceEXT a, EGLDeviceEXT b) {
        return !has_extension(query_string(a, EGL_EXTENSIONS), "EGL_MESA_device_software") &&
               has_extension(query_string(b, EGL_EXTENSIONS), "EGL_MESA_device_software");
      });
      for (EGLint i = 0; i < count; ++i) {
        EGLDisplay display = platform_display(EGL_PLATFORM_DEVICE_EXT, devices[i], nullptr);
        EGLint major = 0, minor = 0;
        if (display != EGL_NO_DISPLAY && eglInitialize(display, &major, &minor)) {
          return Display{display, "device",
                         has_extension(query_string(devices[i], EGL_EXTENSIONS), "EGL_MESA_device_software")};
        }
        tried += "device " + std::to_string(i) + ": " + egl_error_text(eglGetError()) + "; ";
      }
    }
  }
  if (platform != EglPlatform::kDevice && has_extension(client, "EGL_MESA_platform_surfaceless")) {
    EGLDisplay display = eglGetPlatformDisplay(EGL_PLATFORM_SURFACELESS_MESA, EGL_DEFAULT_DISPLAY, nullptr);
    EGLint major = 0, minor = 0;
    // Software or not is read from the renderer once a context exists.
    if (display != EGL_NO_DISPLAY && eglInitialize(display, &major, &minor))
      return Display{display, "surfaceless", false};
    tried += "surfaceless: " + egl_error_text(eglGetError()) + "; ";
  }
  if (tried.empty())
    tried = platform == EglPlatform::kDevice        ? "EGL offers no device platform; "
            : platform == EglPlatform::kSurfaceless ? "EGL offers no surfaceless platform; "
                                                    : "EGL offers neither a device nor a surfaceless platform; ";
  tried.resize(tried.size() - 2);
  return make_error(ErrorCode::kUnsupported, "gpu: no headless EGL display (" + tried + ")", "gpu");
}

Result<EGLContext> create_context(EGLDisplay display) {
  const char* extensions = eglQueryString(display, EGL_EXTENSIONS);
  if (!has_extension(extensions, "EGL_KHR_surfaceless_context"))
    return make_error(ErrorCode::kUnsupported, "gpu: the EGL display cannot bind a context without a surface", "gpu");
  EGLConfig config = nullptr;
  if (!has_extension(extensions, "EGL_KHR_no_config_context")) {
    const EGLint attributes[] = {EGL_RENDERABLE_TYPE, EGL_OPENGL_BIT, EGL_NONE};
    EGLint found = 0;
    if (!eglChooseConfig(display, attributes, &config, 1, &found) || found < 1)
      return make_error(ErrorCode::kUnsupported, "gpu: no EGL config renders desktop OpenGL", "gpu");
  }
  if (!eglBindAPI(EGL_OPENGL_API))
    return make_error(ErrorCode::kUnsupported, "gpu: EGL cannot bind the desktop OpenGL API", "gpu");
  // A reset (a lost context) reported rather than fatal, where the driver
  // offers it (EGL 1.5 / KHR_create_context); without it, plainly.
  const EGLint base[] = {EGL_CONTEXT_MAJOR_VERSION,       4,
                         EGL_CONTEXT_MINOR_VERSION,       3,
                         EGL_CONTEXT_OPENGL_PROFILE_MASK, EGL_CONTEXT_OPENGL_CORE_PROFILE_BIT};
  std::vector<EGLint> robust(std::begin(base), std::end(base));
  robust.insert(robust.end(), {EGL_CONTEXT_OPENGL_RESET_NOTIFICATION_STRATEGY, EGL_LOSE_CONTEXT_ON_RESET, EGL_NONE});
  std::vector<EGLint> plain(std::begin(base), std::end(base));
  plain.push_back(EGL_NONE);
  EGLContext context = eglCreateContext(display, config, EGL_NO_CONTEXT, robust.data());
  if (context == EGL_NO_CONTEXT) context = eglCreateContext(display, config, EGL_NO_CONTEXT, plain.data());
  if (context == EGL_NO_CONTEXT)
    return make_error(ErrorCode::kUnsupported,
                      "gpu: cannot create an OpenGL 4.3 core context (" + egl_error_text(eglGetError()) + ")", "gpu");
  return context;
}

}  // namespace

struct ContextPool::Impl {
  Display display;
  DeviceInfo info;
  struct Slot {
    EGLContext context = EGL_NO_CONTEXT;
    std::vector<std::pair<std::type_index, std::unique_ptr<ContextResources>>> resources;  // one per type
    bool lent = false;
    std::uint64_t taken = 0;  // image bytes taken from `image_memory` for this context (taken_mutex)
  };
  ImageMemory* image_memory = nullptr;
  mutable std::mutex taken_mutex;  // every Slot::taken
  std::uint64_t keep_image_bytes = UINT64_MAX;

  std::uint64_t image_bytes(const Slot& slot) const {
    std::uint64_t bytes = 0;
    for (const auto& held : slot.resources)
      if (held.second) bytes += held.second->image_bytes();
    return bytes;
  }
  // On return, the context current: frees images past keep_image_bytes, then
  // settles the account with what the context really holds (taking more when
  // the GL code held more than it asked for, freeing its images when even
  // that does not fit).
  void settle(Slot& slot) {
    auto release = [&slot] {
      for (auto& r : slot.resources)
        if (r.second) r.second->release_images();
    };
    std::uint64_t held = image_bytes(slot);
    if (held > keep_image_bytes) {
      release();
      held = image_bytes(slot);
    }
    if (image_memory == nullptr) return;
    std::lock_guard lock(taken_mutex);
    if (held > slot.taken && !image_memory->take(held - slot.taken)) {
      release();
      held = std::min(image_bytes(slot), slot.taken);  // every image freed: 0
    }
    if (held < slot.taken) image_memory->give(slot.taken - held);
    slot.taken = held;
  }
  void forget(Slot& slot) {  // its resources destroyed
    std::lock_guard lock(taken_mutex);
    if (image_memory != nullptr && slot.taken > 0) image_memory->give(slot.taken);
    slot.taken = 0;
  }
  std::vector<Slot> slots;
  mutable std::mutex mutex;
  std::condition_variable returned;
  Counters counters;

  // Destroys a slot's context, its resources first with the context current.
  void destroy(Slot& slot) {
    if (slot.context == EGL_NO_CONTEXT) return;
    if (!slot.resources.empty()) {
      eglMakeCurrent(display.display, EGL_NO_SURFACE, EGL_NO_SURFACE, slot.context);
      slot.resources.clear();
      eglMakeCurrent(display.display, EGL_NO_SURFACE, EGL_NO_SURFACE, EGL_NO_CONTEXT);
    }
    forget(slot);
    eglDestroyContext(display.display, slot.context);
    slot.context = EGL_NO_CONTEXT;
  }

  ~Impl() {
    for (Slot& slot : slots) destroy(slot);
    if (display.display == EGL_NO_DISPLAY || !remove_display_user(display.display)) return;
      // Mesa's driver unload leaks a few hundred bytes that LeakSanitizer
      // reports; under ASan the display stays initialised (process exit frees it).
#if !defined(__SANITIZE_ADDRESS__)
    eglTerminate(display.display);
#endif
    eglReleaseThread();
  }
};

Result<std::unique_ptr<ContextPool>> ContextPool::create(const PoolOptions& options) {
  if (options.contexts < 1 || options.contexts > 64)
    return make_error(ErrorCode::kInvalidArgument,
                      "gpu.contexts: must be an integer in [1, 64], got " + std::to_string(options.contexts),
                      "gpu.contexts");
  auto impl = std::make_unique<Impl>();
  auto display = open_display(options.platform);
  if (!display.ok()) return display.error();
  impl->display = *display;
  add_display_user(impl->display.display);
  impl->slots.resize(static_cast<std::size_t>(options.contexts));
  impl->keep_image_bytes = options.keep_image_bytes;
  for (Impl::Slot& slot : impl->slots) {
    auto context = create_context(impl->display.display);
    if (!context.ok()) return context.error();
    slot.context = *context;
  }
  // Facts about the device, read on the first context.
  EGLContext first = impl->slots.front().context;
  if (!eglMakeCurrent(impl->display.display, EGL_NO_SURFACE, EGL_NO_SURFACE, first))
    return make_error(ErrorCode::kUnsupported,
                      "gpu: cannot make a context current (" + egl_error_text(eglGetError()) + ")", "gpu");
  auto text = [](GLenum name) {
    const auto* s = reinterpret_cast<const char*>(glGetString(name));
    return std::string(s ? s : "");
  };
  DeviceInfo& info = impl->info;
  info.platform = impl->display.platform;
  info.vendor = text(GL_VENDOR);
  info.renderer = text(GL_RENDERER);
  info.version = text(GL_VERSION);
  glGetIntegerv(GL_MAX_TEXTURE_SIZE, &info.max_texture_size);
  info.software = impl->display.software_device || info.renderer.find("llvmpipe") != std::string::npos ||
                  info.renderer.find("softpipe") != std::string::npos;
  eglMakeCurrent(impl->display.display, EGL_NO_SURFACE, EGL_NO_SURFACE, EGL_NO_CONTEXT);
  return std::unique_ptr<ContextPool>(new ContextPool(std::move(impl)));
}

ContextPool::ContextPool(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
ContextPool::~ContextPool() = default;

const DeviceInfo& ContextPool::device() const {
  return impl_->info;
}
int ContextPool::size() const {
  return static_cast<int>(impl_->slots.size());
}

void ContextPool::set_image_memory(ImageMemory* memory) {
  std::lock_guard lock(impl_->taken_mutex);
  impl_->image_memory = memory;
}

std::uint64_t ContextPool::held_image_bytes() const {
  std::lock_guard lock(impl_->taken_mutex);
  std::uint64_t bytes = 0;
  for (const Impl::Slot& slot : impl_->slots) bytes += slot.taken;
  return bytes;
}

Result<Lease> ContextPool::borrow() {
  std::unique_lock lock(impl_->mutex);
  auto free_slot = [&] {
    return std::find_if(impl_->slots.begin(), impl_->slots.end(), [](const Impl::Slot& s) { return !s.lent; });
  };
  impl_->returned.wait(lock, [&] { return free_slot() != impl_->slots.end(); });
  Impl::Slot& slot = *free_slot();
  const int index = static_cast<int>(&slot - impl_->slots.data());
  if (slot.context == EGL_NO_CONTEXT) {  // replaced after a failure
    auto context = create_context(impl_->display.display);
    if (!context.ok()) return context.error();
    slot.context = *context;
    ++impl_->counters.replaced;
  }
  if (!eglMakeCurrent(impl_->display.display, EGL_NO_SURFACE, EGL_NO_SURFACE, slot.context))
    return make_error(
        ErrorCode::kInternal,
        "gpu: cannot make context " + std::to_string(index) + " current (" + egl_error_text(eglGetError()) + ")",
        "gpu");
  slot.lent = true;
  ++impl_->counters.leases;
  return Lease(this, index);
}

void ContextPool::give_back(int index, bool failed) {
  Impl::Slot& slot = impl_->slots[static_cast<std::size_t>(index)];
  if (failed) {
    // Resources first, with the context still current, then the context.
    slot.resources.clear();
    impl_->forget(slot);
  } else {
    impl_->settle(slot);
  }
  eglMakeCurrent(impl_->display.display, EGL_NO_SURFACE, EGL_NO_SURFACE, EGL_NO_CONTEXT);
  {
    std::lock_guard lock(impl_->mutex);
    if (failed) {
      eglDestroyContext(impl_->display.display, slot.context);
      slot.context = EGL_NO_CONTEXT;
      ++impl_->counters.failures;
    }
    slot.lent = false;
  }
  impl_->returned.notify_one();
}

ContextPool::Counters ContextPool::counters() const {
  std::lock_guard lock(impl_->mutex);
  return impl_->counters;
}

Lease::Lease(Lease&& other) noexcept
    : pool_(std::exchange(other.pool_, nullptr)), index_(other.index_), failed_(other.failed_) {}

Lease::~Lease() {
  if (pool_) pool_->give_back(index_, failed_);
}

const DeviceInfo& Lease::device() const {
  return pool_->device();
}

std::size_t Lease::resource_kinds() const {
  std::size_t kinds = 0;
  for (const auto& held : pool_->impl_->slots[static_cast<std::size_t>(index_)].resources) kinds += held.second != nullptr;
  return kinds;
}

std::unique_ptr<ContextResources>& Lease::resources_of(std::type_index type) {
  auto& held = pool_->impl_->slots[static_cast<std::size_t>(index_)].resources;
  for (auto& [kind, resources] : held)
    if (kind == type) return resources;
  return held.emplace_back(type, nullptr).second;
}

Status Lease::hold_images(std::uint64_t bytes, const std::string& what) {
  ContextPool::Impl& pool = *pool_->impl_;
  ImageMemory* memory = pool.image_memory;
  if (memory == nullptr || bytes == 0) return Status::Ok();
  if (!memory->take(bytes))
    return make_error(
        ErrorCode::kResourceExhausted,
        "gpu: " + what + " needs " + mib_text(bytes) + " of GL images, more than the memory budget leaves free now",
        "gpu");
  std::lock_guard lock(pool.taken_mutex);
  pool.slots[static_cast<std::size_t>(index_)].taken += bytes;
  return Status::Ok();
}

void Lease::fail() {
  failed_ = true;
}

}  // namespace horizon::gpu
