// chart.cpp — the runtime-against-error PNG (bench.hpp, write_chart), drawn
// on an imageio::Canvas (OpenImageIO's ImageBufAlgo: render_box, render_line,
// render_text with the DejaVu Sans font of Debian's fonts-dejavu-core, which
// scripts/setup.sh installs). If no font can be found the chart is still
// drawn, without its words, and the write reports no error: the CSV and the
// Markdown table carry the numbers.
//
// Axes: x = time per group (seconds, log10, whole decades), y = 1 - IoU in
// percent (log10 from 0.001 % to 100 %); results with no error sit on a
// separate "0" line under the log range. One colour per algorithm, a legend,
// the Pareto front joined by a black staircase (time ascending), default
// settings ringed.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "horizon/evaluation/bench.hpp"
#include "horizon/imageio/imageio.hpp"
#include "label_placement.hpp"

namespace horizon::evaluation {
namespace {

constexpr int kWidth = 1000, kHeight = 640;
constexpr int kLeft = 90, kRight = 200, kTop = 56, kBottom = 64;  // plot margins (legend on the right)
constexpr double kErrorCeilLog = 2.0;                             // 100 %
constexpr const char* kFont = "DejaVuSans";

using Colour = imageio::Colour;

// The algorithms' and peers' own colours; other series (the region sweep's
// sizes) take a qualitative palette in the order they first appear.
std::optional<Colour> own_colour(const std::string& algorithm) {
  static const std::map<std::string, Colour> known = {
      {"fast", {0.12f, 0.47f, 0.71f}}, {"exact", {0.17f, 0.63f, 0.17f}}, {"conservative", {1.0f, 0.5f, 0.05f}},
      {"r3", {0.3f, 0.3f, 0.3f}},      {"gdal", {0.84f, 0.15f, 0.16f}},  {"grass", {0.58f, 0.4f, 0.74f}},
  };
  if (auto it = known.find(algorithm); it != known.end()) return it->second;
  return std::nullopt;
}

Colour palette_colour(int nth) {
  static const Colour palette[] = {{0.12f, 0.47f, 0.71f}, {1.0f, 0.5f, 0.05f},  {0.17f, 0.63f, 0.17f},
                                   {0.84f, 0.15f, 0.16f}, {0.58f, 0.4f, 0.74f}, {0.55f, 0.34f, 0.29f},
                                   {0.89f, 0.47f, 0.76f}, {0.5f, 0.5f, 0.5f}};
  return palette[static_cast<std::size_t>(nth) % std::size(palette)];
}

std::string decade_label_time(int e) {
  static const char* kUnits[] = {"1 us",   "10 us", "100 us", "1 ms",  "10 ms",
                                 "100 ms", "1 s",   "10 s",   "100 s", "1000 s"};
  if (e >= -6 && e <= 3) return kUnits[e + 6];
  char buf[32];
  std::snprintf(buf, sizeof buf, "1e%d s", e);
  return buf;
}

std::string decade_label_error(int e) {
  char buf[32];
  if (e >= 0)
    std::snprintf(buf, sizeof buf, "%.0f%%", std::pow(10.0, e));
  else
    std::snprintf(buf, sizeof buf, "%.*f%%", -e, std::pow(10.0, e));
  return buf;
}

struct Canvas {
  std::unique_ptr<imageio::Canvas> surface;
  bool text_ok = true;

