// tiff_predictor.hpp — undoing a TIFF predictor on decoded rows, fast.
//
// A TIFF compressed with LZW, Deflate, ZSTD or LZMA may store each row
// transformed by a predictor (TIFF 6.0 section 14; Adobe's Technical Note 3
// for the floating-point one), which libtiff undoes byte by byte after
// decompressing: each sample read back the one it just wrote, a chain of
// store-to-load waits. That was most of the time spent reading a Float32
// DEM. The reader (geotiff_reader.cpp) turns libtiff's predictor off on its
// handles and undoes it here, on the rows it converts, with a running sum
// kept in registers (and SSE2 lanes for bytes and 16-bit samples):
//
//   * horizontal (2): each sample is stored as its difference from the
//     previous one in the row, modulo 2^bits; undone by a prefix sum.
//   * floating point (3): the row's samples were split into byte planes,
//     most significant byte first, and the whole plane sequence then
//     differenced byte by byte; undone by a byte prefix sum over the row,
//     then the planes interleaved back into native (little-endian) samples.
//
// Only rows of one sample per pixel (or one plane of separate planes), in
// the host's byte order, come here (predictor_is_ours()); libtiff keeps the
// rest. The results are bit for bit libtiff's (tests/terrain/test_tiff_predictor.cpp).
#pragma once

#include <cstddef>
#include <cstdint>

namespace horizon::terrain::detail {

// Whether the reader undoes `predictor` itself: horizontal over 8-, 16-,
// 32- or 64-bit samples, or floating point over 32- or 64-bit ones, one
// sample per pixel row, a little-endian file on a little-endian host.
bool predictor_is_ours(std::uint16_t predictor, int bits, int samples_per_row_pixel, bool byte_swapped);

// Undoes horizontal differencing in place on `count` samples of `bytes`
// (1, 2, 4 or 8) each.
void undo_horizontal(unsigned char* row, std::size_t count, int bytes);

// Undoes the floating-point predictor on a row of `count` samples of
// `bytes` (4 or 8) each: `row` holds the differenced byte planes and is
// summed in place; samples first .. first + n - 1 are written, native, to
// `out` (n * bytes bytes).
void undo_floating_point(unsigned char* row, std::size_t count, int bytes, std::size_t first, std::size_t n,
                         unsigned char* out);

}  // namespace horizon::terrain::detail
