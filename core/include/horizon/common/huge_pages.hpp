// horizon/common/huge_pages.hpp — whether large blocks may ask for huge pages.
//
// The allocator behind every raster (large_allocator.hpp) backs a block of
// 2 MiB or more with transparent huge pages when the kernel has them to
// spare. allow_huge_pages(false) stops that for the blocks mapped after
// it, process-wide, until allowed again; blocks already mapped keep their
// pages. For a benchmark that measures the sweep on 4 KiB pages
// (tests/bench/bench_viewshed.cpp), or a program that must not hold huge
// pages. back_with_huge_pages is not affected: it is asked for by name.
#pragma once

namespace horizon {

// Whether blocks mapped from now on may ask for huge pages (initially true).
void allow_huge_pages(bool allowed) noexcept;
bool huge_pages_allowed() noexcept;

}  // namespace horizon
