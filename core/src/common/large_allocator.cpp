#include "horizon/common/large_allocator.hpp"

#include <algorithm>
#include <cstdint>

#include "horizon/common/parallel.hpp"

#if defined(__linux__)
#include <sys/mman.h>
#endif

namespace horizon::detail {
namespace {

#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)
constexpr bool kMapLargeBlocks = false;  // sanitizers must see every allocation
#elif defined(__linux__)
constexpr bool kMapLargeBlocks = true;
#else
constexpr bool kMapLargeBlocks = false;
#endif

}  // namespace

bool is_large_block(std::size_t bytes) {
  return kMapLargeBlocks && bytes >= kLargeBlockBytes;
}

#if defined(__linux__)

void* map_large_block(std::size_t bytes) {
  void* block = ::mmap(nullptr, bytes, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
  if (block == MAP_FAILED) throw std::bad_alloc();
#ifdef MADV_POPULATE_WRITE
  // Failure (an old kernel, or memory short now) leaves the pages to be
  // faulted in on first write, as for any other allocation. The kernel
  // allocates pages on the calling thread, so a big block is populated in
  // page-aligned slices on every core (48 MB: ~9 ms instead of ~16 ms here).
  constexpr std::size_t kPage = 4096, kSlice = std::size_t{16} << 20;
  const std::size_t slices = std::clamp<std::size_t>(bytes / kSlice, 1, resolve_thread_count(0));
  const std::size_t step = (bytes / slices + kPage - 1) / kPage * kPage;
  auto populate = [&](std::size_t i) {
    const std::size_t begin = i * step;
    if (begin < bytes) ::madvise(static_cast<char*>(block) + begin, std::min(step, bytes - begin), MADV_POPULATE_WRITE);
  };
  if (slices == 1) {
    populate(0);
  } else {
    parallel_for(slices, static_cast<unsigned>(slices), populate);
  }
#endif
  return block;
}

void unmap_large_block(void* block, std::size_t bytes) noexcept {
  ::munmap(block, bytes);
}

#else

void* map_large_block(std::size_t) {
  throw std::bad_alloc();
}  // never called: is_large_block is false
void unmap_large_block(void*, std::size_t) noexcept {}

#endif

}  // namespace horizon::detail

namespace horizon {

bool back_with_huge_pages(const void* block, std::size_t bytes) noexcept {
#if defined(__linux__)
  constexpr std::uintptr_t kHuge = std::uintptr_t{2} << 20;
  constexpr int kCollapse = 25;  // MADV_COLLAPSE (Linux 6.1), absent from older headers
  if (!detail::is_large_block(bytes)) return false;
  const auto begin = (reinterpret_cast<std::uintptr_t>(block) + kHuge - 1) & ~(kHuge - 1);
  const auto end = (reinterpret_cast<std::uintptr_t>(block) + bytes) & ~(kHuge - 1);
  if (end <= begin) return false;
  return ::madvise(reinterpret_cast<void*>(begin), end - begin, kCollapse) == 0;
#else
  (void)block;
  (void)bytes;
  return false;
#endif
}

}  // namespace horizon
