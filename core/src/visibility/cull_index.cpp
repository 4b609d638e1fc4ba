// Box culling against a full-resolution min-pyramid (cull_index.hpp): the
// index's levels, the batch's Z-order, and the box test in three forms
// (scalar, AVX2, AVX-512) that give the same bits.
#include "horizon/visibility/cull_index.hpp"

#include <algorithm>
#include <cassert>
#include <cmath>
#include <cstring>
#include <limits>
#include <numeric>
#include <utility>

#include "horizon/common/parallel.hpp"
#include "simd.hpp"

namespace horizon::visibility {
namespace {

namespace simd = sweep::simd;

constexpr float kInf = std::numeric_limits<float>::infinity();

// floor(log2 m) for m >= 1.
int floor_log2(std::uint32_t m) {
  return 31 - __builtin_clz(m);
}

// Rows per parallel item when building a level (coarse work items).
constexpr int kRowsPerItem = 64;

// Spreads the low 32 bits of v to the even bits of the result.
std::uint64_t spread_bits(std::uint64_t v) {
  v &= 0xffffffffull;
  v = (v | (v << 16)) & 0x0000ffff0000ffffull;
  v = (v | (v << 8)) & 0x00ff00ff00ff00ffull;
  v = (v | (v << 4)) & 0x0f0f0f0f0f0f0f0full;
  v = (v | (v << 2)) & 0x3333333333333333ull;
  v = (v | (v << 1)) & 0x5555555555555555ull;
  return v;
}

// The largest float not above d (d finite).
float float_at_or_below(double d) {
  float f = static_cast<float>(d);
  if (static_cast<double>(f) > d) f = std::nextafter(f, -kInf);
  return f;
}

// One box's square: its level and side, and whether four reads cover it.
struct Square {
  int k, side;
  bool four;
};

Square square_for(int w, int h, int levels) {
  const int k = std::min(floor_log2(static_cast<std::uint32_t>(std::min(w, h))), levels - 1);
  const int s = 1 << k;
  return {k, s, w <= 2 * s && h <= 2 * s};
}

// The scalar test of one box (sorted position i); the vector kernels'
// lanes compute exactly this. Returns the least OHF, -inf for a footprint
// (partly) outside the index.
float test_box(const CullIndex& index, const BoxBatch& b, std::size_t i, BatchStats& stats) {
  const terrain::Window& win = index.window();
  const int c0 = b.col0[i] - win.col0, r0 = b.row0[i] - win.row0;
  const int c1 = b.col1[i] - win.col0, r1 = b.row1[i] - win.row0;
  if (c0 < 0 || r0 < 0 || c1 > index.width() || r1 > index.height() || c1 <= c0 || r1 <= r0) {
    ++stats.outside;
    return -kInf;
  }
  const Square sq = square_for(c1 - c0, r1 - r0, index.levels());
  if (!sq.four) return index.min_in(c0, r0, c1, r1, &stats.reads);
  const float* level = index.level(sq.k);
  const std::size_t w = static_cast<std::size_t>(index.width());
  const std::size_t ra = static_cast<std::size_t>(r0) * w, rc = static_cast<std::size_t>(r1 - sq.side) * w;
  const std::size_t ca = static_cast<std::size_t>(c0), cb = static_cast<std::size_t>(c1 - sq.side);
  float m = kInf;
  for (const std::size_t k : {ra + ca, ra + cb, rc + ca, rc + cb}) m = std::min(m, level[k]);
  stats.reads += 4;
  ++stats.vector_boxes;
  return m;
}

void answer(BoxVisibility& out, float ohf_min, float threshold) {
  out = {ohf_min <= threshold ? Visibility::kSeen : Visibility::kOccluded, ohf_min};
}

// A box whose least OHF read -inf (rare: off the map, outside the index, a
// void, or the eye's own cell), answered as cull_footprints answers it.
void settle(const CullIndex& index, const BoxBatch& b, std::size_t i, BoxVisibility& out, BatchStats& stats) {
  if (!b.on_map[i]) {
    out = {Visibility::kOutOfRange, -kInf};
    return;
  }
  out = {Visibility::kSeen, -kInf};
  const terrain::Window& win = index.window();
  const int c0 = b.col0[i] - win.col0, r0 = b.row0[i] - win.row0;
  const int c1 = b.col1[i] - win.col0, r1 = b.row1[i] - win.row0;
  if (!index.has_voids() || c0 < 0 || r0 < 0 || c1 > index.width() || r1 > index.height() || c1 <= c0 || r1 <= r0)
    return;
  // The least over the cells that have an OHF: -inf there is a real value
  // (the eye's cell), seen; otherwise the box meets a void, and is seen only
  // if the known cells let it be.
  const float least = index.known_min_in(c0, r0, c1, r1, &stats.reads);
  if (least == -kInf) return;
  out = {least <= b.threshold[i] ? Visibility::kSeen : Visibility::kUndetermined, least == kInf ? -kInf : least};
}

#ifdef HORIZON_SIMD_AVX2

// What a vector kernel leaves for the lanes it could not answer.
struct LaneMasks {
  unsigned outside = 0;   // footprint (partly) outside the index: -inf
  unsigned deferred = 0;  // more than four reads: left to the scalar loop
};

// v[i .. i + 8) - origin: DEM cells to index cells.
HORIZON_AVX2 inline __m256i local8(const std::vector<std::int32_t>& v, std::size_t i, int origin) {
  return _mm256_sub_epi32(_mm256_loadu_si256(reinterpret_cast<const __m256i*>(v.data() + i)), simd::i8(origin));
}
HORIZON_AVX512 inline __m512i local16(const std::vector<std::int32_t>& v, std::size_t i, int origin) {
  return _mm512_sub_epi32(_mm512_loadu_si512(v.data() + i), simd::i16(origin));
}

// Eight boxes from sorted position i: the least OHF of each lane into ohf[].
HORIZON_AVX2 void test8(const CullIndex& index, const BoxBatch& b, std::size_t i, float* ohf, LaneMasks& lanes) {
  const terrain::Window& win = index.window();
  const __m256i c0 = local8(b.col0, i, win.col0), r0 = local8(b.row0, i, win.row0);
  const __m256i c1 = local8(b.col1, i, win.col0), r1 = local8(b.row1, i, win.row0);
  const __m256i zero = _mm256_setzero_si256(), one = simd::i8(1);
  const __m256i w = _mm256_sub_epi32(c1, c0), h = _mm256_sub_epi32(r1, r0);
  // Outside: c0 < 0, r0 < 0, c1 > width, r1 > height, or empty.
  __m256i outside = _mm256_or_si256(_mm256_cmpgt_epi32(zero, c0), _mm256_cmpgt_epi32(zero, r0));
  outside = _mm256_or_si256(outside, _mm256_cmpgt_epi32(c1, simd::i8(index.width())));
  outside = _mm256_or_si256(outside, _mm256_cmpgt_epi32(r1, simd::i8(index.height())));
  outside = _mm256_or_si256(outside, _mm256_cmpgt_epi32(one, w));
  outside = _mm256_or_si256(outside, _mm256_cmpgt_epi32(one, h));
  // k = min(floor(log2 min(w, h)), levels - 1) from the float's exponent:
  // exact below 2^24, and above it the conversion's rounding is clamped away
  // (levels - 1 <= 4). Outside lanes compute nonsense that is never read.
  const __m256i m = _mm256_max_epi32(simd::mini_of(w, h), one);
  __m256i k = _mm256_sub_epi32(_mm256_srli_epi32(_mm256_castps_si256(_mm256_cvtepi32_ps(m)), 23), simd::i8(127));
  k = simd::mini_of(k, simd::i8(index.levels() - 1));
  const __m256i s = _mm256_sllv_epi32(one, k), s2 = _mm256_add_epi32(s, s);
  const __m256i many = _mm256_or_si256(_mm256_cmpgt_epi32(w, s2), _mm256_cmpgt_epi32(h, s2));
  const __m256i four = _mm256_andnot_si256(_mm256_or_si256(outside, many), simd::i8(-1));
  const __m256i width = simd::i8(index.width());
  const __m256i base = _mm256_mullo_epi32(k, simd::i8(static_cast<int>(index.plane())));
  const __m256i ra = _mm256_add_epi32(base, _mm256_mullo_epi32(r0, width));
  const __m256i rc = _mm256_add_epi32(base, _mm256_mullo_epi32(_mm256_sub_epi32(r1, s), width));
  const __m256i cb = _mm256_sub_epi32(c1, s);
  const __m256 mask = _mm256_castsi256_ps(four);
  const float* values = index.level(0);
  __m256 least = simd::f8(kInf);
  least = simd::min_of(least, simd::gather_masked(values, _mm256_add_epi32(ra, c0), mask));
  least = simd::min_of(least, simd::gather_masked(values, _mm256_add_epi32(ra, cb), mask));
  least = simd::min_of(least, simd::gather_masked(values, _mm256_add_epi32(rc, c0), mask));
  least = simd::min_of(least, simd::gather_masked(values, _mm256_add_epi32(rc, cb), mask));
  least = _mm256_blendv_ps(least, simd::f8(-kInf), _mm256_castsi256_ps(outside));
  _mm256_storeu_ps(ohf, least);
  lanes.outside = static_cast<unsigned>(_mm256_movemask_ps(_mm256_castsi256_ps(outside)));
  lanes.deferred = static_cast<unsigned>(_mm256_movemask_ps(_mm256_castsi256_ps(many))) & ~lanes.outside;
}

// The same on sixteen boxes.
HORIZON_AVX512 void test16(const CullIndex& index, const BoxBatch& b, std::size_t i, float* ohf, LaneMasks& lanes) {
  const terrain::Window& win = index.window();
  const __m512i c0 = local16(b.col0, i, win.col0), r0 = local16(b.row0, i, win.row0);
  const __m512i c1 = local16(b.col1, i, win.col0), r1 = local16(b.row1, i, win.row0);
  const __m512i zero = _mm512_setzero_si512(), one = simd::i16(1);
  const __m512i w = _mm512_sub_epi32(c1, c0), h = _mm512_sub_epi32(r1, r0);
  const __mmask16 outside = _mm512_cmplt_epi32_mask(c0, zero) | _mm512_cmplt_epi32_mask(r0, zero) |
                            _mm512_cmpgt_epi32_mask(c1, simd::i16(index.width())) |
                            _mm512_cmpgt_epi32_mask(r1, simd::i16(index.height())) | _mm512_cmplt_epi32_mask(w, one) |
                            _mm512_cmplt_epi32_mask(h, one);
  const __m512i m = _mm512_max_epi32(simd::mini_of(w, h), one);
  __m512i k = _mm512_sub_epi32(_mm512_srli_epi32(_mm512_castps_si512(_mm512_cvtepi32_ps(m)), 23), simd::i16(127));
  k = simd::mini_of(k, simd::i16(index.levels() - 1));
  const __m512i s = _mm512_sllv_epi32(one, k), s2 = _mm512_add_epi32(s, s);
  const __mmask16 many = _mm512_cmpgt_epi32_mask(w, s2) | _mm512_cmpgt_epi32_mask(h, s2);
  const __mmask16 four = static_cast<__mmask16>(~(outside | many));
  const __m512i width = simd::i16(index.width());
  const __m512i base = _mm512_mullo_epi32(k, simd::i16(static_cast<int>(index.plane())));
  const __m512i ra = _mm512_add_epi32(base, _mm512_mullo_epi32(r0, width));
  const __m512i rc = _mm512_add_epi32(base, _mm512_mullo_epi32(_mm512_sub_epi32(r1, s), width));
  const __m512i cb = _mm512_sub_epi32(c1, s);
  const float* values = index.level(0);
  __m512 least = simd::f16(kInf);
  least = simd::min_of(least, simd::gather_masked(values, _mm512_add_epi32(ra, c0), four));
  least = simd::min_of(least, simd::gather_masked(values, _mm512_add_epi32(ra, cb), four));
  least = simd::min_of(least, simd::gather_masked(values, _mm512_add_epi32(rc, c0), four));
  least = simd::min_of(least, simd::gather_masked(values, _mm512_add_epi32(rc, cb), four));
  least = _mm512_mask_blend_ps(outside, least, simd::f16(-kInf));
  _mm512_storeu_ps(ohf, least);
  lanes.outside = outside;
  lanes.deferred = static_cast<unsigned>(many & static_cast<__mmask16>(~outside));
}

#endif

}  // namespace

namespace {

// Fills `values` (levels planes of w x h) from `ohf`, NaN read as `void_value`.
void build_levels(const terrain::Grid<float>& ohf, float void_value, int levels, unsigned threads,
                  std::vector<float, LargeAllocator<float>>& values) {
  const int width = ohf.width(), height = ohf.height();
  const std::size_t w = static_cast<std::size_t>(width);
  const std::size_t plane = w * static_cast<std::size_t>(height);
  values.resize(plane * static_cast<std::size_t>(levels));
  if (plane == 0) return;
  const std::size_t items = (static_cast<std::size_t>(height) + kRowsPerItem - 1) / kRowsPerItem;
  parallel_for(items, threads, [&](std::size_t item) {
    const int r_end = std::min(height, static_cast<int>((item + 1) * kRowsPerItem));
    for (int r = static_cast<int>(item) * kRowsPerItem; r < r_end; ++r) {
      const float* in = &ohf.at(0, r);
      float* out = values.data() + static_cast<std::size_t>(r) * w;
      for (std::size_t c = 0; c < w; ++c) out[c] = in[c] == in[c] ? in[c] : void_value;
    }
  });
  for (int k = 1; k < levels; ++k) {
    const int half = 1 << (k - 1);
    const float* prev = values.data() + static_cast<std::size_t>(k - 1) * plane;
    float* cur = values.data() + static_cast<std::size_t>(k) * plane;
    parallel_for(items, threads, [&](std::size_t item) {
      const int r_end = std::min(height, static_cast<int>((item + 1) * kRowsPerItem));
      for (int r = static_cast<int>(item) * kRowsPerItem; r < r_end; ++r) {
        // Squares hanging over the east or south edge take the last cell
        // there, which is inside them: still the minimum of their clipped part.
        const float* a = prev + static_cast<std::size_t>(r) * w;
        const float* b = prev + static_cast<std::size_t>(std::min(r + half, height - 1)) * w;
        float* out = cur + static_cast<std::size_t>(r) * w;
        const int split = std::max(0, width - half);
        for (int c = 0; c < split; ++c) out[c] = std::min(std::min(a[c], a[c + half]), std::min(b[c], b[c + half]));
        for (int c = split; c < width; ++c)
          out[c] = std::min(std::min(a[c], a[width - 1]), std::min(b[c], b[width - 1]));
      }
    });
  }
}

bool has_nan(const terrain::Grid<float>& g) {
  for (int r = 0; r < g.height(); ++r) {
    const float* row = &g.at(0, r);
    for (int c = 0; c < g.width(); ++c)
      if (row[c] != row[c]) return true;
  }
  return false;
}

}  // namespace

CullIndex::CullIndex(const terrain::Grid<float>& ohf, const terrain::Window& window, int levels, unsigned threads)
    : window_(window),
      width_(ohf.width()),
      height_(ohf.height()),
      levels_(std::clamp(levels, 1, kMaxLevels)),
      plane_(static_cast<std::size_t>(ohf.width()) * static_cast<std::size_t>(ohf.height())) {
  build_levels(ohf, -kInf, levels_, threads, values_);
  if (plane_ != 0 && has_nan(ohf)) build_levels(ohf, kInf, levels_, threads, known_);
  // Aligned blocks of level 0 (voids -inf), for the groups' test.
  block_cols_ = (width_ + kBlock - 1) / kBlock;
  const int block_rows = (height_ + kBlock - 1) / kBlock;
  blocks_.assign(static_cast<std::size_t>(block_cols_) * static_cast<std::size_t>(block_rows), kInf);
  const float* cells = values_.data();
  for (int r = 0; r < height_; ++r) {
    float* out = blocks_.data() + static_cast<std::size_t>(r / kBlock) * static_cast<std::size_t>(block_cols_);
    const float* in = cells + static_cast<std::size_t>(r) * static_cast<std::size_t>(width_);
    for (int c = 0; c < width_; ++c) out[c / kBlock] = std::min(out[c / kBlock], in[c]);
  }
}

float CullIndex::block_min_over(int col0, int row0, int col1, int row1, std::uint64_t* reads) const {
  assert(col0 >= 0 && row0 >= 0 && col1 <= width_ && row1 <= height_ && col0 < col1 && row0 < row1);
  const int b0 = col0 / kBlock, b1 = (col1 - 1) / kBlock;
  float m = kInf;
  for (int r = row0 / kBlock; r <= (row1 - 1) / kBlock; ++r) {
    const float* row = blocks_.data() + static_cast<std::size_t>(r) * static_cast<std::size_t>(block_cols_);
    for (int c = b0; c <= b1; ++c) m = std::min(m, row[c]);
  }
  if (reads) *reads += static_cast<std::uint64_t>((b1 - b0 + 1) * ((row1 - 1) / kBlock - row0 / kBlock + 1));
  return m;
}

int CullIndex::levels_for(std::span<const BoxFootprint> footprints) {
  int k = 0;
  for (const BoxFootprint& f : footprints) {
    const int m = std::min(f.cells.col1 - f.cells.col0, f.cells.row1 - f.cells.row0);
    if (m >= 1) k = std::max(k, floor_log2(static_cast<std::uint32_t>(m)));
  }
  return std::min(k + 1, kMaxLevels);
}

std::uint64_t CullIndex::index_bytes(int width, int height, int levels, bool voids) {
  const auto cells = static_cast<std::uint64_t>(width) * static_cast<std::uint64_t>(height);
  const auto blocks = static_cast<std::uint64_t>((width + kBlock - 1) / kBlock) *
                      static_cast<std::uint64_t>((height + kBlock - 1) / kBlock);
  return (cells * static_cast<std::uint64_t>(std::clamp(levels, 1, kMaxLevels)) * (voids ? 2 : 1) + blocks) *
         sizeof(float);
}

float CullIndex::min_in(int col0, int row0, int col1, int row1, std::uint64_t* reads) const {
  return least_in(values_.data(), col0, row0, col1, row1, reads);
}

float CullIndex::known_min_in(int col0, int row0, int col1, int row1, std::uint64_t* reads) const {
  if (known_.empty()) return min_in(col0, row0, col1, row1, reads);
  return least_in(known_.data(), col0, row0, col1, row1, reads);
}

float CullIndex::least_in(const float* levels, int col0, int row0, int col1, int row1, std::uint64_t* reads) const {
  assert(col0 >= 0 && row0 >= 0 && col1 <= width_ && row1 <= height_ && col0 < col1 && row0 < row1);
  const Square sq = square_for(col1 - col0, row1 - row0, levels_);
  const float* values = levels + static_cast<std::size_t>(sq.k) * plane_;
  const std::size_t w = static_cast<std::size_t>(width_);
  float m = kInf;
  std::uint64_t n = 0;
  // Squares at s steps, the last of each row and column pulled back to end
  // at the footprint's edge.
  for (int r = row0;; r += sq.side) {
    const int rr = std::min(r, row1 - sq.side);
    for (int c = col0;; c += sq.side) {
      const int cc = std::min(c, col1 - sq.side);
      m = std::min(m, values[static_cast<std::size_t>(rr) * w + static_cast<std::size_t>(cc)]);
      ++n;
      if (cc == col1 - sq.side) break;
    }
    if (rr == row1 - sq.side) break;
  }
  if (reads) *reads += n;
  return m;
}

BoxBatch::BoxBatch(std::span<const BoxFootprint> footprints) {
  const std::size_t n = footprints.size();
  std::vector<std::pair<std::uint64_t, std::uint32_t>> keys(n);
  for (std::size_t i = 0; i < n; ++i) {
    const terrain::Window& c = footprints[i].cells;
    // Z-order of the north-west corner (cells are >= 0 in a DEM's grid).
    const bool on = footprints[i].on_map;
    const auto u = static_cast<std::uint32_t>(on ? std::max(0, c.col0) : 0);
    const auto v = static_cast<std::uint32_t>(on ? std::max(0, c.row0) : 0);
    keys[i] = {spread_bits(u) | (spread_bits(v) << 1), static_cast<std::uint32_t>(i)};
  }
  std::sort(keys.begin(), keys.end());
  col0.resize(n);
  row0.resize(n);
  col1.resize(n);
  row1.resize(n);
  threshold.resize(n);
  on_map.resize(n);
  order.resize(n);
  for (std::size_t j = 0; j < n; ++j) {
    const BoxFootprint& f = footprints[keys[j].second];
    order[j] = keys[j].second;
    on_map[j] = f.on_map;
    if (!f.on_map) {
      // An empty footprint: outside any index, and answered kOutOfRange.
      col0[j] = row0[j] = col1[j] = row1[j] = 0;
      threshold[j] = -kInf;
      continue;
    }
    col0[j] = f.cells.col0;
    row0[j] = f.cells.row0;
    col1[j] = f.cells.col1;
    row1[j] = f.cells.row1;
    threshold[j] = float_at_or_below(f.z_max + kTieTolerance);
  }
  // Groups of kGroup neighbours in Z order whose rectangle is small enough to try.
  for (std::size_t g = 0; g + kGroup <= n; g += kGroup) {
    std::int32_t c0 = col0[g], r0 = row0[g], c1 = col1[g], r1 = row1[g];
    float t = threshold[g];
    bool on = true;
    for (std::size_t j = g; j < g + kGroup; ++j) {
      on = on && on_map[j] && col1[j] > col0[j] && row1[j] > row0[j];
      c0 = std::min(c0, col0[j]);
      r0 = std::min(r0, row0[j]);
      c1 = std::max(c1, col1[j]);
      r1 = std::max(r1, row1[j]);
      t = std::max(t, threshold[j]);
    }
    if (!on || c1 - c0 > kGroupSpan || r1 - r0 > kGroupSpan) continue;
    group_first.push_back(static_cast<std::uint32_t>(g));
    group_col0.push_back(c0);
    group_row0.push_back(r0);
    group_col1.push_back(c1);
    group_row1.push_back(r1);
    group_threshold.push_back(t);
  }
}

std::size_t cull_batch(const CullIndex& index, const BoxBatch& batch, std::span<BoxVisibility> out, BatchStats* stats,
                       const CullBatchOptions& options) {
  assert(out.size() == batch.size());
  BatchStats local;
  std::size_t visible = 0;
  const std::size_t n = batch.size();
  // The next group to try (states only): answers boxes j .. j + kGroup and
  // returns true when it is hidden as a whole.
  std::size_t next_group = options.exact_minimum ? batch.group_first.size() : 0;
  const auto group_hidden = [&](std::size_t j) {
    while (next_group < batch.group_first.size() && batch.group_first[next_group] < j) ++next_group;
    if (next_group == batch.group_first.size() || batch.group_first[next_group] != j) return false;
    const std::size_t g = next_group++;
    const terrain::Window& win = index.window();
    const int c0 = batch.group_col0[g] - win.col0, r0 = batch.group_row0[g] - win.row0;
    const int c1 = batch.group_col1[g] - win.col0, r1 = batch.group_row1[g] - win.row0;
    if (c0 < 0 || r0 < 0 || c1 > index.width() || r1 > index.height()) return false;
    ++local.groups_tried;
    const float least = index.block_min_over(c0, r0, c1, r1, &local.reads);
    if (!(least > batch.group_threshold[g])) return false;
    ++local.groups_hidden;
    for (std::size_t i = j; i < j + BoxBatch::kGroup; ++i) out[batch.order[i]] = {Visibility::kOccluded, least};
    return true;
  };
  const auto finish = [&](std::size_t j, float ohf_min) {
    BoxVisibility& o = out[batch.order[j]];
    if (ohf_min == -kInf)
      settle(index, batch, j, o, local);
    else
      answer(o, ohf_min, batch.threshold[j]);
    visible += may_be_seen(o.state);
  };
  std::size_t j = 0;
#ifdef HORIZON_SIMD_AVX2
  // The gathers index level cells with 32-bit offsets.
  const bool fits = index.bytes() / sizeof(float) < (std::size_t{1} << 31);
  if (fits && index.width() > 0) {
    const auto vector_pass = [&](auto kernel, std::size_t width) {
      float ohf[16];
      while (j + width <= n) {
        if (j % BoxBatch::kGroup == 0 && group_hidden(j)) {
          j += BoxBatch::kGroup;
          continue;
        }
        LaneMasks lanes;
        kernel(index, batch, j, ohf, lanes);
        for (std::size_t l = 0; l < width; ++l) {
          if (lanes.deferred >> l & 1u) {
            finish(j + l, test_box(index, batch, j + l, local));
            continue;
          }
          if (lanes.outside >> l & 1u) {
            ++local.outside;
          } else {
            local.reads += 4;
            ++local.vector_boxes;
          }
          finish(j + l, ohf[l]);
        }
        j += width;
      }
    };
    if (simd::has_avx512())
      vector_pass(test16, 16);
    else if (simd::has_avx2())
      vector_pass(test8, 8);
  }
#endif
  while (j < n) {
    if (j % BoxBatch::kGroup == 0 && group_hidden(j)) {
      j += BoxBatch::kGroup;
      continue;
    }
    finish(j, test_box(index, batch, j, local));
    ++j;
  }
  if (stats) {
    stats->reads += local.reads;
    stats->vector_boxes += local.vector_boxes;
    stats->outside += local.outside;
    stats->groups_tried += local.groups_tried;
    stats->groups_hidden += local.groups_hidden;
  }
  return visible;
}

}  // namespace horizon::visibility
