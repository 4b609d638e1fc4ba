// preview.cpp — a PNG a person reads at once: title, map, legend, scale bar,
// north arrow (preview.hpp).
//
// Hillshade: Lambertian shading of the terrain normal under a sun at azimuth
// 315 degrees (north-west) and 45 degrees altitude — the cartographic
// convention (Yoëli 1965; the default of GDAL's gdaldem hillshade). The
// normal comes from central differences over *metric* cell sizes, so a
// geographic DEM (cells narrower east-west than north-south) is not shaded as
// if it were stretched:
//   n = (-dz/dx_east, -dz/dy_north, 1) / |...|,   shade = max(0, n . sun).
// Rows grow south, so dz/dy_north = (z[r-1] - z[r+1]) / (2 * metres_per_row).
// A void neighbour is replaced by the centre cell (a locally flat surface).
//
// Colours: Okabe & Ito, "Color Universal Design" (2008) for the classes;
// viridis (van der Walt & Smith, matplotlib 2015) and ColorBrewer's YlOrRd
// and Blues (Brewer 2003) for the ramps, each monotonic in lightness so that
// they read in grey and under the common colour-vision deficiencies. A
// class or ramp colour is multiplied by the hillshade's light relative to
// flat ground, k = 0.55 + 0.45 * shade / sin(45 degrees) (clamped), so flat
// ground shows the legend's colour exactly and the relief stays readable.
//
// Geometry: the map is drawn at a single scale of `s` ground metres a pixel
// on both axes (true aspect). Each map pixel averages the cells whose
// centres fall inside it, or (enlarged maps) shows the cell under its
// centre; a pixel most of whose cells are voids is hatched. Marks (the
// observers, the reach rings, a region's box) are drawn after, at map
// resolution, clipped to the map.
//
// PNG (ISO/IEC 15948) written through OpenImageIO (imageio.hpp, loaded on first
// use); atomic via atomic_file.hpp.
#include "horizon/terrain/preview.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <functional>
#include <numbers>
#include <string>
#include <vector>

#include "atomic_file.hpp"
#include "horizon/imageio/imageio.hpp"

namespace horizon::terrain {
namespace {

constexpr const char* kFont = "DejaVuSans";
constexpr const char* kBoldFont = "DejaVuSans-Bold";
constexpr int kMargin = 14;  // around everything
constexpr int kGap = 18;     // between the map and the legend
constexpr int kLegendWidth = 270;
constexpr int kHeadingSize = 18;  // the title's first line
constexpr int kTextSize = 13;     // everything else
constexpr int kRowHeight = 22;    // one legend entry
constexpr int kSwatchWidth = 30, kSwatchHeight = 16;
constexpr int kMaxRingedSites = 12;

constexpr Rgb8 kWhite = {255, 255, 255};
constexpr Rgb8 kInk = {20, 20, 20};
constexpr Rgb8 kFrame = {70, 70, 70};

Error preview_error(ErrorCode code, const std::string& path, const std::string& what, std::string field = {}) {
  return make_error(code, "preview '" + path + "': " + what, field.empty() ? path : std::move(field));
}

// ---------------------------------------------------------------- colours

using Rgbf = std::array<double, 3>;

const double kFlatShade = std::sin(45.0 * std::numbers::pi / 180.0);

Rgb8 to8(const Rgbf& c) {
  Rgb8 out;
  for (int k = 0; k < 3; ++k) out[k] = static_cast<std::uint8_t>(std::clamp(std::lround(c[k]), 0L, 255L));
  return out;
}

// A colour lit like the terrain under it: exact on flat ground.
Rgbf lit(Rgb8 colour, double shade) {
  const double k = std::clamp(0.55 + 0.45 * shade / kFlatShade, 0.3, 1.3);
  return {std::min(255.0, colour[0] * k), std::min(255.0, colour[1] * k), std::min(255.0, colour[2] * k)};
}

// The hillshade lightened: terrain without an answer (flat: kPreviewBeyond).
Rgbf beyond(double shade) {
  const double g = 150.0 + 0.4 * 255.0 * shade;
  return {g, g, g};
}

Rgb8 interpolate(const Rgb8* stops, std::size_t n, double t) {
  t = std::clamp(t, 0.0, 1.0) * static_cast<double>(n - 1);
  const std::size_t i = std::min(static_cast<std::size_t>(t), n - 2);
  const double f = t - static_cast<double>(i);
  Rgbf c;
  for (int k = 0; k < 3; ++k) c[k] = stops[i][k] + f * (stops[i + 1][k] - stops[i][k]);
  return to8(c);
}

constexpr Rgb8 kViridis[] = {{68, 1, 84},    {72, 40, 120},  {62, 74, 137},  {49, 104, 142}, {38, 130, 142},
                             {31, 158, 137}, {53, 183, 121}, {109, 205, 89}, {180, 222, 44}, {253, 231, 37}};
constexpr Rgb8 kYlOrRd[] = {{255, 237, 160}, {254, 217, 118}, {254, 178, 76}, {253, 141, 60},
                            {252, 78, 42},   {227, 26, 28},   {189, 0, 38},   {128, 0, 38}};
constexpr Rgb8 kBlues[] = {{107, 174, 214}, {66, 146, 198}, {33, 113, 181}, {8, 81, 156}, {8, 48, 107}};

// ---------------------------------------------------------------- the terrain

struct Shading {
  const Grid<float>& z;
  double metres_per_col, metres_per_row;
  double sun_e, sun_n, sun_u;

