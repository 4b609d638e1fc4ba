// preview.cpp — a PNG a person can look at: hillshade + viewshed tint.
//
// Hillshade: Lambertian shading of the terrain normal under a sun at azimuth
// 315 degrees (north-west) and 45 degrees altitude — the cartographic
// convention (Yoëli 1965; the default of GDAL's gdaldem hillshade). The
// normal comes from central differences over *metric* cell sizes, so a
// geographic DEM (cells narrower east-west than north-south) is not shaded as
// if it were stretched:
//   n = (-dz/dx_east, -dz/dy_north, 1) / |...|,   shade = max(0, n . sun).
// Rows grow south, so dz/dy_north = (z[r-1] - z[r+1]) / (2 * metres_per_row).
// A void neighbour is replaced by the centre cell (a locally flat surface);
// a void cell itself is painted flat blue-grey.
//
// Tint: visible cells lean green, hidden cells darken towards red, other
// values keep the grey. Large grids are box-downsampled by an integer factor
// (every output pixel averages a factor x factor block), then the observer is
// drawn at output resolution so the marker stays visible: a yellow ring with a
// dark outline and a yellow dot.
//
// PNG (ISO/IEC 15948) written through OpenImageIO (imageio.hpp, loaded on first
// use); atomic via atomic_file.hpp.
#include "horizon/terrain/preview.hpp"


#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <numbers>
#include <string>
#include <vector>

#include "atomic_file.hpp"
#include "horizon/imageio/imageio.hpp"

