#include "horizon/common/large_allocator.hpp"

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
  // faulted in on first write, as for any other allocation.
  ::madvise(block, bytes, MADV_POPULATE_WRITE);
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