  Shading(const Grid<float>& elevation, const PreviewOptions& o)
      : z(elevation), metres_per_col(o.metres_per_col), metres_per_row(o.metres_per_row) {
    const double az = 315.0 * std::numbers::pi / 180.0;
    const double alt = 45.0 * std::numbers::pi / 180.0;
    sun_e = std::cos(alt) * std::sin(az);
    sun_n = std::cos(alt) * std::cos(az);
    sun_u = std::sin(alt);
  }

  // The light on cell (c, r), [0, 1]; NaN on a void.
  double shade(int c, int r) const {
    const float centre = z.at(c, r);
    if (std::isnan(centre)) return std::numeric_limits<double>::quiet_NaN();
    const int w = z.width(), h = z.height();
    auto value = [&](int cc, int rr) {
      const float v = z.at(cc, rr);
      return std::isnan(v) ? static_cast<double>(centre) : static_cast<double>(v);
    };
    const int cw = std::max(c - 1, 0), ce = std::min(c + 1, w - 1);
    const int rn = std::max(r - 1, 0), rs = std::min(r + 1, h - 1);
    const double dzdx = ce > cw ? (value(ce, r) - value(cw, r)) / ((ce - cw) * metres_per_col) : 0.0;
    const double dzdn = rs > rn ? (value(c, rn) - value(c, rs)) / ((rs - rn) * metres_per_row) : 0.0;
    const double len = std::sqrt(dzdx * dzdx + dzdn * dzdn + 1.0);
    return std::max(0.0, (-dzdx * sun_e - dzdn * sun_n + sun_u) / len);
  }
};

// What the map shows in each cell, given its light (never called on a void).
using CellColour = std::function<Rgbf(int c, int r, double shade)>;

// ---------------------------------------------------------------- a picture in memory

struct Picture {
  int width = 0, height = 0;
  std::vector<std::uint8_t> rgb;

  Picture(int w, int h) : width(w), height(h), rgb(static_cast<std::size_t>(w) * h * 3, 255) {}

  void set(int x, int y, Rgb8 c) {
    if (x < 0 || y < 0 || x >= width || y >= height) return;
    std::uint8_t* p = rgb.data() + (static_cast<std::size_t>(y) * width + x) * 3;
    p[0] = c[0];
    p[1] = c[1];
    p[2] = c[2];
  }
  // [x0, x1) x [y0, y1)
  void fill(int x0, int y0, int x1, int y1, Rgb8 c) {
    for (int y = std::max(y0, 0); y < std::min(y1, height); ++y)
      for (int x = std::max(x0, 0); x < std::min(x1, width); ++x) set(x, y, c);
  }
  void outline(int x0, int y0, int x1, int y1, Rgb8 c) {
    fill(x0, y0, x1, y0 + 1, c);
    fill(x0, y1 - 1, x1, y1, c);
    fill(x0, y0, x0 + 1, y1, c);
    fill(x1 - 1, y0, x1, y1, c);
  }
  void hatch(int x0, int y0, int x1, int y1) {
    for (int y = std::max(y0, 0); y < std::min(y1, height); ++y)
      for (int x = std::max(x0, 0); x < std::min(x1, width); ++x)
        set(x, y, (x + y) % 6 < 2 ? kPreviewVoidDark : kPreviewVoidLight);
  }
  // Pixels whose centres lie within `radius` of (cx, cy) (continuous pixel coordinates).
  void disc(double cx, double cy, double radius, Rgb8 c) {
    for (int y = static_cast<int>(std::floor(cy - radius)); y <= static_cast<int>(std::ceil(cy + radius)); ++y)
      for (int x = static_cast<int>(std::floor(cx - radius)); x <= static_cast<int>(std::ceil(cx + radius)); ++x)
        if (std::hypot(x + 0.5 - cx, y + 0.5 - cy) <= radius) set(x, y, c);
  }
  // The triangle (a, b, c), filled.
  void triangle(std::array<double, 2> a, std::array<double, 2> b, std::array<double, 2> c, Rgb8 colour) {
    auto edge = [](const std::array<double, 2>& p, const std::array<double, 2>& q, double x, double y) {
      return (q[0] - p[0]) * (y - p[1]) - (q[1] - p[1]) * (x - p[0]);
    };
    const int x0 = static_cast<int>(std::floor(std::min({a[0], b[0], c[0]})));
    const int x1 = static_cast<int>(std::ceil(std::max({a[0], b[0], c[0]})));
    const int y0 = static_cast<int>(std::floor(std::min({a[1], b[1], c[1]})));
    const int y1 = static_cast<int>(std::ceil(std::max({a[1], b[1], c[1]})));
    for (int y = y0; y <= y1; ++y)
      for (int x = x0; x <= x1; ++x) {
        const double px = x + 0.5, py = y + 0.5;
        const double e0 = edge(a, b, px, py), e1 = edge(b, c, px, py), e2 = edge(c, a, px, py);
        if ((e0 >= 0 && e1 >= 0 && e2 >= 0) || (e0 <= 0 && e1 <= 0 && e2 <= 0)) set(x, y, colour);
      }
  }
};

// A rectangle marks may be drawn in.
struct Clip {
  int x0, y0, x1, y1;
  bool inside(int x, int y) const { return x >= x0 && x < x1 && y >= y0 && y < y1; }
};

// A dashed ring, `width` pixels wide with a one-pixel white halo, clipped.
void dashed_ring(Picture& p, const Clip& clip, double cx, double cy, double radius, double width) {
  const double outer = radius + width / 2 + 1.0;
  const double circumference = 2 * std::numbers::pi * radius;
  const int dashes = std::max(8, static_cast<int>(circumference / 16.0));  // ~11 px on, ~5 off
  const int y0 = std::max(clip.y0, static_cast<int>(std::floor(cy - outer)));
  const int y1 = std::min(clip.y1, static_cast<int>(std::ceil(cy + outer)) + 1);
  const int x0 = std::max(clip.x0, static_cast<int>(std::floor(cx - outer)));
  const int x1 = std::min(clip.x1, static_cast<int>(std::ceil(cx + outer)) + 1);
  for (int y = y0; y < y1; ++y)
    for (int x = x0; x < x1; ++x) {
      const double dx = x + 0.5 - cx, dy = y + 0.5 - cy;
      const double off = std::abs(std::hypot(dx, dy) - radius);
      if (off > width / 2 + 1.0) continue;
      const double turn = (std::atan2(dy, dx) + std::numbers::pi) / (2 * std::numbers::pi);  // [0, 1]
      const double phase = turn * dashes - std::floor(turn * dashes);
      if (phase > 0.7) continue;
      p.set(x, y, off <= width / 2 ? kInk : kWhite);
    }
}

void observer_mark(Picture& p, const Clip& clip, double cx, double cy, bool small) {
  const double r = small ? 4.0 : 7.0;
  auto disc = [&](double radius, Rgb8 c) {
    for (int y = static_cast<int>(std::floor(cy - radius)); y <= static_cast<int>(std::ceil(cy + radius)); ++y)
      for (int x = static_cast<int>(std::floor(cx - radius)); x <= static_cast<int>(std::ceil(cx + radius)); ++x)
        if (clip.inside(x, y) && std::hypot(x + 0.5 - cx, y + 0.5 - cy) <= radius) p.set(x, y, c);
  };
  disc(r, kWhite);
  disc(r - 1.5, kInk);
  if (!small) disc(2.0, kWhite);
}

// ---------------------------------------------------------------- text

struct Words {
  bool have_font = true;

