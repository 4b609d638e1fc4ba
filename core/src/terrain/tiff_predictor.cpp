// tiff_predictor.cpp — TIFF predictors undone with register sums (see tiff_predictor.hpp).
#include "tiff_predictor.hpp"

#include <bit>
#include <cstring>

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

namespace horizon::terrain::detail {
namespace {

// A prefix sum modulo 2^(8 sizeof(T)), the running value in a register.
template <class T>
void prefix_sum(unsigned char* p, std::size_t count) {
  T acc = 0;
  for (std::size_t i = 0; i < count; ++i) {
    T v;
    std::memcpy(&v, p + i * sizeof(T), sizeof(T));
    acc = static_cast<T>(acc + v);
    std::memcpy(p + i * sizeof(T), &acc, sizeof(T));
  }
}

#if defined(__SSE2__)
// 16 bytes at a time: a log-step sum inside the lanes, then the previous
// block's last byte added to every lane.
void prefix_sum_bytes(unsigned char* p, std::size_t count) {
  __m128i carry = _mm_setzero_si128();
  std::size_t i = 0;
  for (; i + 16 <= count; i += 16) {
    __m128i x = _mm_loadu_si128(reinterpret_cast<const __m128i*>(p + i));
    x = _mm_add_epi8(x, _mm_slli_si128(x, 1));
    x = _mm_add_epi8(x, _mm_slli_si128(x, 2));
    x = _mm_add_epi8(x, _mm_slli_si128(x, 4));
    x = _mm_add_epi8(x, _mm_slli_si128(x, 8));
    x = _mm_add_epi8(x, carry);
    _mm_storeu_si128(reinterpret_cast<__m128i*>(p + i), x);
    // Byte 15 to every lane.
    __m128i last = _mm_srli_si128(x, 15);
    last = _mm_unpacklo_epi8(last, last);
    last = _mm_unpacklo_epi16(last, last);
    carry = _mm_shuffle_epi32(last, 0);
  }
  unsigned char acc = i ? p[i - 1] : 0;
  for (; i < count; ++i) p[i] = acc = static_cast<unsigned char>(acc + p[i]);
}

// 8 samples of 16 bits at a time, as above.
void prefix_sum_u16(unsigned char* p, std::size_t count) {
  __m128i carry = _mm_setzero_si128();
  std::size_t i = 0;
  for (; i + 8 <= count; i += 8) {
    __m128i x = _mm_loadu_si128(reinterpret_cast<const __m128i*>(p + 2 * i));
    x = _mm_add_epi16(x, _mm_slli_si128(x, 2));
    x = _mm_add_epi16(x, _mm_slli_si128(x, 4));
    x = _mm_add_epi16(x, _mm_slli_si128(x, 8));
    x = _mm_add_epi16(x, carry);
    _mm_storeu_si128(reinterpret_cast<__m128i*>(p + 2 * i), x);
    const __m128i high = _mm_shufflehi_epi16(x, 0xFF);  // lanes 4-7 = lane 7
    carry = _mm_unpackhi_epi64(high, high);
  }
  std::uint16_t acc = 0;
  if (i) std::memcpy(&acc, p + 2 * (i - 1), 2);
  for (; i < count; ++i) {
    std::uint16_t v;
    std::memcpy(&v, p + 2 * i, 2);
    acc = static_cast<std::uint16_t>(acc + v);
    std::memcpy(p + 2 * i, &acc, 2);
  }
}
#else
void prefix_sum_bytes(unsigned char* p, std::size_t count) {
  prefix_sum<std::uint8_t>(p, count);
}
void prefix_sum_u16(unsigned char* p, std::size_t count) {
  prefix_sum<std::uint16_t>(p, count);
}
#endif

// Planes (most significant first, `count` bytes each) back into samples of
// 4 bytes, little-endian: sample i's byte b is plane (3 - b)'s byte i.
void interleave4(const unsigned char* planes, std::size_t count, std::size_t first, std::size_t n, unsigned char* out) {
  const unsigned char* p0 = planes + first;  // most significant
  const unsigned char* p1 = p0 + count;
  const unsigned char* p2 = p1 + count;
  const unsigned char* p3 = p2 + count;  // least significant
  std::size_t i = 0;
#if defined(__SSE2__)
  for (; i + 16 <= n; i += 16) {
    const __m128i b0 = _mm_loadu_si128(reinterpret_cast<const __m128i*>(p0 + i));
    const __m128i b1 = _mm_loadu_si128(reinterpret_cast<const __m128i*>(p1 + i));
    const __m128i b2 = _mm_loadu_si128(reinterpret_cast<const __m128i*>(p2 + i));
    const __m128i b3 = _mm_loadu_si128(reinterpret_cast<const __m128i*>(p3 + i));
    const __m128i low_lo = _mm_unpacklo_epi8(b3, b2), low_hi = _mm_unpackhi_epi8(b3, b2);    // bytes 0, 1
    const __m128i high_lo = _mm_unpacklo_epi8(b1, b0), high_hi = _mm_unpackhi_epi8(b1, b0);  // bytes 2, 3
    __m128i* o = reinterpret_cast<__m128i*>(out + 4 * i);
    _mm_storeu_si128(o + 0, _mm_unpacklo_epi16(low_lo, high_lo));
    _mm_storeu_si128(o + 1, _mm_unpackhi_epi16(low_lo, high_lo));
    _mm_storeu_si128(o + 2, _mm_unpacklo_epi16(low_hi, high_hi));
    _mm_storeu_si128(o + 3, _mm_unpackhi_epi16(low_hi, high_hi));
  }
#endif
  for (; i < n; ++i) {
    unsigned char* o = out + 4 * i;
    o[0] = p3[i];
    o[1] = p2[i];
    o[2] = p1[i];
    o[3] = p0[i];
  }
}

}  // namespace

bool predictor_is_ours(std::uint16_t predictor, int bits, int samples_per_row_pixel, bool byte_swapped) {
  if (byte_swapped || samples_per_row_pixel != 1 || std::endian::native != std::endian::little) return false;
  if (predictor == 2) return bits == 8 || bits == 16 || bits == 32 || bits == 64;
  if (predictor == 3) return bits == 32 || bits == 64;
  return false;
}

void undo_horizontal(unsigned char* row, std::size_t count, int bytes) {
  switch (bytes) {
    case 1:
      return prefix_sum_bytes(row, count);
    case 2:
      return prefix_sum_u16(row, count);
    case 4:
      return prefix_sum<std::uint32_t>(row, count);
    case 8:
      return prefix_sum<std::uint64_t>(row, count);
    default:
      return;
  }
}

void undo_floating_point(unsigned char* row, std::size_t count, int bytes, std::size_t first, std::size_t n,
                         unsigned char* out) {
  const auto b = static_cast<std::size_t>(bytes);
  prefix_sum_bytes(row, count * b);
  if (b == 4) return interleave4(row, count, first, n, out);
  for (std::size_t i = 0; i < n; ++i)
    for (std::size_t k = 0; k < b; ++k) out[i * b + k] = row[(b - 1 - k) * count + first + i];
}

}  // namespace horizon::terrain::detail
