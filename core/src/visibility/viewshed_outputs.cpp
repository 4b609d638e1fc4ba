// The rasters of viewshed_outputs.hpp, each derived from the result's OHF.
#include "horizon/visibility/viewshed_outputs.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <string>
#include <utility>

#include "horizon/common/parallel.hpp"

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

terrain::Grid<std::uint8_t> visibility_codes(const ViewshedResult& result, double target_height,
                                             const ValueCodes& codes, unsigned threads) {
  terrain::Grid<std::uint8_t> out(result.ohf.width(), result.ohf.height(), terrain::kUninitialized);
  const float th = static_cast<float>(target_height);
  const std::size_t n = out.size();
  // Chunks of 256 Ki cells (~2 MB read, 256 KB written): a 12 M-cell raster
  // is 47 items, a small one a single item on the calling thread.
  constexpr std::size_t kChunk = std::size_t{1} << 18;
  const std::size_t chunks = (n + kChunk - 1) / kChunk;
  parallel_for(chunks, chunks > 1 ? threads : 1, [&](std::size_t k) {
    const std::size_t begin = k * kChunk, end = std::min(n, begin + kChunk);
    const float* __restrict o = result.ohf.data();
    const float* __restrict g = result.terrain.data();
    std::uint8_t* __restrict d = out.data();
    // Branch-free (every answer computed, one kept) so that it vectorises.
    for (std::size_t i = begin; i < end; ++i) {
      const std::uint8_t seen = th >= min_target_height_at(o[i], g[i]) ? codes.visible : codes.hidden;
      const std::uint8_t answered = std::isnan(o[i]) ? codes.out_of_range : seen;
      d[i] = std::isnan(g[i]) ? codes.nodata : answered;
    }
  });
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