  int width(const std::string& s, int size, bool bold = false) {
    if (have_font)
      if (auto w = imageio::text_width(s, size, bold ? kBoldFont : kFont)) return *w;
    have_font = false;
    return static_cast<int>(s.size() * size * 0.6);
  }
  // Splits `line` at spaces into lines at most `max_width` pixels wide (a
  // word wider than that stands alone).
  std::vector<std::string> wrap(const std::string& line, int size, bool bold, int max_width) {
    std::vector<std::string> out;
    std::string current;
    for (std::size_t start = 0; start <= line.size();) {
      std::size_t end = line.find(' ', start);
      if (end == std::string::npos) end = line.size();
      const std::string word = line.substr(start, end - start);
      start = end + 1;
      if (word.empty()) continue;
      const std::string joined = current.empty() ? word : current + " " + word;
      if (!current.empty() && width(joined, size, bold) > max_width) {
        out.push_back(current);
        current = word;
      } else {
        current = joined;
      }
    }
    if (!current.empty()) out.push_back(current);
    return out;
  }
};

struct Text {
  int x, baseline;
  std::string s;
  int size;
  bool bold;
  int align;  // 0 left, 1 centred, 2 right
};

// ---------------------------------------------------------------- numbers

std::string number(double v, int decimals) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.*f", decimals, v);
  std::string s = buf;
  if (s == "-0") s = "0";
  return s;
}

// The least of 1, 1.5, 2, 2.5, 3, 4, 5, 6, 8 times a power of ten that is >= x (x > 0).
double nice_ceil(double x) {
  const double e = std::pow(10.0, std::floor(std::log10(x)));
  for (double m : {1.0, 1.5, 2.0, 2.5, 3.0, 4.0, 5.0, 6.0, 8.0, 10.0})
    if (m * e >= x * (1 - 1e-12)) return m * e;
  return 10 * e;
}
// The greatest of 1, 2, 5 times a power of ten that is <= x (x > 0).
double nice_floor(double x) {
  const double e = std::pow(10.0, std::floor(std::log10(x)));
  for (double m : {5.0, 2.0, 1.0})
    if (m * e <= x * (1 + 1e-12)) return m * e;
  return e;
}

std::string distance_label(double metres) {
  if (metres >= 1000.0) {
    const double km = metres / 1000.0;
    return number(km, std::abs(km - std::round(km)) < 1e-9 ? 0 : 1) + " km";
  }
  return number(metres, 0) + " m";
}

// ---------------------------------------------------------------- the picture

// What the legend lists, besides the scale and the arrow.
struct LegendEntry {
  enum Kind { kSwatch, kHatch, kObserver, kRing, kBox } kind = kSwatch;
  Rgb8 colour{};
  std::string label;
};

struct RampBar {
  PreviewRampSpec spec;
  double low = 0.0, high = 1.0;  // the values at the bar's bottom and top
  std::function<Rgb8(double t)> colour;
  std::optional<LegendEntry> zero;  // the class of 0 (kHeightNeeded, kCount)
  std::vector<double> ticks;
  int decimals = 0;
  bool discrete = false;     // no bar: the values' classes are listed as legend entries
  bool logarithmic = false;  // positions by log(1 + value)

