// horizon/common/large_allocator.hpp — the allocator behind every raster.
//
// A block of 2 MiB or more is mapped on its own and, on Linux, populated
// up front (madvise MADV_POPULATE_WRITE, Linux 5.14+; older kernels ignore
// it), in slices on every core when it is big: the kernel allocates the
// block's pages in a few passes instead of taking a page fault on each
// first write, ~12,000 of them for a 12 M-cell float raster. Smaller
// blocks, and every block in sanitizer builds (which must see each
// allocation), come from operator new.
//
// Such a block is also backed by transparent huge pages (MADV_HUGEPAGE,
// the mapping aligned to 2 MiB) when the kernel hands them out on request
// (THP mode "madvise", Debian's default) and has free 2 MiB blocks enough
// for it twice over and 64 MiB more (/proc/buddyinfo, want_huge_pages):
// then no fault waits for the kernel to compact memory (asked for with
// fragmented memory, 3 of 11 whole viewsheds once took 1.0-1.1 s instead
// of 0.35 s). Mode "always" backs blocks unasked; in "never" asking does
// nothing. Huge pages matter most on a VM whose hypervisor builds its own
// page tables (shadow paging, such as PVM): there each 4 KiB page costs a
// trip to the hypervisor on first touch even after the kernel populated
// it, ~1.3 ms per MB (a 12 M-cell float raster: ~60 ms), against ~1.4 ms
// for the whole raster on huge pages (docs/benchmarks.md). On a VM whose
// kernel reports free memory to its host (virtio-balloon page reporting),
// a huge page freed more than ~2 s earlier is faulted back in from the
// host, and a run that allocates then pays that: on the Intel Xeon VM, 7
// of 25 runs took 5-15 ms longer; on the AMD EPYC PVM such a run costs what
// 4 KiB pages cost every time.
#pragma once

#include <cstddef>
#include <limits>
#include <new>
#include <string_view>
#include <type_traits>
#include <utility>

namespace horizon {

namespace detail {
inline constexpr std::size_t kLargeBlockBytes = std::size_t{2} << 20;
inline constexpr std::size_t kHugePageBytes = std::size_t{2} << 20;
// Whether a block of `bytes` is mapped (large) rather than taken from operator new.
bool is_large_block(std::size_t bytes);
// Whether to ask for huge pages for a block of `bytes`, from the texts of
// /sys/kernel/mm/transparent_hugepage/enabled and /proc/buddyinfo: only in
// mode "madvise", and only while the free 2 MiB blocks number twice the
// block's and 32 more.
bool want_huge_pages(std::string_view thp_mode, std::string_view buddyinfo, std::size_t bytes);
// A zeroed, page-aligned block of `bytes`, its pages allocated; throws std::bad_alloc.
void* map_large_block(std::size_t bytes);
void unmap_large_block(void* block, std::size_t bytes) noexcept;
}  // namespace detail

// For a large block a caller keeps and reuses for many runs (a daemon
// worker's Workspace, visibility/plan.hpp): asks the kernel to back it with
// 2 MiB pages now (madvise MADV_COLLAPSE, Linux 6.1+, whatever the THP
// mode), where the allocator did not (memory fragmented then, or mode
// "never"), so that reads that stride across rows (the east and west
// sectors of the radial sweep read a new row at every sample) stop missing
// the TLB: 6-8 % off the sweep in steady state (docs/benchmarks.md). A
// collapse copies: the first of 48 MB took 13-18 ms on the Intel Xeon, and
// up to 140 ms on a VM that had handed the memory back to its host; a block
// already backed costs microseconds. True when the whole 2 MiB-aligned
// part of the block is backed; false (and nothing changed) for a small
// block, a sanitizer build, a kernel without MADV_COLLAPSE, or memory short.
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
