// The rasters of viewshed_outputs.hpp, each derived from the result's OHF
// (or, for the codes, from a mask-only result's mask).
#include "horizon/visibility/viewshed_outputs.hpp"

#include <algorithm>
#include <cassert>
#include <cmath>
#include <limits>
#include <numbers>
#include <string>
#include <utility>
#include <vector>

#include "horizon/common/parallel.hpp"

#ifdef __SSE2__
#include <immintrin.h>
#endif

namespace horizon::visibility {
namespace {

constexpr std::pair<ViewshedOutput, std::string_view> kNames[] = {
    {ViewshedOutput::kVisibility, "visible"},
    {ViewshedOutput::kBoolean, "boolean"},
    {ViewshedOutput::kOhf, "ohf"},
    {ViewshedOutput::kMinTargetHeight, "min-target-height"},
    {ViewshedOutput::kVerticalAngle, "vertical-angle"},
    {ViewshedOutput::kElevationDifference, "elevation-difference"},
};

constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();

bool visible_at(float ohf, float z, float target_height) {
  return !std::isnan(ohf) && !std::isnan(z) && target_height >= min_target_height_at(ohf, z);
}

// A window-sized raster holding f(col, row, z) on the cells visible at
// `target_height` (window coordinates), NaN elsewhere.
template <class F>
terrain::Grid<float> per_visible_cell(const ViewshedResult& result, double target_height, F&& f) {
  const int width = result.ohf.width(), height = result.ohf.height();
  terrain::Grid<float> out(width, height, kNaN);
  const float th = static_cast<float>(target_height);
  for (int r = 0; r < height; ++r) {
    const float* ohf = result.ohf.row(r);
    const float* z = result.terrain.row(r);
    float* dst = out.row(r);
    for (int c = 0; c < width; ++c)
      if (visible_at(ohf[c], z[c], th)) dst[c] = f(c, r, z[c]);
  }
  return out;
}

}  // namespace

std::string_view output_name(ViewshedOutput output) {
  for (const auto& [o, name] : kNames)
    if (o == output) return name;
  return "unknown";
}

std::optional<ViewshedOutput> parse_output(std::string_view name) {
  for (const auto& [o, n] : kNames)
    if (n == name) return o;
  return std::nullopt;
}

bool is_code_raster(ViewshedOutput output) {
  return output == ViewshedOutput::kVisibility || output == ViewshedOutput::kBoolean;
}

bool needs_heights(ViewshedOutput output) {
  return output == ViewshedOutput::kOhf || output == ViewshedOutput::kMinTargetHeight;
}

Status validate_value_codes(const ValueCodes& codes) {
  const auto clash = [&](std::uint8_t other, const char* what) -> Status {
    if (codes.visible != other) return Status::Ok();
    return make_error(ErrorCode::kInvalidArgument,
                      "visible_value: " + std::to_string(codes.visible) + " is also the " + what +
                          " value; visible cells need a code of their own",
                      "visible_value");
  };
  HORIZON_RETURN_IF_ERROR(clash(codes.hidden, "hidden"));
  HORIZON_RETURN_IF_ERROR(clash(codes.out_of_range, "out-of-range"));
  return clash(codes.nodata, "nodata");
}

namespace {

// The classes of cells [0, n) of one run, written as `codes` into d, and
// counted: visible, and answered (visible or hidden), and voids.
struct RunCounts {
  std::uint32_t visible = 0, answered = 0, nodata = 0;
};

// One cell, by the rule of min_target_height_at(): a void target first, then
// no answer (NaN OHF), then visible or hidden.
inline void code_cell(float o, float g, float th, const ValueCodes& codes, std::uint8_t& d, RunCounts& n) {
  const bool gap = std::isnan(g), none = std::isnan(o);
  const bool seen = th >= min_target_height_at(o, g);
  d = gap ? codes.nodata : (none ? codes.out_of_range : (seen ? codes.visible : codes.hidden));
  n.visible += !gap && !none && seen;
  n.answered += !gap && !none;
  n.nodata += gap;
}

RunCounts code_run(const float* __restrict o, const float* __restrict g, std::uint8_t* __restrict d, std::size_t n,
                   float th, const ValueCodes& codes) {
  RunCounts counts;
  std::size_t i = 0;
#ifdef __SSE2__
  // Sixteen cells a step, the same float operations as code_cell (a
  // subtraction and two compares, no fused arithmetic), so the same answers;
  // the masks' -1 lanes are subtracted into per-lane counters.
  const __m128 tol = _mm_set1_ps(kTieTolerance), height = _mm_set1_ps(th);
  const __m128i visible = _mm_set1_epi32(codes.visible), hidden = _mm_set1_epi32(codes.hidden);
  const __m128i out_of_range = _mm_set1_epi32(codes.out_of_range), nodata = _mm_set1_epi32(codes.nodata);
  auto select = [](__m128i mask, __m128i yes, __m128i no) {
    return _mm_or_si128(_mm_and_si128(mask, yes), _mm_andnot_si128(mask, no));
  };
  __m128i seen_n = _mm_setzero_si128(), answered_n = _mm_setzero_si128(), gap_n = _mm_setzero_si128();
  auto four = [&](std::size_t at) {
    const __m128 ov = _mm_loadu_ps(o + at), gv = _mm_loadu_ps(g + at);
    const __m128 above = _mm_sub_ps(ov, gv);
    const __m128 needed = _mm_and_ps(_mm_cmpgt_ps(above, tol), above);  // min_target_height_at
    const __m128i seen = _mm_castps_si128(_mm_cmpge_ps(height, needed));
    const __m128i none = _mm_castps_si128(_mm_cmpunord_ps(ov, ov));
    const __m128i gap = _mm_castps_si128(_mm_cmpunord_ps(gv, gv));
    const __m128i answered = _mm_andnot_si128(_mm_or_si128(none, gap), _mm_set1_epi32(-1));
    seen_n = _mm_sub_epi32(seen_n, _mm_and_si128(answered, seen));
    answered_n = _mm_sub_epi32(answered_n, answered);
    gap_n = _mm_sub_epi32(gap_n, gap);
    return select(gap, nodata, select(none, out_of_range, select(seen, visible, hidden)));
  };
  for (; i + 16 <= n; i += 16) {
    const __m128i lo = _mm_packs_epi32(four(i), four(i + 4)), hi = _mm_packs_epi32(four(i + 8), four(i + 12));
    _mm_storeu_si128(reinterpret_cast<__m128i*>(d + i), _mm_packus_epi16(lo, hi));
  }
  alignas(16) std::uint32_t lanes[3][4];
  _mm_store_si128(reinterpret_cast<__m128i*>(lanes[0]), seen_n);
  _mm_store_si128(reinterpret_cast<__m128i*>(lanes[1]), answered_n);
  _mm_store_si128(reinterpret_cast<__m128i*>(lanes[2]), gap_n);
  for (int k = 0; k < 4; ++k) {
    counts.visible += lanes[0][k];
    counts.answered += lanes[1][k];
    counts.nodata += lanes[2][k];
  }
#endif
  for (; i < n; ++i) code_cell(o[i], g[i], th, codes, d[i], counts);
  return counts;
}

// visibility_codes() of a result with a mask and no OHF: the mask's codes
// mapped to `codes`, a no-answer cell told apart by its ground (a void is no
// data, as code_cell tells it first).
terrain::Grid<std::uint8_t> recode_mask(const ViewshedResult& result, const ValueCodes& codes, unsigned threads,
                                        AnswerCounts* counts) {
  const terrain::Grid<std::uint8_t>& mask = *result.mask;
  if (counts) *counts = result.mask_counts;
  if (codes == ValueCodes{}) return mask;
  terrain::Grid<std::uint8_t> out(mask.width(), mask.height(), terrain::kUninitialized);
  const std::size_t n = out.size();
  constexpr std::size_t kChunk = std::size_t{1} << 18;
  const std::size_t chunks = (n + kChunk - 1) / kChunk;
  parallel_for(chunks, chunks > 1 ? threads : 1, [&](std::size_t k) {
    const std::size_t begin = k * kChunk, end = std::min(n, begin + kChunk);
    const std::uint8_t* m = mask.data();
    const float* g = result.terrain.data();
    std::uint8_t* d = out.data();
    for (std::size_t i = begin; i < end; ++i)
      d[i] = m[i] == kVisible  ? codes.visible
             : m[i] == kHidden ? codes.hidden
                               : (std::isnan(g[i]) ? codes.nodata : codes.out_of_range);
  });
  return out;
}

}  // namespace

terrain::Grid<std::uint8_t> visibility_codes(const ViewshedResult& result, double target_height,
                                             const ValueCodes& codes, unsigned threads, AnswerCounts* counts) {
  if (result.mask && result.ohf.size() == 0) {
    assert(target_height == result.target_height);
    return recode_mask(result, codes, threads, counts);
  }
  terrain::Grid<std::uint8_t> out(result.ohf.width(), result.ohf.height(), terrain::kUninitialized);
  const float th = static_cast<float>(target_height);
  const std::size_t n = out.size();
  // Chunks of 256 Ki cells (~2 MB read, 256 KB written): a 12 M-cell raster
  // is 47 items, a small one a single item on the calling thread.
  constexpr std::size_t kChunk = std::size_t{1} << 18;
  const std::size_t chunks = (n + kChunk - 1) / kChunk;
  std::vector<RunCounts> part(chunks);
  parallel_for(chunks, chunks > 1 ? threads : 1, [&](std::size_t k) {
    const std::size_t begin = k * kChunk, end = std::min(n, begin + kChunk);
    part[k] =
        code_run(result.ohf.data() + begin, result.terrain.data() + begin, out.data() + begin, end - begin, th, codes);
  });
  if (counts) {
    *counts = {};
    for (std::size_t k = 0; k < chunks; ++k) {
      const std::size_t cells = std::min(n, (k + 1) * kChunk) - k * kChunk;
      counts->visible += part[k].visible;
      counts->hidden += part[k].answered - part[k].visible;
      counts->nodata += part[k].nodata;
      counts->out_of_range += cells - part[k].answered - part[k].nodata;
    }
  }
  return out;
}

terrain::Grid<float> vertical_angle_raster(const ViewshedResult& result, double target_height) {
  const ViewFrame& f = result.frame;
  // The cell the eye stands in (cell c spans [c - 0.5, c + 0.5)), in window coordinates.
  const int eye_col = static_cast<int>(std::floor(f.observer_col + 0.5)) - f.window.col0;
  const int eye_row = static_cast<int>(std::floor(f.observer_row + 0.5)) - f.window.row0;
  constexpr double kDegrees = 180.0 / std::numbers::pi;
  return per_visible_cell(result, target_height, [&](int c, int r, float z) {
    if (c == eye_col && r == eye_row) return 180.0f;
    const double col = c + f.window.col0, row = r + f.window.row0;
    const double d = f.distance(col, row);
    const double rise = z + target_height - f.curvature * d * d - f.eye;
    return static_cast<float>(90.0 + std::atan2(rise, d) * kDegrees);
  });
}

terrain::Grid<float> elevation_difference_raster(const ViewshedResult& result, double target_height) {
  const double eye = result.frame.eye;
  return per_visible_cell(result, target_height, [&](int, int, float z) { return static_cast<float>(z - eye); });
}

terrain::Grid<float> float_raster(const ViewshedResult& result, ViewshedOutput output, double target_height) {
  switch (output) {
    case ViewshedOutput::kOhf:
      return ohf_raster(result);
    case ViewshedOutput::kMinTargetHeight:
      return min_target_height(result);
    case ViewshedOutput::kVerticalAngle:
      return vertical_angle_raster(result, target_height);
    case ViewshedOutput::kElevationDifference:
      return elevation_difference_raster(result, target_height);
    case ViewshedOutput::kVisibility:
    case ViewshedOutput::kBoolean:
      break;
  }
  return {};
}

}  // namespace horizon::visibility
