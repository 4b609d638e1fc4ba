// What a traced frame gives (horizon/trace/products.hpp).
#include "horizon/trace/products.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "../terrain/atomic_file.hpp"
#include "horizon/common/parallel.hpp"
#include "horizon/imageio/imageio.hpp"

namespace horizon::trace {
namespace {

constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();

struct Rgb {
  double r, g, b;
};

Rgb mix(Rgb a, Rgb b, double t) {
  return {a.r + (b.r - a.r) * t, a.g + (b.g - a.g) * t, a.b + (b.b - a.b) * t};
}

// Elevation tint, t in [0, 1] over the frame's range: lowland green, upland
// olive and brown, rock grey, snow white.
Rgb tint(double t) {
  static const Rgb stops[] = {
      {0.28, 0.50, 0.26}, {0.55, 0.60, 0.33}, {0.56, 0.45, 0.31}, {0.58, 0.56, 0.55}, {0.95, 0.95, 0.97}};
  t = std::clamp(t, 0.0, 1.0) * 4.0;
  const int i = std::min(3, static_cast<int>(t));
  return mix(stops[i], stops[i + 1], t - i);
}

std::uint8_t byte(double v) {
  return static_cast<std::uint8_t>(std::lround(std::clamp(v, 0.0, 1.0) * 255.0));
}

}  // namespace

terrain::Grid<float> depth_image(const TraceResult& frame) {
  const TraceImage& im = frame.image;
  terrain::Grid<float> depth(im.width, im.height, terrain::kUninitialized);
  for (int j = 0; j < im.height; ++j)
    for (int x = 0; x < im.width; ++x) {
      const Hit h = frame.hit(x, j);
      depth.at(x, j) = h.sky ? kNaN : static_cast<float>(h.range);
    }
  return depth;
}

HitImages hit_images(const TraceResult& frame, int col_offset, int row_offset) {
  const TraceImage& im = frame.image;
  HitImages out{terrain::Grid<float>(im.width, im.height, terrain::kUninitialized),
                terrain::Grid<float>(im.width, im.height, terrain::kUninitialized),
                terrain::Grid<float>(im.width, im.height, terrain::kUninitialized)};
  for (int j = 0; j < im.height; ++j)
    for (int x = 0; x < im.width; ++x) {
      const Hit h = frame.hit(x, j);
      out.col.at(x, j) = h.sky ? kNaN : static_cast<float>(h.col + col_offset);
      out.row.at(x, j) = h.sky ? kNaN : static_cast<float>(h.row + row_offset);
      out.elevation.at(x, j) = h.sky ? kNaN : static_cast<float>(h.elevation);
    }
  return out;
}

std::vector<std::uint8_t> shaded_view(const TraceResult& frame, const terrain::HeightView& view) {
  const TraceImage& im = frame.image;
  const Camera& cam = frame.camera;
  std::vector<Hit> hits(static_cast<std::size_t>(im.width) * static_cast<std::size_t>(im.height));
  double z_lo = std::numeric_limits<double>::infinity(), z_hi = -z_lo, far = 0.0;
  for (int j = 0; j < im.height; ++j)
    for (int x = 0; x < im.width; ++x) {
      Hit& h = hits[static_cast<std::size_t>(j) * static_cast<std::size_t>(im.width) + static_cast<std::size_t>(x)];
      h = frame.hit(x, j);
      if (h.sky) continue;
      z_lo = std::min(z_lo, h.elevation);
      z_hi = std::max(z_hi, h.elevation);
      far = std::max(far, h.range);
    }
  const double span = z_hi > z_lo ? z_hi - z_lo : 1.0;
  const double haze_scale = std::max(far, 1.0) * 0.6;  // half the light lost ~0.4 of the way out
  const Rgb haze{0.80, 0.85, 0.90}, zenith{0.30, 0.50, 0.85};
  // The sun: from the north-west, 45 degrees up (x east, y north, z up).
  const double sun[3] = {-0.5, 0.5, std::sqrt(0.5)};
  std::vector<std::uint8_t> rgb(hits.size() * 3);
  for (int j = 0; j < im.height; ++j)
    for (int x = 0; x < im.width; ++x) {
      const std::size_t i =
          static_cast<std::size_t>(j) * static_cast<std::size_t>(im.width) + static_cast<std::size_t>(x);
      const Hit& h = hits[i];
      Rgb c;
      if (h.sky) {
        const double up = std::clamp(std::atan(cam.slope(x, j)) / (M_PI / 3.0), 0.0, 1.0);
        c = mix(haze, zenith, up * (2.0 - up));  // eases in from the horizon
      } else {
        // The terrain's slope at the hit: central differences at the four
        // cells around it, blended bilinearly (smooth shading, no facets).
        double dzdx = 0.0, dzdy = 0.0;
        const double fc = std::clamp(h.col, 1.0, view.width() - 2.0), fr = std::clamp(h.row, 1.0, view.height() - 2.0);
        const int c0 = std::min(static_cast<int>(fc), view.width() - 3),
                  r0 = std::min(static_cast<int>(fr), view.height() - 3);
        double weight = 0.0;
        for (int dr = 0; dr < 2; ++dr)
          for (int dc = 0; dc < 2; ++dc) {
            const int cc = c0 + dc, rr = r0 + dr;
            const double w = (dc ? fc - c0 : 1.0 - (fc - c0)) * (dr ? fr - r0 : 1.0 - (fr - r0));
            const double gx = (view.at(cc + 1, rr) - view.at(cc - 1, rr)) / (2.0 * cam.metres_per_col);
            const double gy = (view.at(cc, rr - 1) - view.at(cc, rr + 1)) / (2.0 * cam.metres_per_row);
            if (!std::isfinite(gx) || !std::isfinite(gy)) continue;
            dzdx += w * gx;
            dzdy += w * gy;
            weight += w;
          }
        if (weight > 0) {
          dzdx /= weight;
          dzdy /= weight;
        }
        const double norm = std::sqrt(dzdx * dzdx + dzdy * dzdy + 1.0);
        const double light = std::max(0.0, (-dzdx * sun[0] - dzdy * sun[1] + sun[2]) / norm);
        const Rgb base = tint((h.elevation - z_lo) / span);
        const double lit = 0.35 + 0.75 * light;
        c = {base.r * lit, base.g * lit, base.b * lit};
        c = mix(c, haze, 1.0 - std::exp(-h.range / haze_scale));
      }
      rgb[3 * i] = byte(c.r);
      rgb[3 * i + 1] = byte(c.g);
      rgb[3 * i + 2] = byte(c.b);
    }
  return rgb;
}

Status write_shaded_png(const std::string& path, const TraceResult& frame, const terrain::HeightView& view) {
  const std::vector<std::uint8_t> rgb = shaded_view(frame, view);
  terrain::detail::AtomicFile file(path);
  HORIZON_RETURN_IF_ERROR(file.create("view"));
  if (Status written = imageio::write_png(file.temp_path(), frame.image.width, frame.image.height, 3, rgb.data());
      !written.ok())
    return written;
  return file.commit("view");
}

terrain::Grid<std::uint8_t> footprint(const TraceResult& frame, const terrain::HeightView& view) {
  terrain::Grid<std::uint8_t> seen(view.width(), view.height(), 0);
  for (int r = 0; r < view.height(); ++r)
    for (int c = 0; c < view.width(); ++c)
      if (view.is_void(c, r)) seen.at(c, r) = 255;
  const TraceImage& im = frame.image;
  for (int j = 0; j < im.height; ++j)
    for (int x = 0; x < im.width; ++x) {
      const Hit h = frame.hit(x, j);
      if (h.sky) continue;
      const int c = static_cast<int>(std::lround(h.col)), r = static_cast<int>(std::lround(h.row));
      if (c < 0 || r < 0 || c >= view.width() || r >= view.height()) continue;
      std::uint8_t& cell = seen.at(c, r);
      if (cell == 0) cell = 1;
    }
  return seen;
}

namespace {

// Where a column's ray (from the eye, ground direction (dx, dy) in metres
// per metre, east and south) passes through a box's footprint: the ground
// distances [in, out], by the slab method. False when it misses.
bool ray_through(const Camera& cam, double az, const ViewBox& b, double& in, double& out) {
  const double dx = std::sin(az), dy = -std::cos(az);  // metres east / north per metre, as columns and rows grow
  const double ox = cam.eye.col * cam.metres_per_col, oy = cam.eye.row * cam.metres_per_row;
  const double lo[2] = {b.col_min * cam.metres_per_col, b.row_min * cam.metres_per_row};
  const double hi[2] = {b.col_max * cam.metres_per_col, b.row_max * cam.metres_per_row};
  const double o[2] = {ox, oy}, d[2] = {dx, dy};
  in = 0.0;
  out = std::numeric_limits<double>::infinity();
  for (int a = 0; a < 2; ++a) {
    if (std::abs(d[a]) < 1e-15) {
      if (o[a] < lo[a] || o[a] > hi[a]) return false;
      continue;
    }
    double t0 = (lo[a] - o[a]) / d[a], t1 = (hi[a] - o[a]) / d[a];
    if (t0 > t1) std::swap(t0, t1);
    in = std::max(in, t0);
    out = std::min(out, t1);
  }
  return in <= out;
}

// The columns whose azimuths can meet the box, as at most two ranges
// [x0, x1) (a panorama can see one box at both its ends): the columns
// between the azimuths of its corners seen from the eye, with a column's
// margin each side; every column when the eye stands inside the box.
struct ColumnRange {
  int x0 = 0, x1 = 0;
};
int column_ranges(const Camera& cam, const ViewBox& b, ColumnRange out[2]) {
  const int width = cam.spec.width;
  if (cam.eye.col >= b.col_min && cam.eye.col <= b.col_max && cam.eye.row >= b.row_min && cam.eye.row <= b.row_max) {
    out[0] = {0, width};
    return 1;
  }
  // Corner azimuths relative to the yaw, unwrapped around the box's centre
  // (the box spans less than half a turn from outside it).
  const double yaw = cam.spec.yaw * M_PI / 180.0;
  auto rel = [&](double c, double r) {
    const double east = (c - cam.eye.col) * cam.metres_per_col, north = (cam.eye.row - r) * cam.metres_per_row;
    return std::remainder(std::atan2(east, north) - yaw, 2.0 * M_PI);
  };
  const double centre = rel((b.col_min + b.col_max) / 2, (b.row_min + b.row_max) / 2);
  double lo = centre, hi = centre;
  for (double c : {b.col_min, b.col_max})
    for (double r : {b.row_min, b.row_max}) {
      const double a = centre + std::remainder(rel(c, r) - centre, 2.0 * M_PI);
      lo = std::min(lo, a);
      hi = std::max(hi, a);
    }
  // The camera's relative azimuths rise with x inside [-pi, pi]; [lo, hi]
  // may poke out of that range at one end: that piece wraps to the other.
  auto range_of = [&](double a0, double a1) {
    const auto begin = std::lower_bound(cam.azimuth.begin(), cam.azimuth.end(), yaw + a0);
    const auto end = std::upper_bound(cam.azimuth.begin(), cam.azimuth.end(), yaw + a1);
    ColumnRange r{std::max(0, static_cast<int>(begin - cam.azimuth.begin()) - 1),
                  std::min(width, static_cast<int>(end - cam.azimuth.begin()) + 1)};
    return r;
  };
  int n = 0;
  auto add = [&](double a0, double a1) {
    if (a0 > a1) return;
    const ColumnRange r = range_of(a0, a1);
    if (r.x0 < r.x1) out[n++] = r;
  };
  add(std::max(lo, -M_PI), std::min(hi, M_PI));
  if (hi > M_PI) add(-M_PI, hi - 2.0 * M_PI);
  if (lo < -M_PI) add(lo + 2.0 * M_PI, M_PI);
  return n;
}

}  // namespace

std::uint64_t box_pixel_bound(const Camera& camera, std::span<const ViewBox> boxes) {
  std::uint64_t bound = 0;
  ColumnRange ranges[2];
  for (const ViewBox& b : boxes) {
    const int n = column_ranges(camera, b, ranges);
    for (int i = 0; i < n; ++i)
      bound += static_cast<std::uint64_t>(ranges[i].x1 - ranges[i].x0) * static_cast<std::uint64_t>(camera.spec.height);
  }
  return bound;
}

Result<std::vector<BoxView>> box_views(const TraceResult& frame, std::span<const ViewBox> boxes,
                                       const TraceOptions& options, const RunControl* control) {
  const Camera& cam = frame.camera;
  const TraceImage& im = frame.image;
  std::vector<BoxView> views(boxes.size());
  auto answer = [&](std::size_t bi) {
    const ViewBox& b = boxes[bi];
    BoxView& view = views[bi];
    auto column = [&](int x) {
      double in = 0, out = 0;
      if (!ray_through(cam, cam.azimuth[static_cast<std::size_t>(x)], b, in, out)) return;
      in = std::max(in, cam.near_distance(x, options.near));
      out = std::min(out, options.max_distance);
      if (!(in <= out) || out <= 0.0) return;
      // The box lowered by curvature at its mid-depth, relative to the eye.
      const double mid = 0.5 * (in + out);
      const double drop = frame.curvature * mid * mid;
      const double lo = b.z_min - cam.eye.elevation - drop, hi = b.z_max - cam.eye.elevation - drop;
      for (int j = 0; j < im.height; ++j) {
        const double s = cam.slope(x, j);
        // The ray's stretch inside the box's heights, within [in, out].
        double enter = in, leave = out;
        if (s > 0) {
          enter = std::max(enter, lo / s);
          leave = std::min(leave, hi / s);
        } else if (s < 0) {
          enter = std::max(enter, hi / s);
          leave = std::min(leave, lo / s);
        } else if (lo > 0 || hi < 0) {
          continue;
        }
        if (!(enter <= leave)) continue;
        ++view.pixels;
        const float hit =
            im.distance[static_cast<std::size_t>(j) * static_cast<std::size_t>(im.width) + static_cast<std::size_t>(x)];
        if (enter < hit) ++view.visible;
      }
    };
    ColumnRange ranges[2];
    const int n = column_ranges(cam, b, ranges);
    for (int piece = 0; piece < n; ++piece)
      for (int x = ranges[piece].x0; x < ranges[piece].x1; ++x) column(x);
  };
  HORIZON_RETURN_IF_ERROR(parallel_for(boxes.size(), options.threads, control, answer));
  return views;
}

}  // namespace horizon::trace