namespace horizon::terrain {
namespace {

using Rgb = std::array<double, 3>;

constexpr Rgb kVoidColour = {112.0, 120.0, 136.0};
constexpr std::array<std::uint8_t, 3> kMarker = {255, 226, 0};
constexpr std::array<std::uint8_t, 3> kMarkerOutline = {20, 20, 20};

Error preview_error(ErrorCode code, const std::string& path, const std::string& what, std::string field = {}) {
  return make_error(code, "preview '" + path + "': " + what, field.empty() ? path : std::move(field));
}

// The sun's direction (east, north, up) for azimuth 315 degrees, altitude 45 degrees.
struct Sun {
  double e, n, u;
};
Sun make_sun() {
  const double az = 315.0 * std::numbers::pi / 180.0;
  const double alt = 45.0 * std::numbers::pi / 180.0;
  return {std::cos(alt) * std::sin(az), std::cos(alt) * std::cos(az), std::sin(alt)};
}

// Colour of one cell: hillshade grey tinted by its visibility code.
Rgb cell_colour(const Grid<float>& z, const Grid<std::uint8_t>& vis, int c, int r, const PreviewOptions& o,
                const Sun& sun) {
  const float centre = z.at(c, r);
  if (std::isnan(centre)) return kVoidColour;
  const int w = z.width(), h = z.height();
  auto value = [&](int cc, int rr) {
    const float v = z.at(cc, rr);
    return std::isnan(v) ? static_cast<double>(centre) : static_cast<double>(v);
  };
  const int cw = std::max(c - 1, 0), ce = std::min(c + 1, w - 1);
  const int rn = std::max(r - 1, 0), rs = std::min(r + 1, h - 1);
  const double dzdx = ce > cw ? (value(ce, r) - value(cw, r)) / ((ce - cw) * o.metres_per_col) : 0.0;
  const double dzdn = rs > rn ? (value(c, rn) - value(c, rs)) / ((rs - rn) * o.metres_per_row) : 0.0;
  const double len = std::sqrt(dzdx * dzdx + dzdn * dzdn + 1.0);
  const double shade = std::max(0.0, (-dzdx * sun.e - dzdn * sun.n + sun.u) / len);
  const double g = 255.0 * shade;
  if (!vis.empty()) {
    const std::uint8_t v = vis.at(c, r);
    if (v == 1) return {0.55 * g, 0.55 * g + 0.45 * 235.0, 0.55 * g + 0.45 * 60.0};
    if (v == 0) return {0.45 * g + 0.25 * 200.0, 0.30 * g, 0.30 * g};
    if (v == 2) return {0.55 * g + 0.45 * 240.0, 0.55 * g + 0.45 * 170.0, 0.55 * g};
  }
  return {g, g, g};
}

void draw_observer(std::vector<std::uint8_t>& rgb, int w, int h, double ox, double oy) {
  const double radius = std::max(5.0, 0.015 * std::max(w, h));
  const double dot = std::max(2.0, radius / 3.0);
  const int x0 = std::max(0, static_cast<int>(std::floor(ox - radius - 3)));
  const int x1 = std::min(w - 1, static_cast<int>(std::ceil(ox + radius + 3)));
  const int y0 = std::max(0, static_cast<int>(std::floor(oy - radius - 3)));
  const int y1 = std::min(h - 1, static_cast<int>(std::ceil(oy + radius + 3)));
  for (int y = y0; y <= y1; ++y) {
    for (int x = x0; x <= x1; ++x) {
      const double d = std::hypot(x - ox, y - oy);
      const double ring = std::abs(d - radius);
      const std::array<std::uint8_t, 3>* colour = nullptr;
      if (ring <= 1.0 || d <= dot)
        colour = &kMarker;
      else if (ring <= 2.0 || (d <= dot + 1.0))
        colour = &kMarkerOutline;
      if (!colour) continue;
      std::uint8_t* p = rgb.data() + (static_cast<std::size_t>(y) * w + x) * 3;
      p[0] = (*colour)[0];
      p[1] = (*colour)[1];
      p[2] = (*colour)[2];
    }
  }
}

}  // namespace

Status write_viewshed_preview(const std::string& path, const Grid<float>& elevation,
                              const Grid<std::uint8_t>& visibility, const PreviewOptions& options) {
  if (elevation.empty()) return preview_error(ErrorCode::kInvalidArgument, path, "elevation grid is empty");
  if (!visibility.empty() && (visibility.width() != elevation.width() || visibility.height() != elevation.height()))
    return preview_error(ErrorCode::kInvalidArgument, path,
                         "visibility grid is " + std::to_string(visibility.width()) + "x" +
                             std::to_string(visibility.height()) + " but elevation is " +
                             std::to_string(elevation.width()) + "x" + std::to_string(elevation.height()),
                         "visibility");
  if (!(options.metres_per_col > 0.0) || !(options.metres_per_row > 0.0) || !std::isfinite(options.metres_per_col) ||
      !std::isfinite(options.metres_per_row))
    return preview_error(ErrorCode::kInvalidArgument, path, "cell sizes must be finite and positive", "metres_per_col");
  if (options.max_size < 1)
    return preview_error(ErrorCode::kInvalidArgument, path, "max_size must be at least 1", "max_size");
  if (options.observer_col.has_value() != options.observer_row.has_value() ||
      (options.observer_col && (!std::isfinite(*options.observer_col) || !std::isfinite(*options.observer_row))))
    return preview_error(ErrorCode::kInvalidArgument, path, "observer needs both a finite column and row", "observer");

  const int w = elevation.width(), h = elevation.height();
  const int longest = std::max(w, h);
  const int factor = (longest + options.max_size - 1) / options.max_size;
  const int out_w = (w + factor - 1) / factor;
  const int out_h = (h + factor - 1) / factor;

  // Box filter: sum the colours of every cell into its output pixel.
  const Sun sun = make_sun();
  std::vector<double> sums(static_cast<std::size_t>(out_w) * out_h * 3, 0.0);
  std::vector<std::uint32_t> counts(static_cast<std::size_t>(out_w) * out_h, 0);
  for (int r = 0; r < h; ++r) {
    const std::size_t out_row = static_cast<std::size_t>(r / factor) * out_w;
    for (int c = 0; c < w; ++c) {
      const Rgb colour = cell_colour(elevation, visibility, c, r, options, sun);
      const std::size_t i = out_row + c / factor;
      sums[3 * i] += colour[0];
      sums[3 * i + 1] += colour[1];
      sums[3 * i + 2] += colour[2];
      ++counts[i];
    }
  }
  std::vector<std::uint8_t> rgb(sums.size());
  for (std::size_t i = 0; i < counts.size(); ++i)
    for (int k = 0; k < 3; ++k)
      rgb[3 * i + k] = static_cast<std::uint8_t>(std::clamp(std::lround(sums[3 * i + k] / counts[i]), 0L, 255L));

  if (options.observer_col) {
    // Cell c covers output pixels' [c/f, (c+1)/f); its centre is at (c + 0.5)/f - 0.5
    // in output coordinates with pixel centres on integers.
    draw_observer(rgb, out_w, out_h, (*options.observer_col + 0.5) / factor - 0.5,
                  (*options.observer_row + 0.5) / factor - 0.5);
  }

  detail::AtomicFile file(path);
  HORIZON_RETURN_IF_ERROR(file.create("preview"));
  if (Status written = imageio::write_png(file.temp_path(), out_w, out_h, 3, rgb.data()); !written.ok())
    return preview_error(written.error().code, path, written.error().message);
  return file.commit("preview");
}

}  // namespace horizon::terrain