  // Where `value` lies on the bar, [0, 1] (bottom to top).
  double position(double value) const {
    if (!(high > low)) return 0.5;
    const double t = logarithmic ? std::log1p(value - low) / std::log1p(high - low) : (value - low) / (high - low);
    return std::clamp(t, 0.0, 1.0);
  }
};

struct Geometry {
  double s = 1.0;  // metres a pixel
  int map_w = 1, map_h = 1;
};

Geometry map_geometry(int w, int h, const PreviewOptions& o) {
  const double ex = w * o.metres_per_col, ey = h * o.metres_per_row;
  const double longest = std::max(ex, ey);
  Geometry g;
  g.s = std::min(o.metres_per_col, o.metres_per_row);  // the finer cell side: no detail lost
  if (longest / g.s > o.max_size)
    g.s = longest / o.max_size;
  else if (longest / g.s < std::min(o.min_size, o.max_size))
    g.s = longest / std::min(o.min_size, o.max_size);
  g.map_w = std::max(1, static_cast<int>(std::lround(ex / g.s)));
  g.map_h = std::max(1, static_cast<int>(std::lround(ey / g.s)));
  return g;
}

// For each of `out` pixels, the cells [first, last) it shows: those whose
// centres fall in it, or the one under its centre.
std::vector<std::pair<int, int>> spans(int out, int cells, double cell_m, double pixel_m) {
  std::vector<std::pair<int, int>> v(static_cast<std::size_t>(out));
  for (int p = 0; p < out; ++p) {
    int lo = static_cast<int>(std::ceil(p * pixel_m / cell_m - 0.5));
    int hi = static_cast<int>(std::ceil((p + 1) * pixel_m / cell_m - 0.5));
    lo = std::clamp(lo, 0, cells);
    hi = std::clamp(hi, 0, cells);
    if (lo >= hi) {
      lo = std::clamp(static_cast<int>(std::floor((p + 0.5) * pixel_m / cell_m)), 0, cells - 1);
      hi = lo + 1;
    }
    v[static_cast<std::size_t>(p)] = {lo, hi};
  }
  return v;
}

Status check_inputs(const std::string& path, const Grid<float>& elevation, int w, int h, const PreviewOptions& o,
                    const char* what) {
  if (elevation.empty()) return preview_error(ErrorCode::kInvalidArgument, path, "elevation grid is empty");
  if (w != elevation.width() || h != elevation.height())
    return preview_error(ErrorCode::kInvalidArgument, path,
                         std::string(what) + " grid is " + std::to_string(w) + "x" + std::to_string(h) +
                             " but elevation is " + std::to_string(elevation.width()) + "x" +
                             std::to_string(elevation.height()),
                         what);
  if (!(o.metres_per_col > 0.0) || !(o.metres_per_row > 0.0) || !std::isfinite(o.metres_per_col) ||
      !std::isfinite(o.metres_per_row))
    return preview_error(ErrorCode::kInvalidArgument, path, "cell sizes must be finite and positive", "metres_per_col");
  if (o.max_size < 1)
    return preview_error(ErrorCode::kInvalidArgument, path, "max_size must be at least 1", "max_size");
  for (const PreviewSite& site : o.observers)
    if (!std::isfinite(site.col) || !std::isfinite(site.row) || !(site.reach_m > 0.0))
      return preview_error(ErrorCode::kInvalidArgument, path,
                           "an observer needs a finite column and row and a positive reach", "observer");
  if (o.region && !(std::isfinite(o.region->col0) && std::isfinite(o.region->row0) && std::isfinite(o.region->col1) &&
                    std::isfinite(o.region->row1)))
    return preview_error(ErrorCode::kInvalidArgument, path, "the region needs finite corners", "region");
  return Status::Ok();
}

Status draw(const std::string& path, const Grid<float>& elevation, const CellColour& colour,
            std::vector<LegendEntry> classes, const RampBar* ramp, bool any_void, bool any_beyond,
            const PreviewOptions& o, PreviewLayout* layout_out) {
  const int w = elevation.width(), h = elevation.height();
  const Geometry g = map_geometry(w, h, o);
  Words words;

  // Legend entries, top to bottom.
  if (any_beyond) classes.push_back({LegendEntry::kSwatch, kPreviewBeyond, o.classes.beyond});
  if (any_void) classes.push_back({LegendEntry::kHatch, {}, "no data (void in the DEM)"});
  const bool ring_sites = o.observers.size() <= kMaxRingedSites;
  if (!o.observers.empty())
    classes.push_back({LegendEntry::kObserver,
                       {},
                       o.observers.size() == 1 ? "observer" : std::to_string(o.observers.size()) + " observers"});
  if (ring_sites && !o.observers.empty() && std::isfinite(o.observers.front().reach_m)) {
    bool same = true;
    for (const PreviewSite& site : o.observers) same = same && site.reach_m == o.observers.front().reach_m;
    classes.push_back({LegendEntry::kRing,
                       {},
                       same ? "reach: " + distance_label(o.observers.front().reach_m) : "each observer's reach"});
  }
  if (o.region) classes.push_back({LegendEntry::kBox, {}, "viewpoint region"});

  // Layout: title band, then the map and the legend side by side.
  const int legend_w = kLegendWidth;
  const int width = kMargin + g.map_w + kGap + legend_w + kMargin;
  std::vector<Text> texts;
  int y = kMargin;
  for (std::size_t i = 0; i < o.title.size(); ++i) {
    const bool heading = i == 0;
    const int size = heading ? kHeadingSize : kTextSize;
    for (const std::string& line : words.wrap(o.title[i], size, heading, width - 2 * kMargin)) {
      const int line_h = heading ? 24 : 18;
      texts.push_back({kMargin, y + (heading ? 18 : 13), line, size, heading, 0});
      y += line_h;
    }
  }
  const int top = o.title.empty() ? kMargin : y + 10;
  const int map_x = kMargin, map_y = top;
  const int lx = map_x + g.map_w + kGap, ly = top;

  // The legend's words and its height (drawn later, once the picture exists).
  const int label_x = kSwatchWidth + 10;
  std::vector<std::string> ramp_heading;
  if (ramp) {
    ramp_heading = words.wrap(ramp->spec.heading, kTextSize, true, legend_w);
    if (!ramp->spec.units.empty()) ramp_heading.push_back("(" + ramp->spec.units + ")");
  }
  if (ramp && ramp->zero) classes.insert(classes.begin(), *ramp->zero);
  std::vector<std::vector<std::string>> labels;
  for (const LegendEntry& e : classes) labels.push_back(words.wrap(e.label, kTextSize, false, legend_w - label_x));
  auto row_height = [&](std::size_t i) { return kRowHeight + 16 * (static_cast<int>(labels[i].size()) - 1); };
  int legend_h = 24;  // "Legend"
  if (ramp) legend_h += static_cast<int>(ramp_heading.size()) * 18 + 6;
  const int bar_h = ramp && !ramp->discrete ? std::clamp(g.map_h / 2, 120, 220) : 0;
  if (bar_h > 0) legend_h += bar_h + 14;
  for (std::size_t i = 0; i < classes.size(); ++i) legend_h += row_height(i);
  legend_h += 14 + 44 + 14 + 40;  // north arrow, scale bar and its labels
  const int height = std::max(map_y + g.map_h, ly + legend_h) + kMargin;

  Picture pic(width, height);

  // The map.
  const Shading shading(elevation, o);
  const auto cols = spans(g.map_w, w, o.metres_per_col, g.s);
  const auto rows = spans(g.map_h, h, o.metres_per_row, g.s);
  for (int py = 0; py < g.map_h; ++py) {
    const auto [r0, r1] = rows[static_cast<std::size_t>(py)];
    for (int px = 0; px < g.map_w; ++px) {
      const auto [c0, c1] = cols[static_cast<std::size_t>(px)];
      Rgbf sum{0, 0, 0};
      int n = 0, voids = 0;
      for (int r = r0; r < r1; ++r)
        for (int c = c0; c < c1; ++c) {
          const double shade = shading.shade(c, r);
          if (std::isnan(shade)) {
            ++voids;
            continue;
          }
          const Rgbf v = colour(c, r, shade);
          sum[0] += v[0];
          sum[1] += v[1];
          sum[2] += v[2];
          ++n;
        }
      const int x = map_x + px, yy = map_y + py;
      if (voids > n)
        pic.set(x, yy, (x + yy) % 6 < 2 ? kPreviewVoidDark : kPreviewVoidLight);
      else
        pic.set(x, yy, to8({sum[0] / n, sum[1] / n, sum[2] / n}));
    }
  }

  // Marks on the map, in map pixels: cell centre c lies at (c + 0.5) * metres / s.
  const Clip map_clip{map_x, map_y, map_x + g.map_w, map_y + g.map_h};
  auto px_of = [&](double col) { return map_x + (col + 0.5) * o.metres_per_col / g.s; };
  auto py_of = [&](double row) { return map_y + (row + 0.5) * o.metres_per_row / g.s; };
  if (o.region) {
    // At least 4 pixels a side, so that a box of one cell still shows.
    const double cx = 0.5 * (px_of(o.region->col0) + px_of(o.region->col1));
    const double cy = 0.5 * (py_of(o.region->row0) + py_of(o.region->row1));
    const double hw = std::max(2.0, 0.5 * std::abs(px_of(o.region->col1) - px_of(o.region->col0)));
    const double hh = std::max(2.0, 0.5 * std::abs(py_of(o.region->row1) - py_of(o.region->row0)));
    const int x0 = static_cast<int>(std::lround(cx - hw)), x1 = static_cast<int>(std::lround(cx + hw));
    const int y0 = static_cast<int>(std::lround(cy - hh)), y1 = static_cast<int>(std::lround(cy + hh));
    for (int k = 0; k < 4; ++k) {
      const Rgb8 c = k == 0 || k == 3 ? kWhite : kInk;
      Picture* pp = &pic;
      auto edge = [&](int ax, int ay, int bx, int by) {
        for (int yy = std::max(ay, map_clip.y0); yy < std::min(by, map_clip.y1); ++yy)
          for (int xx = std::max(ax, map_clip.x0); xx < std::min(bx, map_clip.x1); ++xx) pp->set(xx, yy, c);
      };
      const int d = k - 2;  // -2 .. 1: halo, ink, ink, halo
      edge(x0 + d, y0 + d, x1 - d, y0 + d + 1);
      edge(x0 + d, y1 - d - 1, x1 - d, y1 - d);
      edge(x0 + d, y0 + d, x0 + d + 1, y1 - d);
      edge(x1 - d - 1, y0 + d, x1 - d, y1 - d);
    }
  }
  if (ring_sites)
    for (const PreviewSite& site : o.observers)
      if (std::isfinite(site.reach_m))
        dashed_ring(pic, map_clip, px_of(site.col), py_of(site.row), site.reach_m / g.s, 2.0);
  for (const PreviewSite& site : o.observers)
    observer_mark(pic, map_clip, px_of(site.col), py_of(site.row), o.observers.size() > 1);
  pic.outline(map_x - 1, map_y - 1, map_x + g.map_w + 1, map_y + g.map_h + 1, kFrame);

  // The legend.
  PreviewLayout layout;
  int yy = ly;
  texts.push_back({lx, yy + 15, "Legend", 14, true, 0});
  yy += 24;
  if (ramp) {
    for (std::size_t i = 0; i < ramp_heading.size(); ++i) {
      const bool units = !ramp->spec.units.empty() && i + 1 == ramp_heading.size();
      texts.push_back({lx, yy + 13, ramp_heading[i], kTextSize, !units, 0});
      yy += 18;
    }
    yy += 6;
  }
  if (bar_h > 0) {
    const int bar_x = lx, bar_w = 22;
    const int bar_top = yy + 6, bar_bottom = bar_top + bar_h - 1;
    for (int row = bar_top; row <= bar_bottom; ++row) {
      const double t = bar_h > 1 ? static_cast<double>(bar_bottom - row) / (bar_h - 1) : 1.0;
      pic.fill(bar_x, row, bar_x + bar_w, row + 1, ramp->colour(t));
    }
    pic.outline(bar_x - 1, bar_top - 1, bar_x + bar_w + 1, bar_bottom + 2, kFrame);
    for (double tick : ramp->ticks) {
      const double t = ramp->position(tick);
      const int row = static_cast<int>(std::lround(bar_bottom - t * (bar_h - 1)));
      pic.fill(bar_x + bar_w + 1, row, bar_x + bar_w + 6, row + 1, kInk);
      texts.push_back({bar_x + bar_w + 10, row + 5, number(tick, ramp->decimals), kTextSize, false, 0});
    }
    layout.ramp_x = bar_x;
    layout.ramp_top = bar_top;
    layout.ramp_bottom = bar_bottom;
    layout.ramp_low = ramp->low;
    layout.ramp_high = ramp->high;
    yy = bar_bottom + 14;
  }
  for (std::size_t i = 0; i < classes.size(); ++i) {
    const LegendEntry& e = classes[i];
    const int sx = lx, sy = yy + (kRowHeight - kSwatchHeight) / 2;
    const double cx = sx + kSwatchWidth / 2.0, cy = sy + kSwatchHeight / 2.0;
    const Clip all{0, 0, width, height};
    switch (e.kind) {
      case LegendEntry::kSwatch:
        pic.fill(sx, sy, sx + kSwatchWidth, sy + kSwatchHeight, e.colour);
        pic.outline(sx - 1, sy - 1, sx + kSwatchWidth + 1, sy + kSwatchHeight + 1, kFrame);
        break;
      case LegendEntry::kHatch:
        pic.hatch(sx, sy, sx + kSwatchWidth, sy + kSwatchHeight);
        pic.outline(sx - 1, sy - 1, sx + kSwatchWidth + 1, sy + kSwatchHeight + 1, kFrame);
        break;
      case LegendEntry::kObserver:
        pic.fill(sx, sy, sx + kSwatchWidth, sy + kSwatchHeight, kPreviewBeyond);
        observer_mark(pic, all, cx, cy, o.observers.size() > 1);
        break;
      case LegendEntry::kRing:
        pic.fill(sx, sy, sx + kSwatchWidth, sy + kSwatchHeight, kPreviewBeyond);
        dashed_ring(pic, {sx, sy, sx + kSwatchWidth, sy + kSwatchHeight}, cx, cy + 26.0, 30.0, 2.0);
        break;
      case LegendEntry::kBox:
        pic.fill(sx, sy, sx + kSwatchWidth, sy + kSwatchHeight, kPreviewBeyond);
        pic.outline(sx + 5, sy + 2, sx + kSwatchWidth - 5, sy + kSwatchHeight - 2, kInk);
        pic.outline(sx + 6, sy + 3, sx + kSwatchWidth - 6, sy + kSwatchHeight - 3, kInk);
        break;
    }
    for (std::size_t k = 0; k < labels[i].size(); ++k)
      texts.push_back({sx + label_x, yy + 16 + 16 * static_cast<int>(k), labels[i][k], kTextSize, false, 0});
    yy += row_height(i);
  }

  // North arrow: the map is north-up (grid north; true north for geographic DEMs).
  yy += 14;
  {
    const double ax = lx + 14.0, top_y = yy + 16.0, base_y = yy + 44.0;
    pic.triangle({ax, top_y}, {ax - 9.0, base_y}, {ax, base_y - 8.0}, kInk);
    pic.triangle({ax, top_y}, {ax + 9.0, base_y}, {ax, base_y - 8.0}, kFrame);
    pic.triangle({ax + 1.0, top_y + 4.0}, {ax + 7.0, base_y - 3.0}, {ax + 1.0, base_y - 9.0}, kWhite);
    texts.push_back({static_cast<int>(ax), yy + 12, "N", 14, true, 1});
  }
  // Scale bar: a round length of at most 200 pixels, in four alternating quarters.
  {
    const int bar_x = lx + 44, bar_y = yy + 24;
    const double max_px = std::min(200.0, legend_w - 44.0 - 40.0);
    const double length_m = nice_floor(max_px * g.s);
    const int len_px = std::max(4, static_cast<int>(std::lround(length_m / g.s)));
    pic.outline(bar_x, bar_y, bar_x + len_px + 1, bar_y + 8, kInk);
    for (int q = 0; q < 4; ++q) {
      const int qx0 = bar_x + 1 + q * len_px / 4, qx1 = bar_x + (q + 1) * len_px / 4;
      pic.fill(qx0, bar_y + 1, qx1 + (q == 3 ? 0 : 1), bar_y + 7, q % 2 == 0 ? kInk : kWhite);
    }
    texts.push_back({bar_x, bar_y + 24, "0", kTextSize, false, 1});
    texts.push_back({bar_x + len_px, bar_y + 24, distance_label(length_m), kTextSize, false, 1});
    texts.push_back({bar_x, bar_y - 6, "Scale (ground distance)", kTextSize, false, 0});
  }

  // Words over the pixels.
  auto canvas = imageio::make_canvas(width, height);
  if (!canvas.ok()) return preview_error(canvas.error().code, path, canvas.error().message);
  (*canvas)->paste(0, 0, width, height, pic.rgb.data());
  if (words.have_font)
    for (const Text& t : texts)
      if (!(*canvas)->text_baseline(t.x, t.baseline, t.s, t.size, t.bold ? kBoldFont : kFont, t.align,
                                    {0.08f, 0.08f, 0.08f}))
        break;  // no font after all: the picture without words

  layout.width = width;
  layout.height = height;
  layout.map_x = map_x;
  layout.map_y = map_y;
  layout.map_width = g.map_w;
  layout.map_height = g.map_h;
  layout.legend_x = lx;
  layout.legend_y = ly;
  layout.legend_width = legend_w;
  layout.legend_height = legend_h;
  layout.metres_per_pixel = g.s;
  if (layout_out) *layout_out = layout;

  detail::AtomicFile file(path);
  HORIZON_RETURN_IF_ERROR(file.create("preview"));
  if (Status written = (*canvas)->write_png(file.temp_path()); !written.ok())
    return preview_error(written.error().code, path, written.error().message);
  return file.commit("preview");
}

// Round ticks between low and high, both ends included.
std::vector<double> ticks_between(double low, double high, int& decimals) {
  std::vector<double> ticks;
  if (!(high > low)) {
    decimals = std::abs(low) < 10 && low != std::round(low) ? 2 : 0;
    return {low};
  }
  const double step = nice_ceil((high - low) / 4.0);
  decimals = step >= 1.0 ? 0 : static_cast<int>(std::ceil(-std::log10(step) - 1e-9));
  ticks.push_back(low);
  for (double t = std::ceil(low / step + 1e-9) * step; t < high - 0.3 * step; t += step)
    if (t > low + 0.3 * step) ticks.push_back(t);
  ticks.push_back(high);
  // Ends that are not round keep the decimals they need to differ from their neighbours.
  return ticks;
}

}  // namespace

