// horizon/common/large_allocator.hpp — the allocator behind every raster.
//
// A block of 2 MiB or more is mapped on its own and, on Linux, populated
// up front (madvise MADV_POPULATE_WRITE, Linux 5.14+; older kernels ignore
// it), in slices on every core when it is big: the kernel allocates the
// block's pages in a few passes instead of taking a page fault on each
// first write, ~12,000 of them for a 12 M-cell float raster. Smaller blocks, and every block in sanitizer builds (which
// must see each allocation), come from operator new.
//
// Transparent huge pages (MADV_HUGEPAGE) were measured as well: 10-15 %
// faster sweeps, but with the kernel's usual "defrag=madvise" a fault may
// wait for memory compaction, and 3 of 11 whole `horizon viewshed` runs took
// 1.0-1.1 s instead of 0.35 s. Asked for only when /proc/buddyinfo showed
// free 2 MiB blocks to spare, the median read and sweep got 20 % faster, but
// on a VM whose kernel reports free memory to its host (virtio-balloon page
// reporting), of 25 runs 8 took 4-15 ms longer in the sweep and 5 in the
// read, the phases that allocate. A viewshed must not stall like that, so they
// are not asked for here; a caller that keeps a block for many runs asks once
// (back_with_huge_pages, below).
#pragma once

#include <cstddef>
#include <limits>
#include <new>
#include <type_traits>
#include <utility>

namespace horizon {

namespace detail {
inline constexpr std::size_t kLargeBlockBytes = std::size_t{2} << 20;
// Whether a block of `bytes` is mapped (large) rather than taken from operator new.
bool is_large_block(std::size_t bytes);
// A zeroed, page-aligned block of `bytes`, its pages allocated; throws std::bad_alloc.
void* map_large_block(std::size_t bytes);
void unmap_large_block(void* block, std::size_t bytes) noexcept;
}  // namespace detail

// For a large block a caller keeps and reuses for many runs (a daemon
// worker's Workspace, visibility/plan.hpp): asks the kernel to back it with
// 2 MiB pages now (madvise MADV_COLLAPSE, Linux 6.1+), so that reads that
// stride across rows (the east and west sectors of the radial sweep read a
// new row at every sample) stop missing the TLB: 6-8 % off the sweep in
// steady state (docs/benchmarks.md). Not for one-shot rasters: the first
// collapse of 48 MB took 13-18 ms here, and up to 140 ms on a VM that had
// handed the memory back to its host (the reason the allocator never asks
// for huge pages itself, above). Once backed, asking again costs
// microseconds. True when the whole 2 MiB-aligned part of the block is
// backed; false (and nothing changed) for a small block, a sanitizer build,
// a kernel without MADV_COLLAPSE, or memory short.
bool back_with_huge_pages(const void* block, std::size_t bytes) noexcept;

template <class T>
struct LargeAllocator {
  using value_type = T;

  LargeAllocator() noexcept = default;
  template <class U>
  LargeAllocator(const LargeAllocator<U>&) noexcept {}

  T* allocate(std::size_t n) {
    if (n > std::numeric_limits<std::size_t>::max() / sizeof(T)) throw std::bad_array_new_length();
    const std::size_t bytes = n * sizeof(T);
    if (detail::is_large_block(bytes)) return static_cast<T*>(detail::map_large_block(bytes));
    return static_cast<T*>(::operator new (bytes, std::align_val_t{alignof(T)}));
  }

  void deallocate(T* p, std::size_t n) noexcept {
    const std::size_t bytes = n * sizeof(T);
    if (detail::is_large_block(bytes)) {
      detail::unmap_large_block(p, bytes);
    } else {
      ::operator delete (p, std::align_val_t{alignof(T)});
    }
  }

  // A value-less construct default-initialises (a float is left as the
  // memory holds it), so a container sized without a value does not write
  // every element first; terrain::Grid only does that when asked
  // (terrain::kUninitialized), for rasters the caller then fills whole.
  template <class U>
  void construct(U* p) noexcept(std::is_nothrow_default_constructible_v<U>) {
    ::new (static_cast<void*>(p)) U;
  }
  template <class U, class... Args>
  void construct(U* p, Args&&... args) {
    ::new (static_cast<void*>(p)) U(std::forward<Args>(args)...);
  }

  template <class U>
  friend bool operator==(const LargeAllocator&, const LargeAllocator<U>&) noexcept {
    return true;
  }
};

}  // namespace horizon
