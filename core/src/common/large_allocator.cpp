#include "horizon/common/large_allocator.hpp"

#include <algorithm>
#include <atomic>
#include <cstdint>
#include <string>
#include <string_view>

#include "horizon/common/huge_pages.hpp"
#include "horizon/common/parallel.hpp"

#if defined(__linux__)
#include <fcntl.h>
#include <sys/mman.h>
#include <unistd.h>
#endif

namespace horizon {
namespace {

std::atomic<bool> g_huge_pages_allowed{true};

}  // namespace

void allow_huge_pages(bool allowed) noexcept {
  g_huge_pages_allowed.store(allowed, std::memory_order_relaxed);
}

bool huge_pages_allowed() noexcept {
  return g_huge_pages_allowed.load(std::memory_order_relaxed);
}

}  // namespace horizon

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

bool want_huge_pages(std::string_view thp_mode, std::string_view buddyinfo, std::size_t bytes) {
  if (thp_mode.find("[madvise]") == std::string_view::npos) return false;
  constexpr int kHugeOrder = 9;  // 2 MiB of 4 KiB pages
  constexpr std::size_t kReserve = 32;
  // "Node 0, zone   Normal  16941   9822 ...": the free blocks of order 0,
  // 1, ... after the zone's name, for every zone of every node.
  std::size_t free_huge = 0;
  while (!buddyinfo.empty()) {
    const std::size_t eol = buddyinfo.find('\n');
    std::string_view line = buddyinfo.substr(0, eol);
    buddyinfo = eol == std::string_view::npos ? std::string_view() : buddyinfo.substr(eol + 1);
    const std::size_t zone = line.find("zone");
    if (zone == std::string_view::npos) continue;
    line.remove_prefix(zone + 4);
    int field = -1;  // -1: the zone's name
    for (std::size_t i = 0; i < line.size();) {
      if (line[i] == ' ' || line[i] == '\t') {
        ++i;
        continue;
      }
      std::size_t count = 0;
      bool digits = true;
      const std::size_t start = i;
      for (; i < line.size() && line[i] != ' ' && line[i] != '\t'; ++i) {
        digits = digits && line[i] >= '0' && line[i] <= '9';
        if (digits) count = count * 10 + static_cast<std::size_t>(line[i] - '0');
      }
      if (field >= kHugeOrder && digits && i > start && field - kHugeOrder < 20)
        free_huge += count << (field - kHugeOrder);
      ++field;
    }
  }
  const std::size_t needed = (bytes + kHugePageBytes - 1) / kHugePageBytes;
  return free_huge >= 2 * needed + kReserve;
}

#if defined(__linux__)

namespace {

// A small kernel text file whole, empty when it cannot be read.
std::string_view read_text(const char* path, char* buffer, std::size_t size) {
  const int fd = ::open(path, O_RDONLY | O_CLOEXEC);
  if (fd < 0) return {};
  std::size_t got = 0;
  for (ssize_t n; got < size && (n = ::read(fd, buffer + got, size - got)) > 0;) got += static_cast<std::size_t>(n);
  ::close(fd);
  return {buffer, got};
}

bool huge_pages_for(std::size_t bytes) {
  if (!huge_pages_allowed()) return false;
  // The mode is set at boot or by an administrator: read once.
  static const std::string mode = [] {
    char text[256];
    return std::string(read_text("/sys/kernel/mm/transparent_hugepage/enabled", text, sizeof text));
  }();
  if (mode.find("[madvise]") == std::string::npos) return false;
  char buddyinfo[16384];  // a line per zone and node: tens of lines
  return want_huge_pages(mode, read_text("/proc/buddyinfo", buddyinfo, sizeof buddyinfo), bytes);
}

}  // namespace

void* map_large_block(std::size_t bytes) {
  constexpr std::size_t kPage = 4096;
  const bool huge = huge_pages_for(bytes);
  // For huge pages the block starts on a 2 MiB boundary: mapped 2 MiB
  // larger, the ends around the aligned block unmapped again.
  const std::size_t mapped = huge ? bytes + kHugePageBytes : bytes;
  void* raw = ::mmap(nullptr, mapped, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
  if (raw == MAP_FAILED) throw std::bad_alloc();
  void* block = raw;
  if (huge) {
    const auto at = reinterpret_cast<std::uintptr_t>(raw);
    const std::uintptr_t aligned = (at + kHugePageBytes - 1) / kHugePageBytes * kHugePageBytes;
    const std::uintptr_t end = aligned + (bytes + kPage - 1) / kPage * kPage;
    if (aligned > at) ::munmap(raw, aligned - at);
    if (at + mapped > end) ::munmap(reinterpret_cast<void*>(end), at + mapped - end);
    block = reinterpret_cast<void*>(aligned);
    ::madvise(block, bytes, MADV_HUGEPAGE);  // a failure leaves small pages
  }
#ifdef MADV_POPULATE_WRITE
  // Failure (an old kernel, or memory short now) leaves the pages to be
  // faulted in on first write, as for any other allocation. The kernel
  // allocates pages on the calling thread, so a big block is populated in
  // slices on every core (48 MB of 4 KiB pages: ~9 ms instead of ~16 ms on
  // the Intel Xeon), each slice whole pages of the block's size.
  constexpr std::size_t kSlice = std::size_t{16} << 20;
  const std::size_t unit = huge ? kHugePageBytes : kPage;
  const std::size_t slices = std::clamp<std::size_t>(bytes / kSlice, 1, resolve_thread_count(0));
  const std::size_t step = (bytes / slices + unit - 1) / unit * unit;
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
