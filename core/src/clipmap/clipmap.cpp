#include "horizon/clipmap/clipmap.hpp"

#include <algorithm>
#include <atomic>
#include <bit>
#include <cassert>
#include <cmath>
#include <cstring>
#include <mutex>
#include <string>

#include "visibility/simd.hpp"

namespace horizon::clipmap {
namespace {

constexpr std::uint64_t kMaxValidityBytes = 16u << 20;
// 2^-k: level-k cells per source cell.
constexpr double kLevelScale[ClipmapShape::kMaxLevels] = {1.0, 0.5, 0.25, 0.125, 0.0625, 0.03125, 0.015625, 0.0078125,
                                                          0.00390625, 0.001953125};

bool power_of_two(int v) { return v > 0 && (v & (v - 1)) == 0; }
int log2i(int v) { return std::countr_zero(static_cast<unsigned>(v)); }

}  // namespace

Result<std::shared_ptr<Clipmap>> Clipmap::make(int source_width, int source_height, const ClipmapShape& shape) {
  HORIZON_RETURN_IF_ERROR(check(source_width, source_height, shape));
  return std::shared_ptr<Clipmap>(new Clipmap(source_width, source_height, shape));
}

Status Clipmap::check(int source_width, int source_height, const ClipmapShape& shape) {
  if (source_width <= 0 || source_height <= 0)
    return make_error(ErrorCode::kInvalidArgument, "clip-map source has no cells", "source");
  if (shape.levels < 1 || shape.levels > ClipmapShape::kMaxLevels)
    return make_error(ErrorCode::kInvalidArgument,
                      "clipmap.levels must be 1.." + std::to_string(ClipmapShape::kMaxLevels) + ", got " +
                          std::to_string(shape.levels),
                      "clipmap.levels");
  if (!power_of_two(shape.level_size) || shape.level_size < 64 || shape.level_size > 4096)
    return make_error(ErrorCode::kInvalidArgument,
                      "clipmap.level_size must be a power of two in [64, 4096], got " +
                          std::to_string(shape.level_size),
                      "clipmap.level_size");
  if (!power_of_two(shape.subtile) || shape.subtile < 8 || shape.subtile > shape.level_size / 2)
    return make_error(ErrorCode::kInvalidArgument,
                      "clipmap.subtile must be a power of two in [8, level_size / 2 = " +
                          std::to_string(shape.level_size / 2) + "], got " + std::to_string(shape.subtile),
                      "clipmap.subtile");
  const int longest = std::max(source_width, source_height);
  const int top = shape.levels - 1;
  if ((static_cast<std::int64_t>(shape.level_size) << top) < longest) {
    int needed = shape.levels;
    while ((static_cast<std::int64_t>(shape.level_size) << (needed - 1)) < longest) ++needed;
    std::string message = "clipmap.levels: " + std::to_string(shape.levels) + " levels of " +
                          std::to_string(shape.level_size) + " samples reach " +
                          std::to_string(static_cast<std::int64_t>(shape.level_size) << top) +
                          " cells, the source is " + std::to_string(longest) +
                          " cells across; the coarsest level must cover it: ";
    if (needed <= ClipmapShape::kMaxLevels)
      message += "use at least " + std::to_string(needed) + " levels";
    else
      message += "use a larger level_size";
    return make_error(ErrorCode::kInvalidArgument, std::move(message), "clipmap.levels");
  }
  const std::uint64_t validity = static_cast<std::uint64_t>((source_width + shape.subtile - 1) / shape.subtile) *
                                 static_cast<std::uint64_t>((source_height + shape.subtile - 1) / shape.subtile);
  if (validity > kMaxValidityBytes)
    return make_error(ErrorCode::kResourceExhausted,
                      "clipmap.subtile " + std::to_string(shape.subtile) + " needs a validity grid of " +
                          std::to_string(validity) + " positions over this source (at most " +
                          std::to_string(kMaxValidityBytes) + "): use a larger subtile",
                      "clipmap.subtile");
  return Status::Ok();
}

std::uint64_t Clipmap::bytes_for(int source_width, int source_height, const ClipmapShape& shape) {
  const std::uint64_t n2 = static_cast<std::uint64_t>(shape.level_size) * static_cast<std::uint64_t>(shape.level_size);
  const std::uint64_t tiles = static_cast<std::uint64_t>(shape.level_size / shape.subtile);
  const std::uint64_t validity =
      static_cast<std::uint64_t>((source_width + shape.subtile - 1) / shape.subtile) *
      static_cast<std::uint64_t>((source_height + shape.subtile - 1) / shape.subtile);
  return static_cast<std::uint64_t>(shape.levels) * (n2 * sizeof(float) + tiles * tiles * sizeof(SubtileKey)) +
         validity;
}

Clipmap::Clipmap(int width, int height, const ClipmapShape& shape)
    : shape_(shape),
      id_([] {
        static std::atomic<std::uint64_t> made{0};
        return ++made;
      }()),
      width_(width),
      height_(height),
      tiles_(shape.level_size / shape.subtile),
      log_t_(log2i(shape.subtile)),
      log_n_(log2i(shape.level_size)),
      valid_w_((width + shape.subtile - 1) / shape.subtile),
      valid_h_((height + shape.subtile - 1) / shape.subtile),
      levels_(static_cast<std::size_t>(shape.levels)),
      validity_(static_cast<std::size_t>(valid_w_) * static_cast<std::size_t>(valid_h_), kNoLevel) {
  const std::size_t n2 = static_cast<std::size_t>(shape.level_size) * static_cast<std::size_t>(shape.level_size);
  for (Level& level : levels_) {
    // Poison: a slot never written reads NaN, which no test accepts as terrain.
    level.samples.assign(n2, std::numeric_limits<float>::quiet_NaN());
    level.tags.assign(static_cast<std::size_t>(tiles_) * static_cast<std::size_t>(tiles_), kEmptyTag);
  }
}

std::uint64_t Clipmap::bytes() const { return bytes_for(width_, height_, shape_); }

LevelOrigin Clipmap::origin_for(int k, double col, double row) const {
  assert(k >= 0 && k < shape_.levels);
  if (full_extent(k)) return {};
  const int n = shape_.level_size, t = shape_.subtile;
  auto axis = [&](double centre, int level_cells) {
    const double u = (centre + 0.5) / static_cast<double>(1 << k) - 0.5;  // level-cell coordinate
    const double start = std::clamp(u - n / 2.0, -1e9, 1e9);
    int origin = static_cast<int>(std::floor(start / t + 0.5)) * t;
    // Keep the window over the source where it can be: no slots spent off its edges.
    const int last = level_cells > n ? (level_cells - n + t - 1) / t * t : 0;
    return std::clamp(origin, 0, last);
  };
  return {axis(col, level_width(k)), axis(row, level_height(k))};
}

bool Clipmap::in_window(const LevelOrigin& o, int tx, int ty) const {
  const int x0 = o.col0 >> log_t_, y0 = o.row0 >> log_t_;
  return tx >= x0 && tx < x0 + tiles_ && ty >= y0 && ty < y0 + tiles_;
}

bool Clipmap::inside_source(int k, int tx, int ty) const {
  return tx >= 0 && ty >= 0 && (tx << log_t_) < level_width(k) && (ty << log_t_) < level_height(k);
}

bool Clipmap::resident(int k, int tx, int ty) const {
  const Level& level = levels_[static_cast<std::size_t>(k)];
  return level.tags[static_cast<std::size_t>(slot_of(tx, ty))] == SubtileKey{tx, ty};
}

std::vector<SubtileKey> Clipmap::missing_subtiles(int k, const LevelOrigin& origin) const {
  std::shared_lock lock(mutex_);
  std::vector<SubtileKey> keys;
  const int x0 = origin.col0 >> log_t_, y0 = origin.row0 >> log_t_;
  for (int ty = y0; ty < y0 + tiles_; ++ty)
    for (int tx = x0; tx < x0 + tiles_; ++tx)
      if (inside_source(k, tx, ty) && !resident(k, tx, ty)) keys.push_back({tx, ty});
  return keys;
}

void Clipmap::refresh_validity(int k, int tx, int ty) {
  // Level-k sub-tile (tx, ty) spans finest positions [tx 2^k, (tx + 1) 2^k).
  const int px0 = std::max(0, tx << k), px1 = std::min(valid_w_, (tx + 1) << k);
  const int py0 = std::max(0, ty << k), py1 = std::min(valid_h_, (ty + 1) << k);
  for (int py = py0; py < py1; ++py)
    for (int px = px0; px < px1; ++px) {
      std::uint8_t v = kNoLevel;
      for (int level = 0; level < shape_.levels; ++level)
        if (resident(level, px >> level, py >> level)) {
          v = static_cast<std::uint8_t>(level);
          break;
        }
      validity_[static_cast<std::size_t>(py) * static_cast<std::size_t>(valid_w_) + static_cast<std::size_t>(px)] = v;
    }
}

void Clipmap::publish(const LevelUpdate& update) {
  std::unique_lock lock(mutex_);
  const int k = update.level;
  assert(k >= 0 && k < shape_.levels);
  Level& level = levels_[static_cast<std::size_t>(k)];
  const int t = shape_.subtile;
  assert(update.samples.size() == update.keys.size() * static_cast<std::size_t>(t) * static_cast<std::size_t>(t));

  std::vector<SubtileKey> dropped;
  for (SubtileKey& tag : level.tags)
    if (!(tag == kEmptyTag) && !in_window(update.origin, tag.tx, tag.ty)) {
      dropped.push_back(tag);
      tag = kEmptyTag;
      --level.resident;
    }
  level.origin = update.origin;

  const float* src = update.samples.data();
  for (const SubtileKey& key : update.keys) {
    assert(in_window(update.origin, key.tx, key.ty) && inside_source(k, key.tx, key.ty));
    SubtileKey& tag = level.tags[static_cast<std::size_t>(slot_of(key.tx, key.ty))];
    const bool fresh = !(tag == key);
    const int col = key.tx << log_t_;
    for (int r = 0; r < t; ++r) {
      const int row = (key.ty << log_t_) + r;
      for (int c = 0; c < t; c += 4)  // t >= 8: whole bricks' rows of four
        std::memcpy(level.samples.data() + sample_index(col + c, row), src + c, 4 * sizeof(float));
      src += t;
    }
    tag = key;
    if (fresh) ++level.resident;
  }
  for (const SubtileKey& key : dropped) refresh_validity(k, key.tx, key.ty);
  for (const SubtileKey& key : update.keys) refresh_validity(k, key.tx, key.ty);
  level.loaded_once = true;
  ++level.version;
  level.pose = update.pose;
  // Complete: every sub-tile of the window that lies in the source is resident.
  std::uint64_t inside = 0;
  const int x0 = level.origin.col0 >> log_t_, y0 = level.origin.row0 >> log_t_;
  for (int ty = y0; ty < y0 + tiles_; ++ty)
    for (int tx = x0; tx < x0 + tiles_; ++tx) inside += inside_source(k, tx, ty);
  level.complete = level.resident == inside;
}

// --- ClipmapReader ---

ClipmapReader::ClipmapReader(const Clipmap& map) : map_(map), lock_(map.mutex_) {}

LevelState ClipmapReader::level(int k) const {
  const Clipmap::Level& level = map_.levels_[static_cast<std::size_t>(k)];
  return {level.origin, map_.full_extent(k), level.version, level.pose, level.resident};
}

bool ClipmapReader::resident(int k, int i, int j) const {
  // A tag is dropped when its sub-tile leaves the level's window, so the tag alone says it.
  return map_.resident(k, i >> map_.log_t_, j >> map_.log_t_);
}

float ClipmapReader::cell(int k, int i, int j) const {
  assert(resident(k, i, j));
  return map_.levels_[static_cast<std::size_t>(k)]
      .samples[map_.sample_index(i, j)];
}

int ClipmapReader::level_for(int k, double col, double row) const {
  const int px = std::clamp(static_cast<int>(std::floor(col)) >> map_.log_t_, 0, map_.valid_w_ - 1);
  const int py = std::clamp(static_cast<int>(std::floor(row)) >> map_.log_t_, 0, map_.valid_h_ - 1);
  const std::uint8_t v =
      map_.validity_[static_cast<std::size_t>(py) * static_cast<std::size_t>(map_.valid_w_) + static_cast<std::size_t>(px)];
  if (v == Clipmap::kNoLevel) return map_.shape_.levels;
  return std::max(k, static_cast<int>(v));
}

namespace {

// The window of a complete level inside which sample_many's direct path
// holds: a sample whose four cells lie in the window and the level (no
// clamping) reads level k, as sample() would (validity there is k or finer).
struct DirectWindow {
  const float* cells;
  double scale, lo_u, lo_v, hi_u, hi_v, max_col, max_row;
  unsigned mask;  // n - 1
  int log_n;
};

#ifdef HORIZON_SIMD_AVX2
// Four samples of the direct path at once, with the scalar path's double
// and float operations (no fused multiply-add: AVX2 alone carries none).
// Returns false, writing nothing, unless all four lie in the window.
HORIZON_AVX2 bool direct_four(const DirectWindow& d, const double* cols, const double* rows, float* out) {
  const __m256d half = _mm256_set1_pd(0.5), scale = _mm256_set1_pd(d.scale);
  const __m256d col = _mm256_loadu_pd(cols), row = _mm256_loadu_pd(rows);
  const __m256d u = _mm256_sub_pd(_mm256_mul_pd(_mm256_add_pd(col, half), scale), half);
  const __m256d v = _mm256_sub_pd(_mm256_mul_pd(_mm256_add_pd(row, half), scale), half);
  const __m256d fi = _mm256_floor_pd(u), fj = _mm256_floor_pd(v);
  __m256d in = _mm256_and_pd(_mm256_cmp_pd(fi, _mm256_set1_pd(d.lo_u), _CMP_GE_OQ),
                             _mm256_cmp_pd(fi, _mm256_set1_pd(d.hi_u), _CMP_LT_OQ));
  in = _mm256_and_pd(in, _mm256_cmp_pd(fj, _mm256_set1_pd(d.lo_v), _CMP_GE_OQ));
  in = _mm256_and_pd(in, _mm256_cmp_pd(fj, _mm256_set1_pd(d.hi_v), _CMP_LT_OQ));
  in = _mm256_and_pd(in, _mm256_cmp_pd(col, _mm256_set1_pd(d.max_col), _CMP_LE_OQ));
  in = _mm256_and_pd(in, _mm256_cmp_pd(row, _mm256_set1_pd(d.max_row), _CMP_LE_OQ));
  if (_mm256_movemask_pd(in) != 0xf) return false;
  const __m256d a = _mm256_sub_pd(u, fi), b = _mm256_sub_pd(v, fj);
  // Clipmap::sample_index for the four corners, in 32-bit lanes.
  const __m128i mask = _mm_set1_epi32(static_cast<int>(d.mask)), three = _mm_set1_epi32(3), one = _mm_set1_epi32(1);
  const __m128i i0 = _mm256_cvttpd_epi32(fi), j0 = _mm256_cvttpd_epi32(fj);
  const __m128i row_shift = _mm_cvtsi32_si128(d.log_n + 2);
  auto index = [&](__m128i i, __m128i j) {
    const __m128i uu = _mm_and_si128(i, mask), vv = _mm_and_si128(j, mask);
    const __m128i brick_row = _mm_sll_epi32(_mm_srli_epi32(vv, 2), row_shift);
    const __m128i brick_col = _mm_slli_epi32(_mm_srli_epi32(uu, 2), 4);
    const __m128i inner = _mm_add_epi32(_mm_slli_epi32(_mm_and_si128(vv, three), 2), _mm_and_si128(uu, three));
    return _mm_add_epi32(_mm_add_epi32(brick_row, brick_col), inner);
  };
  const __m128i i1 = _mm_add_epi32(i0, one), j1 = _mm_add_epi32(j0, one);
  const __m128 z00 = _mm_i32gather_ps(d.cells, index(i0, j0), 4), z10 = _mm_i32gather_ps(d.cells, index(i1, j0), 4);
  const __m128 z01 = _mm_i32gather_ps(d.cells, index(i0, j1), 4), z11 = _mm_i32gather_ps(d.cells, index(i1, j1), 4);
  const __m256d d0 = _mm256_cvtps_pd(_mm_sub_ps(z10, z00)), d1 = _mm256_cvtps_pd(_mm_sub_ps(z11, z01));
  const __m256d top = _mm256_add_pd(_mm256_cvtps_pd(z00), _mm256_mul_pd(d0, a));
  const __m256d bottom = _mm256_add_pd(_mm256_cvtps_pd(z01), _mm256_mul_pd(d1, a));
  const __m256d z = _mm256_add_pd(top, _mm256_mul_pd(_mm256_sub_pd(bottom, top), b));
  _mm_storeu_ps(out, _mm256_cvtpd_ps(z));
  return true;
}

// Clipmap::sample_index for eight cells.
HORIZON_AVX512 inline __m256i brick_index8(const DirectWindow& d, __m256i i, __m256i j) {
  const __m256i mask = _mm256_set1_epi32(static_cast<int>(d.mask)), three = _mm256_set1_epi32(3);
  const __m256i uu = _mm256_and_si256(i, mask), vv = _mm256_and_si256(j, mask);
  const __m256i brick_row = _mm256_sll_epi32(_mm256_srli_epi32(vv, 2), _mm_cvtsi32_si128(d.log_n + 2));
  const __m256i brick_col = _mm256_slli_epi32(_mm256_srli_epi32(uu, 2), 4);
  const __m256i inner = _mm256_add_epi32(_mm256_slli_epi32(_mm256_and_si256(vv, three), 2), _mm256_and_si256(uu, three));
  return _mm256_add_epi32(_mm256_add_epi32(brick_row, brick_col), inner);
}

// Eight at once, the same operations: doubles in 512-bit registers, the
// indices and gathers in 256-bit ones.
HORIZON_AVX512 bool direct_eight(const DirectWindow& d, const double* cols, const double* rows, float* out) {
  const __m512d half = _mm512_set1_pd(0.5), scale = _mm512_set1_pd(d.scale);
  const __m512d col = _mm512_loadu_pd(cols), row = _mm512_loadu_pd(rows);
  const __m512d u = _mm512_sub_pd(_mm512_mul_pd(_mm512_add_pd(col, half), scale), half);
  const __m512d v = _mm512_sub_pd(_mm512_mul_pd(_mm512_add_pd(row, half), scale), half);
  const __m512d fi = _mm512_roundscale_pd(u, _MM_FROUND_TO_NEG_INF | _MM_FROUND_NO_EXC);
  const __m512d fj = _mm512_roundscale_pd(v, _MM_FROUND_TO_NEG_INF | _MM_FROUND_NO_EXC);
  __mmask8 in = _mm512_cmp_pd_mask(fi, _mm512_set1_pd(d.lo_u), _CMP_GE_OQ);
  in &= _mm512_cmp_pd_mask(fi, _mm512_set1_pd(d.hi_u), _CMP_LT_OQ);
  in &= _mm512_cmp_pd_mask(fj, _mm512_set1_pd(d.lo_v), _CMP_GE_OQ);
  in &= _mm512_cmp_pd_mask(fj, _mm512_set1_pd(d.hi_v), _CMP_LT_OQ);
  in &= _mm512_cmp_pd_mask(col, _mm512_set1_pd(d.max_col), _CMP_LE_OQ);
  in &= _mm512_cmp_pd_mask(row, _mm512_set1_pd(d.max_row), _CMP_LE_OQ);
  if (in != 0xff) return false;
  const __m512d a = _mm512_sub_pd(u, fi), b = _mm512_sub_pd(v, fj);
  const __m256i one = _mm256_set1_epi32(1);
  const __m256i i0 = _mm512_cvttpd_epi32(fi), j0 = _mm512_cvttpd_epi32(fj);
  const __m256i i1 = _mm256_add_epi32(i0, one), j1 = _mm256_add_epi32(j0, one);
  const __m256 z00 = _mm256_i32gather_ps(d.cells, brick_index8(d, i0, j0), 4);
  const __m256 z10 = _mm256_i32gather_ps(d.cells, brick_index8(d, i1, j0), 4);
  const __m256 z01 = _mm256_i32gather_ps(d.cells, brick_index8(d, i0, j1), 4);
  const __m256 z11 = _mm256_i32gather_ps(d.cells, brick_index8(d, i1, j1), 4);
  const __m512d d0 = _mm512_cvtps_pd(_mm256_sub_ps(z10, z00)), d1 = _mm512_cvtps_pd(_mm256_sub_ps(z11, z01));
  const __m512d top = _mm512_add_pd(_mm512_cvtps_pd(z00), _mm512_mul_pd(d0, a));
  const __m512d bottom = _mm512_add_pd(_mm512_cvtps_pd(z01), _mm512_mul_pd(d1, a));
  const __m512d z = _mm512_add_pd(top, _mm512_mul_pd(_mm512_sub_pd(bottom, top), b));
  _mm256_storeu_ps(out, _mm512_cvtpd_ps(z));
  return true;
}
#endif

}  // namespace

void ClipmapReader::sample_many(int k, std::size_t count, const double* cols, const double* rows, float* out,
                                SampleStats& stats) const {
  const Clipmap::Level& level = map_.levels_[static_cast<std::size_t>(k)];
  if (!level.complete) {
    for (std::size_t i = 0; i < count; ++i) out[i] = sample(k, cols[i], rows[i], stats);
    return;
  }
  // Level k is whole over its window: a sample whose four cells lie in the
  // window and in the level (no clamping) reads level k, as sample() would
  // (validity there is k or finer), with the same arithmetic.
  const int n = map_.shape_.level_size;
  const DirectWindow d{level.samples.data(),
                       kLevelScale[k],
                       static_cast<double>(std::max(level.origin.col0, 0)),
                       static_cast<double>(std::max(level.origin.row0, 0)),
                       static_cast<double>(std::min(level.origin.col0 + n, map_.level_width(k)) - 1),  // i1 <= hi
                       static_cast<double>(std::min(level.origin.row0 + n, map_.level_height(k)) - 1),
                       map_.width_ - 0.5,
                       map_.height_ - 0.5,
                       static_cast<unsigned>(n - 1),
                       map_.log_n_};
  std::size_t slow = 0;
  auto one = [&](std::size_t i) {
    const double col = cols[i], row = rows[i];
    const double u = (col + 0.5) * d.scale - 0.5, v = (row + 0.5) * d.scale - 0.5;
    const double fi = std::floor(u), fj = std::floor(v);
    if (!(fi >= d.lo_u && fi < d.hi_u && fj >= d.lo_v && fj < d.hi_v && col <= d.max_col && row <= d.max_row)) {
      out[i] = sample(k, col, row, stats);
      ++slow;
      return;
    }
    const double a = u - fi, b = v - fj;
    const int i0 = static_cast<int>(fi), j0 = static_cast<int>(fj);
    const float* cells = d.cells;
    const float z00 = cells[map_.sample_index(i0, j0)], z10 = cells[map_.sample_index(i0 + 1, j0)];
    const float z01 = cells[map_.sample_index(i0, j0 + 1)], z11 = cells[map_.sample_index(i0 + 1, j0 + 1)];
    const double top = z00 + (z10 - z00) * a, bottom = z01 + (z11 - z01) * a;
    out[i] = static_cast<float>(top + (bottom - top) * b);
  };
  std::size_t i = 0;
#ifdef HORIZON_SIMD_AVX2
  const visibility::sweep::simd::Isa isa = visibility::sweep::simd::kernel_isa();
  if (isa >= visibility::sweep::simd::Isa::kAvx512)
    for (; i + 8 <= count; i += 8)
      if (!direct_eight(d, cols + i, rows + i, out + i))
        for (std::size_t j = i; j < i + 8; ++j) one(j);
  if (isa >= visibility::sweep::simd::Isa::kAvx2)
    for (; i + 4 <= count; i += 4)
      if (!direct_four(d, cols + i, rows + i, out + i))
        for (std::size_t j = i; j < i + 4; ++j) one(j);
#endif
  for (; i < count; ++i) one(i);
  stats.samples += count - slow;
}

float ClipmapReader::sample(int k, double col, double row, SampleStats& stats, int* used) const {
  ++stats.samples;
  if (used) *used = map_.shape_.levels;
  if (!(col >= -0.5 && row >= -0.5 && col <= map_.width_ - 0.5 && row <= map_.height_ - 0.5))
    return std::numeric_limits<float>::quiet_NaN();
  const int lt = map_.log_t_;
  for (int kk = level_for(k, col, row); kk < map_.shape_.levels; ++kk) {
    const double scale = kLevelScale[kk];
    const double u = (col + 0.5) * scale - 0.5, v = (row + 0.5) * scale - 0.5;
    const int w = map_.level_width(kk), h = map_.level_height(kk);
    const double fi = std::floor(u), fj = std::floor(v);
    const double a = u - fi, b = v - fj;
    // col, row >= -0.5 make u, v >= -0.5: fi, fj >= -1, so i1, j1 >= 0.
    const int i0 = std::clamp(static_cast<int>(fi), 0, w - 1), i1 = std::min(static_cast<int>(fi) + 1, w - 1);
    const int j0 = std::clamp(static_cast<int>(fj), 0, h - 1), j1 = std::min(static_cast<int>(fj) + 1, h - 1);
    // Usually all four cells lie in one sub-tile: one tag to check.
    if ((i0 >> lt) == (i1 >> lt) && (j0 >> lt) == (j1 >> lt)) {
      if (!map_.resident(kk, i0 >> lt, j0 >> lt)) continue;
    } else if (!resident(kk, i0, j0) || !resident(kk, i1, j0) || !resident(kk, i0, j1) || !resident(kk, i1, j1)) {
      continue;
    }
    if (kk > k) ++stats.fallbacks;
    if (used) *used = kk;
    const float* cells = map_.levels_[static_cast<std::size_t>(kk)].samples.data();
    const float z00 = cells[map_.sample_index(i0, j0)], z10 = cells[map_.sample_index(i1, j0)];
    const float z01 = cells[map_.sample_index(i0, j1)], z11 = cells[map_.sample_index(i1, j1)];
    const double top = z00 + (z10 - z00) * a, bottom = z01 + (z11 - z01) * a;
    return static_cast<float>(top + (bottom - top) * b);
  }
  return std::numeric_limits<float>::quiet_NaN();
}

float ClipmapReader::lowest(int k, int col0, int row0, int col1, int row1, SampleStats& stats) const {
  ++stats.samples;
  col0 = std::max(col0, 0);
  row0 = std::max(row0, 0);
  col1 = std::min(col1, map_.width_ - 1);
  row1 = std::min(row1, map_.height_ - 1);
  if (col0 > col1 || row0 > row1) return std::numeric_limits<float>::infinity();
  {
    // Level k complete and the rectangle's cells inside its window: all
    // resident, and validity there is k or finer, so no look-ups.
    const Clipmap::Level& level = map_.levels_[static_cast<std::size_t>(k)];
    const int i0 = col0 >> k, i1 = col1 >> k, j0 = row0 >> k, j1 = row1 >> k, n = map_.shape_.level_size;
    if (level.complete && i0 >= level.origin.col0 && i1 < level.origin.col0 + n && j0 >= level.origin.row0 &&
        j1 < level.origin.row0 + n) {
      const float* cells = level.samples.data();
      float least = std::numeric_limits<float>::infinity();
      for (int j = j0; j <= j1; ++j)
        for (int i = i0; i <= i1; ++i) {
          const float z = cells[map_.sample_index(i, j)];
          if (z != z) return -std::numeric_limits<float>::infinity();
          least = std::min(least, z);
        }
      return least;
    }
  }
  int start = std::max({level_for(k, col0, row0), level_for(k, col1, row0), level_for(k, col0, row1),
                        level_for(k, col1, row1)});
  for (int kk = start; kk < map_.shape_.levels; ++kk) {
    const int i0 = col0 >> kk, i1 = col1 >> kk, j0 = row0 >> kk, j1 = row1 >> kk;
    bool all = true;
    for (int j = j0; j <= j1 && all; ++j)
      for (int i = i0; i <= i1 && all; ++i) all = resident(kk, i, j);
    if (!all) continue;
    if (kk > k) ++stats.fallbacks;
    float least = std::numeric_limits<float>::infinity();
    for (int j = j0; j <= j1; ++j)
      for (int i = i0; i <= i1; ++i) {
        const float z = cell(kk, i, j);
        if (std::isnan(z)) return -std::numeric_limits<float>::infinity();  // a void bounds nothing
        if (z < least) least = z;
      }
    return least;
  }
  return -std::numeric_limits<float>::infinity();  // nothing resident: no bound
}

void ClipmapReader::copy_level(int k, float* samples, std::uint8_t* resident) const {
  const Clipmap::Level& level = map_.levels_[static_cast<std::size_t>(k)];
  const int n = map_.shape_.level_size;
  const float* cells = level.samples.data();
  for (int v = 0; v < n; ++v) {
    float* row = samples + static_cast<std::size_t>(v) * static_cast<std::size_t>(n);
    for (int u = 0; u < n; u += 4) std::memcpy(row + u, cells + map_.sample_index(u, v), 4 * sizeof(float));
  }
  for (std::size_t slot = 0; slot < level.tags.size(); ++slot)
    resident[slot] = level.tags[slot] == Clipmap::kEmptyTag ? 0 : 1;
}

}  // namespace horizon::clipmap