Rgb8 preview_ramp_colour(PreviewRamp ramp, double t) {
  switch (ramp) {
    case PreviewRamp::kElevation:
      return interpolate(kViridis, std::size(kViridis), t);
    case PreviewRamp::kHeightNeeded:
      return interpolate(kYlOrRd, std::size(kYlOrRd), t);
    case PreviewRamp::kCount:
      return interpolate(kBlues, std::size(kBlues), t);
  }
  return {0, 0, 0};
}

Status write_viewshed_preview(const std::string& path, const Grid<float>& elevation, const Grid<std::uint8_t>& codes,
                              const PreviewOptions& options, PreviewLayout* layout) {
  if (elevation.empty()) return preview_error(ErrorCode::kInvalidArgument, path, "elevation grid is empty");
  HORIZON_RETURN_IF_ERROR(check_inputs(path, elevation, codes.empty() ? elevation.width() : codes.width(),
                                       codes.empty() ? elevation.height() : codes.height(), options, "visibility"));
  bool any_void = false, any_beyond = false, any_undetermined = false;
  const auto z = elevation.values();
  for (std::size_t i = 0; i < z.size(); ++i) {
    if (std::isnan(z[i])) {
      any_void = true;
      continue;
    }
    if (codes.empty()) continue;
    const std::uint8_t v = codes.values()[i];
    any_undetermined = any_undetermined || v == 2;
    any_beyond = any_beyond || v > 2;
  }
  std::vector<LegendEntry> classes;
  if (!codes.empty()) {
    classes.push_back({LegendEntry::kSwatch, kPreviewVisible, options.classes.visible});
    classes.push_back({LegendEntry::kSwatch, kPreviewHidden, options.classes.hidden});
    if (any_undetermined) classes.push_back({LegendEntry::kSwatch, kPreviewUndetermined, options.classes.undetermined});
  }
  const CellColour colour = [&](int c, int r, double shade) -> Rgbf {
    if (codes.empty()) return {255.0 * shade, 255.0 * shade, 255.0 * shade};
    switch (codes.at(c, r)) {
      case 1:
        return lit(kPreviewVisible, shade);
      case 0:
        return lit(kPreviewHidden, shade);
      case 2:
        return lit(kPreviewUndetermined, shade);
      default:
        return beyond(shade);
    }
  };
  return draw(path, elevation, colour, std::move(classes), nullptr, any_void, any_beyond, options, layout);
}