  void line(int x0, int y0, int x1, int y1, const Colour& c) { surface->line(x0, y0, x1, y1, c); }
  void thick_line(int x0, int y0, int x1, int y1, const Colour& c) {
    for (int d = -1; d <= 1; ++d) {
      line(x0, y0 + d, x1, y1 + d, c);
      line(x0 + d, y0, x1 + d, y1, c);
    }
  }
  void box(int x0, int y0, int x1, int y1, const Colour& c, bool fill) { surface->box(x0, y0, x1, y1, c, fill); }
  // Text with its top-left corner at (x, y_top); align: 0 left, 1 centre, 2 right.
  void text(int x, int y_top, const std::string& s, int size, int align = 0, const Colour& c = {0, 0, 0}) {
    if (text_ok) text_ok = surface->text(x, y_top, s, size, kFont, align, c);
  }
};

}  // namespace

Status write_chart(const std::string& path, const std::vector<Aggregate>& group, const std::string& title,
                   const ChartText& words) {
  if (group.empty()) return make_error(ErrorCode::kInvalidArgument, "chart: nothing to draw", "chart");
  auto surface = imageio::make_canvas(kWidth, kHeight);
  if (!surface.ok()) return surface.error();
  Canvas cv{std::move(*surface)};
  const int px0 = kLeft, px1 = kWidth - kRight, py0 = kTop, py1 = kHeight - kBottom;
  const int zero_line = py1 - 18;         // y of "0 error"
  const int log_bottom = zero_line - 22;  // y of the log range's floor
  const double floor_log = std::min(words.error_floor_log, static_cast<int>(kErrorCeilLog) - 1);
  // Series in order of appearance, each with its colour.
  std::vector<std::string> algorithms;
  std::map<std::string, Colour> colours;
  int unknown = 0;
  for (const Aggregate& a : group)
    if (std::find(algorithms.begin(), algorithms.end(), a.algorithm) == algorithms.end()) {
      algorithms.push_back(a.algorithm);
      const std::optional<Colour> own = own_colour(a.algorithm);
      colours[a.algorithm] = own ? *own : palette_colour(unknown++);
    }

  double t_min = std::numeric_limits<double>::infinity(), t_max = 0;
  for (const Aggregate& a : group) {
    const double t = std::max(a.seconds, 1e-6);
    t_min = std::min(t_min, t);
    t_max = std::max(t_max, t);
  }
  const int e0 = static_cast<int>(std::floor(std::log10(t_min))),
            e1 = std::max(e0 + 1, int(std::ceil(std::log10(t_max))));
  auto x_of = [&](double seconds) {
    const double l = std::log10(std::max(seconds, 1e-6));
    return px0 + static_cast<int>(std::lround((l - e0) / (e1 - e0) * (px1 - px0)));
  };
  auto y_of = [&](double error) {
    const double pct = 100.0 * error;
    if (!(pct > 0)) return zero_line;
    const double l = std::clamp(std::log10(pct), floor_log, kErrorCeilLog);
    return log_bottom -
           static_cast<int>(std::lround((l - floor_log) / (kErrorCeilLog - floor_log) * (log_bottom - py0)));
  };

  // Grid, ticks and labels.
  const Colour grid{0.88f, 0.88f, 0.88f}, black{0, 0, 0};
  for (int e = e0; e <= e1; ++e) {
    const int x = x_of(std::pow(10.0, e));
    cv.line(x, py0, x, py1, grid);
    cv.line(x, py1, x, py1 + 6, black);
    cv.text(x, py1 + 9, decade_label_time(e), 13, 1);
    if (e < e1)
      for (int m = 2; m <= 9; ++m) {
        const int xm = x_of(m * std::pow(10.0, e));
        cv.line(xm, py1, xm, py1 + 3, black);
      }
  }
  for (int e = static_cast<int>(floor_log); e <= static_cast<int>(kErrorCeilLog); ++e) {
    const int y = y_of(std::pow(10.0, e) / 100.0);
    cv.line(px0, y, px1, y, grid);
    cv.line(px0 - 6, y, px0, y, black);
    cv.text(px0 - 9, y - 7, decade_label_error(e), 13, 2);
  }
  cv.line(px0, zero_line, px1, zero_line, {0.75f, 0.85f, 0.75f});
  cv.line(px0 - 6, zero_line, px0, zero_line, black);
  cv.text(px0 - 9, zero_line - 7, words.zero_line, 13, 2);
  cv.box(px0, py0, px1, py1, black, false);
  cv.text((px0 + px1) / 2, py1 + 30, words.x_axis, 15, 1);
  cv.text(8, py0 - 22, words.y_axis, 13);
  cv.text((px0 + px1) / 2, 8, title, 17, 1);
  for (std::size_t i = 0; i < words.notes.size(); ++i)
    cv.text(px1 + 16, py1 - 18 - 14 * static_cast<int>(words.notes.size() - 1 - i), words.notes[i], 11);

  // The front: a staircase through the front's points by time.
  std::vector<const Aggregate*> front;
  for (const Aggregate& a : group)
    if (a.on_front && words.pareto_front) front.push_back(&a);
  std::sort(front.begin(), front.end(), [](const Aggregate* a, const Aggregate* b) { return a->seconds < b->seconds; });
  for (std::size_t i = 0; i + 1 < front.size(); ++i) {
    const int xa = x_of(front[i]->seconds), ya = y_of(front[i]->error());
    const int xb = x_of(front[i + 1]->seconds), yb = y_of(front[i + 1]->error());
    cv.thick_line(xa, ya, xb, ya, black);
    cv.thick_line(xb, ya, xb, yb, black);
  }

  // Without a front, each series' points joined in order and each named.
  if (!words.pareto_front)
    for (const std::string& name : algorithms) {
      const Aggregate* last = nullptr;
      for (const Aggregate& a : group) {
        if (a.algorithm != name) continue;
        if (last) cv.line(x_of(last->seconds), y_of(last->error()), x_of(a.seconds), y_of(a.error()), colours[name]);
        cv.text(x_of(a.seconds) + 8, y_of(a.error()) - 18, a.setting, 11, 0, {0.25f, 0.25f, 0.25f});
        last = &a;
      }
    }
  // Points, coloured by algorithm; default settings ringed; front points outlined.
  for (const Aggregate& a : group) {
    const int x = x_of(a.seconds), y = y_of(a.error());
    const Colour c = colours[a.algorithm];
    cv.box(x - 5, y - 5, x + 5, y + 5, c, true);
    if (a.on_front && words.pareto_front) cv.box(x - 6, y - 6, x + 6, y + 6, black, false);
    if (a.is_default) cv.box(x - 9, y - 9, x + 9, y + 9, c, false);
  }
  // Front points named (the setting, or the peer), right of the point:
  // above it or below, whichever meets no other name and no point, or
  // further out where names would overprint (front points can sit a few
  // pixels apart, and other series' points beside them).
  std::vector<std::string> names;
  std::vector<LabelBox> boxes;
  for (const Aggregate* a : front) {
    names.push_back(a->is_peer || a->setting == "default" || a->setting == "reference"
                        ? a->algorithm
                        : a->algorithm + " " + a->setting);
    const int width = imageio::text_width(names.back(), 11, kFont).value_or(7 * static_cast<int>(names.back().size()));
    boxes.push_back({x_of(a->seconds) + 12, y_of(a->error()), width, 13});
  }
  std::vector<LabelBox> points;
  for (const Aggregate& a : group) points.push_back({x_of(a.seconds) - 5, y_of(a.error()) - 5, 11, 11});
  const std::vector<int> dy = place_labels(boxes, {-16, 6, -30, 20, -44, 34, -58, 48}, points);
  for (std::size_t i = 0; i < names.size(); ++i)
    cv.text(boxes[i].x, boxes[i].y + dy[i], names[i], 11, 0, {0.25f, 0.25f, 0.25f});

  // Legend.
  int ly = py0 + 6;
  const int lx = px1 + 16;
  for (const std::string& name : algorithms) {
    cv.box(lx, ly + 2, lx + 12, ly + 14, colours[name], true);
    cv.text(lx + 20, ly, name, 14);
    ly += 22;
  }
  ly += 8;
  if (words.pareto_front) {
    cv.thick_line(lx, ly + 8, lx + 14, ly + 8, black);
    cv.text(lx + 20, ly, "Pareto front", 13);
    ly += 22;
  }
  cv.box(lx - 2, ly, lx + 14, ly + 16, {0.4f, 0.4f, 0.4f}, false);
  cv.text(lx + 20, ly, "default setting", 13);

  // Write atomically: temporary name, then rename.
  const std::string tmp = path + ".tmp";
  if (Status written = cv.surface->write_png(tmp); !written.ok()) {
    std::filesystem::remove(tmp);
    return make_error(ErrorCode::kIoError, "cannot write chart '" + path + "': " + written.error().message, path);
  }
  std::error_code ec;
  std::filesystem::rename(tmp, path, ec);
  if (ec) return make_error(ErrorCode::kIoError, "cannot write chart '" + path + "': " + ec.message(), path);
  return Status::Ok();
}

}  // namespace horizon::evaluation