Status write_ramp_preview(const std::string& path, const Grid<float>& elevation, const Grid<float>& values,
                          const PreviewRampSpec& spec, const PreviewOptions& options, PreviewLayout* layout) {
  if (elevation.empty()) return preview_error(ErrorCode::kInvalidArgument, path, "elevation grid is empty");
  HORIZON_RETURN_IF_ERROR(check_inputs(path, elevation, values.width(), values.height(), options, "values"));
  bool any_void = false, any_beyond = false;
  double lo = std::numeric_limits<double>::infinity(), hi = -lo;
  const auto z = elevation.values();
  const auto v = values.values();
  for (std::size_t i = 0; i < v.size(); ++i) {
    if (std::isnan(z[i])) {
      any_void = true;
      continue;
    }
    if (!std::isfinite(v[i])) {
      any_beyond = true;
      continue;
    }
    lo = std::min(lo, double{v[i]});
    hi = std::max(hi, double{v[i]});
  }
  RampBar bar;
  bar.spec = spec;
  if (!std::isfinite(lo)) lo = hi = 0.0;
  switch (spec.ramp) {
    case PreviewRamp::kElevation:
      bar.low = std::floor(lo);
      bar.high = std::ceil(hi);
      break;
    case PreviewRamp::kHeightNeeded:
      // Metres to thousands of metres: a log scale keeps the few metres a
      // mast or a person adds apart from the hundreds behind a ridge.
      bar.low = 0.0;
      bar.high = nice_ceil(std::max(1.0, hi));
      bar.logarithmic = true;
      bar.zero = LegendEntry{LegendEntry::kSwatch, kPreviewVisible, spec.zero.empty() ? "0: visible" : spec.zero};
      break;
    case PreviewRamp::kCount:
      bar.low = 1.0;
      bar.high = std::max(1.0, hi);
      bar.zero = LegendEntry{LegendEntry::kSwatch, kPreviewHidden, spec.zero.empty() ? "0: none" : spec.zero};
      break;
  }
  const PreviewRamp ramp = spec.ramp;
  bar.colour = [ramp](double t) { return preview_ramp_colour(ramp, t); };
  std::vector<LegendEntry> steps;
  if (spec.ramp == PreviewRamp::kCount && bar.high - bar.low < 8) {
    // Few counts: one entry each, in the colours the map uses.
    bar.discrete = true;
    for (double k = bar.low; k <= bar.high + 1e-9; k += 1.0)
      steps.push_back({LegendEntry::kSwatch,
                       preview_ramp_colour(spec.ramp, bar.high > bar.low ? (k - bar.low) / (bar.high - bar.low) : 1.0),
                       number(k, 0)});
  } else if (bar.logarithmic) {
    // 0, 1, 10, 100, ... and the top, each at least 14 % of the bar from the next.
    bar.ticks.push_back(bar.low);
    for (double t = 1.0; t < bar.high; t *= 10.0)
      if (bar.position(t) - bar.position(bar.ticks.back()) >= 0.14 && bar.position(bar.high) - bar.position(t) >= 0.14)
        bar.ticks.push_back(t);
    bar.ticks.push_back(bar.high);
    bar.decimals = 0;
  } else {
    bar.ticks = ticks_between(bar.low, bar.high, bar.decimals);
  }
  const CellColour colour = [&](int c, int r, double shade) -> Rgbf {
    const float value = values.at(c, r);
    if (!std::isfinite(value)) return beyond(shade);
    switch (ramp) {
      case PreviewRamp::kElevation:
        return lit(preview_ramp_colour(ramp, bar.position(value)), shade);
      case PreviewRamp::kHeightNeeded:
        if (value <= 0.0f) return lit(kPreviewVisible, shade);
        return lit(preview_ramp_colour(ramp, bar.position(value)), shade);
      case PreviewRamp::kCount:
        if (value < 0.5f) return lit(kPreviewHidden, shade);
        return lit(preview_ramp_colour(ramp, bar.high > bar.low ? bar.position(value) : 1.0), shade);
    }
    return beyond(shade);
  };
  return draw(path, elevation, colour, std::move(steps), &bar, any_void, any_beyond, options, layout);
}

}  // namespace horizon::terrain
