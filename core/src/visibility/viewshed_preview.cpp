// viewshed_preview.cpp — what a viewshed's PNG says (viewshed_preview.hpp);
// terrain/preview.cpp draws it.
#include "horizon/visibility/viewshed_preview.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <limits>
#include <vector>

#include "horizon/geodesy/crs.hpp"
#include "horizon/terrain/qgis_style.hpp"

namespace horizon::visibility {
namespace {

std::string fixed(double v, int decimals) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.*f", decimals, v);
  return buf;
}

// Metres as a person says them: "2 m", "1.5 m", "4373 m".
std::string metres(double m) {
  const double r = std::round(m * 10.0) / 10.0;
  return fixed(r, r == std::round(r) ? 0 : 1) + " m";
}

std::string distance(double m) {
  if (!std::isfinite(m)) return "the whole DEM";
  if (m >= 1000.0) {
    const double km = m / 1000.0;
    return fixed(km, std::abs(km - std::round(km)) < 1e-9 ? 0 : 2) + " km";
  }
  return metres(m);
}

// A CRS in the title: "EPSG:27700", or its name when it has no code, in
// ASCII ("user-defined" when PROJ names it "unknown").
std::string crs_tag(const geodesy::Crs& crs) {
  if (crs.horizontal_epsg() != 0) return "EPSG:" + std::to_string(crs.horizontal_epsg());
  std::string name = crs.horizontal_name();
  if (name.empty() || name == "unknown") return "user-defined";
  for (char& c : name)
    if (static_cast<unsigned char>(c) >= 0x80) c = '?';
  return name;
}

// "46.8529 N, 121.7604 W" (ASCII: OpenImageIO 2.4 draws no other glyphs), plus the CRS's own coordinates when
// projected.
std::string place(const std::optional<geodesy::Crs>& crs, double x, double y) {
  if (!crs) return "x " + fixed(x, 1) + ", y " + fixed(y, 1);
  auto ll = crs->to_lonlat({x, y});
  std::string s;
  if (ll.ok())
    s = fixed(std::abs(ll->lat), 4) + " " + (ll->lat < 0 ? "S" : "N") + ", " + fixed(std::abs(ll->lon), 4) + " " +
        (ll->lon < 0 ? "W" : "E");
  if (!crs->is_geographic())
    s += std::string(s.empty() ? "" : " = ") + "x " + fixed(x, 0) + ", y " + fixed(y, 0) + " (" + crs_tag(*crs) + ")";
  return s;
}

// Degrees as the title says them: "300", "12.5".
std::string degrees(double d) {
  const double r = std::round(d * 10.0) / 10.0;
  return fixed(r, r == std::round(r) ? 0 : 1);
}

// "; view azimuth 300 to 60 deg, from 400 m, pitch -10 to 2 deg", or nothing
// when the observer looks all round.
std::string view(const FieldOfView& v) {
  std::vector<std::string> parts;
  if (v.limits_azimuth())
    parts.push_back("azimuth " + degrees(v.azimuth_start) + " to " + degrees(v.azimuth_end) + " deg");
  if (v.min_distance > 0) parts.push_back("from " + distance(v.min_distance));
  if (v.limits_pitch()) parts.push_back("pitch " + degrees(v.pitch_min) + " to " + degrees(v.pitch_max) + " deg");
  std::string s;
  for (const std::string& p : parts) s += (s.empty() ? "; view " : ", ") + p;
  return s;
}

// The legend's no-answer class: beyond the reach, or outside the view too.
std::string beyond(const FieldOfView& v) {
  return v.limits() ? "out of range: beyond reach or outside the view" : terrain::PreviewClasses{}.beyond;
}

std::string eye(double elevation, double ground) {
  if (std::isnan(ground)) return "eye at " + metres(elevation) + " (ground: no data)";
  return "eye " + metres(elevation - ground) + " above the ground (" + metres(elevation) + ")";
}

std::string heading(PreviewRaster raster) {
  switch (raster) {
    case PreviewRaster::kVisibility:
      return "Viewshed";
    case PreviewRaster::kOhf:
      return "Occlusion height field";
    case PreviewRaster::kMinTargetHeight:
      return "Minimum visible target height";
    case PreviewRaster::kVerticalAngle:
      return "Vertical angle of the visible cells";
    case PreviewRaster::kElevationDifference:
      return "Elevation of the visible cells from the eye";
  }
  return "Viewshed";
}

// A ramp of kStops interpolated stops over [min, max], labelled in `unit`.
std::string ramp_style(double min, double max, int decimals, const std::string& unit) {
  if (!(max > min)) max = min + 1.0;
  constexpr int kStops = 9;
  std::vector<terrain::StyleEntry> entries;
  for (int i = 0; i < kStops; ++i) {
    const double t = static_cast<double>(i) / (kStops - 1);
    const double v = min + t * (max - min);
    entries.push_back(
        {v, terrain::preview_ramp_colour(terrain::PreviewRamp::kElevation, t), fixed(v, decimals) + " " + unit});
  }
  return terrain::qml_pseudocolor(entries, false, decimals);
}

}  // namespace

std::string dem_label(const std::string& path) {
  std::filesystem::path p(path);
  while (!p.empty() && p.filename().empty()) p = p.parent_path();  // "tiles/" names the folder
  const std::string stem = p.stem().string();
  return stem.empty() ? path : stem;
}

std::string viewshed_style(PreviewRaster raster, double min, double max) {
  using terrain::StyleEntry;
  std::vector<StyleEntry> entries;
  switch (raster) {
    case PreviewRaster::kVisibility:
      return terrain::qml_paletted(std::vector<StyleEntry>{{0.0, terrain::kPreviewHidden, "hidden"},
                                                           {1.0, terrain::kPreviewVisible, "visible"}});
    case PreviewRaster::kOhf:
      return ramp_style(min, max, 0, "m");
    case PreviewRaster::kVerticalAngle:
      return ramp_style(min, max, 1, "deg");
    case PreviewRaster::kElevationDifference:
      return ramp_style(min, max, 0, "m");
    case PreviewRaster::kMinTargetHeight: {
      // Classes 0, up to 1, 2, 5, 10, 20, 50, ... metres, to the first bound at or above max,
      // coloured as the preview's log ramp.
      std::vector<double> bounds;
      for (double decade = 1.0; bounds.empty() || bounds.back() < max; decade *= 10.0)
        for (double m : {1.0, 2.0, 5.0})
          if (bounds.empty() || bounds.back() < max) bounds.push_back(m * decade);
      entries.push_back({0.0, terrain::kPreviewVisible, "0 m: the ground is visible"});
      double previous = 0.0;
      for (double b : bounds) {
        const double t = std::log1p(b) / std::log1p(bounds.back());
        entries.push_back({b, terrain::preview_ramp_colour(terrain::PreviewRamp::kHeightNeeded, t),
                           fixed(previous, 0) + " - " + fixed(b, 0) + " m"});
        previous = b;
      }
      return terrain::qml_pseudocolor(entries, true, 0);
    }
  }
  return {};
}

std::string visibility_style(const ValueCodes& codes) {
  using terrain::StyleEntry;
  const bool out_of_range_drawn = codes.out_of_range != codes.nodata && codes.out_of_range != codes.hidden;
  const std::string hidden =
      codes.out_of_range == codes.hidden && codes.out_of_range != codes.nodata ? "not visible" : "hidden";
  std::vector<StyleEntry> entries{{static_cast<double>(codes.hidden), terrain::kPreviewHidden, hidden},
                                  {static_cast<double>(codes.visible), terrain::kPreviewVisible, "visible"}};
  if (codes.hidden == codes.nodata) entries.erase(entries.begin());  // hidden left transparent, as r.viewshed does
  if (out_of_range_drawn)
    entries.push_back({static_cast<double>(codes.out_of_range), terrain::kPreviewBeyond, "out of range"});
  std::sort(entries.begin(), entries.end(), [](const StyleEntry& a, const StyleEntry& b) { return a.value < b.value; });
  return terrain::qml_paletted(entries);
}

std::string viewshed_style(PreviewRaster raster, const terrain::Grid<float>& values) {
  double lo = std::numeric_limits<double>::infinity(), hi = -lo;
  for (float v : values.values())
    if (std::isfinite(v)) {
      lo = std::min(lo, double{v});
      hi = std::max(hi, double{v});
    }
  if (!std::isfinite(lo)) lo = hi = 0.0;
  return viewshed_style(raster, lo, hi);
}

std::string many_observers_style(PreviewAccumulation accumulation, std::uint32_t max_count) {
  using terrain::StyleEntry;
  if (accumulation != PreviewAccumulation::kCount) {
    const bool any = accumulation == PreviewAccumulation::kAny;
    return terrain::qml_paletted(std::vector<StyleEntry>{
        {0.0, terrain::kPreviewHidden, any ? "seen by none" : "not seen by every observer"},
        {1.0, terrain::kPreviewVisible, any ? "seen by at least one" : "seen by every observer"}});
  }
  // 0, then each count up to 8, or 8 classes of counts.
  std::vector<StyleEntry> entries{{0.0, terrain::kPreviewHidden, "0: seen by none"}};
  const std::uint32_t top = std::max<std::uint32_t>(1, max_count);
  const std::uint32_t classes = std::min<std::uint32_t>(top, 8);
  std::uint32_t previous = 0;
  for (std::uint32_t i = 1; i <= classes; ++i) {
    const std::uint32_t bound = static_cast<std::uint32_t>(
        std::ceil(static_cast<double>(top) * static_cast<double>(i) / static_cast<double>(classes)));
    if (bound <= previous) continue;
    const double t = top > 1 ? static_cast<double>(bound - 1) / static_cast<double>(top - 1) : 1.0;
    const std::string label =
        bound == previous + 1 ? std::to_string(bound) : std::to_string(previous + 1) + " - " + std::to_string(bound);
    entries.push_back({static_cast<double>(bound), terrain::preview_ramp_colour(terrain::PreviewRamp::kCount, t),
                       label + (bound == 1 && previous == 0 ? " observer" : " observers")});
    previous = bound;
  }
  return terrain::qml_pseudocolor(entries, true, 0);
}

std::string region_style() {
  using terrain::StyleEntry;
  return terrain::qml_paletted(std::vector<StyleEntry>{{0.0, terrain::kPreviewHidden, "always hidden"},
                                                       {1.0, terrain::kPreviewVisible, "always visible"},
                                                       {2.0, terrain::kPreviewUndetermined, "undetermined"}});
}

terrain::ColourTable code_colour_table() {
  terrain::ColourTable table{};  // black for codes never written
  table[0] = terrain::kPreviewHidden;
  table[1] = terrain::kPreviewVisible;
  table[2] = terrain::kPreviewUndetermined;
  table[255] = terrain::kPreviewBeyond;
  return table;
}

terrain::ColourTable code_colour_table(const ValueCodes& codes) {
  terrain::ColourTable table = code_colour_table();  // the default codes' colours where no other code falls
  table[codes.nodata] = terrain::kPreviewBeyond;
  table[codes.out_of_range] = terrain::kPreviewBeyond;
  table[codes.hidden] = terrain::kPreviewHidden;
  table[codes.visible] = terrain::kPreviewVisible;
  return table;
}

PreviewRaster preview_raster(ViewshedOutput output) {
  switch (output) {
    case ViewshedOutput::kVisibility:
    case ViewshedOutput::kBoolean:
      return PreviewRaster::kVisibility;
    case ViewshedOutput::kOhf:
      return PreviewRaster::kOhf;
    case ViewshedOutput::kMinTargetHeight:
      return PreviewRaster::kMinTargetHeight;
    case ViewshedOutput::kVerticalAngle:
      return PreviewRaster::kVerticalAngle;
    case ViewshedOutput::kElevationDifference:
      return PreviewRaster::kElevationDifference;
  }
  return PreviewRaster::kVisibility;
}

std::vector<std::string> viewshed_title(const ViewshedResult& result, PreviewRaster raster,
                                        const PreviewCaption& caption) {
  const ViewFrame& f = result.frame;
  std::vector<std::string> title;
  title.push_back(heading(raster) + " over " + caption.dem);
  std::string details = "Observer " + place(caption.crs, caption.x, caption.y) + "; " + eye(f.eye, caption.ground);
  if (raster != PreviewRaster::kOhf && raster != PreviewRaster::kMinTargetHeight)
    details += "; targets " + metres(result.target_height) + " above the ground";
  details += "; reach " + distance(f.max_distance) + view(result.field_of_view);
  if (!caption.algorithm.empty()) details += "; algorithm " + caption.algorithm;
  title.push_back(details);
  return title;
}

Status write_viewshed_picture(const std::string& path, const ViewshedResult& result, PreviewRaster raster,
                              const terrain::Grid<std::uint8_t>& mask, const PreviewCaption& caption) {
  terrain::PreviewOptions o = preview_options(result);
  o.title = viewshed_title(result, raster, caption);
  o.classes.beyond = beyond(result.field_of_view);
  switch (raster) {
    case PreviewRaster::kVisibility:
      return terrain::write_viewshed_preview(path, result.terrain, mask, o);
    case PreviewRaster::kOhf:
      return terrain::write_ramp_preview(path, result.terrain, ohf_raster(result),
                                         {terrain::PreviewRamp::kElevation, "Lowest visible elevation", "metres", ""},
                                         o);
    case PreviewRaster::kMinTargetHeight:
      return terrain::write_ramp_preview(path, result.terrain, min_target_height(result),
                                         {terrain::PreviewRamp::kHeightNeeded, "Height a target needs to be seen",
                                          "metres above the ground", "0 m: the ground is visible"},
                                         o);
    case PreviewRaster::kVerticalAngle: {
      o.classes.beyond = "not visible, or out of range";
      // The eye's own cell is 180 by r.viewshed's rule, and no other cell
      // reaches it (a target d > 0 away is below straight up): drawn, it
      // would stretch the ramp over angles no cell has. The observer's
      // marker stands there instead; the GeoTIFF keeps the 180.
      terrain::Grid<float> angles = vertical_angle_raster(result, result.target_height);
      for (std::size_t i = 0; i < angles.size(); ++i)
        if (angles.data()[i] == 180.0f) angles.data()[i] = std::numeric_limits<float>::quiet_NaN();
      return terrain::write_ramp_preview(path, result.terrain, angles,
                                         {terrain::PreviewRamp::kElevation, "Vertical angle from the eye",
                                          "degrees from straight down (90: level)", ""},
                                         o);
    }
    case PreviewRaster::kElevationDifference:
      o.classes.beyond = "not visible, or out of range";
      return terrain::write_ramp_preview(path, result.terrain,
                                         elevation_difference_raster(result, result.target_height),
                                         {terrain::PreviewRamp::kElevation, "Ground elevation from the eye's",
                                          "metres", ""},
                                         o);
  }
  return Status::Ok();
}

Status write_many_observers_picture(const std::string& path, const ManyObserversPlan& plan,
                                    const ManyObserversResult& result, const terrain::Grid<float>& elevation,
                                    PreviewAccumulation accumulation, const PreviewCaption& caption) {
  const terrain::Window& w = result.window;
  terrain::PreviewOptions o;
  o.metres_per_col = plan.frames.front().metres_per_col;
  o.metres_per_row = plan.frames.front().metres_per_row;
  double min_eye = std::numeric_limits<double>::infinity(), max_eye = -min_eye;
  double min_reach = min_eye, max_reach = -min_eye;
  for (std::size_t i = 0; i < plan.frames.size(); ++i) {
    const ViewFrame& f = plan.frames[i];
    o.observers.push_back({f.observer_col - w.col0, f.observer_row - w.row0,
                           std::isfinite(f.max_distance) ? f.max_distance : std::numeric_limits<double>::infinity()});
    const double above = plan.points[i].elevation - plan.points[i].ground;
    if (std::isfinite(above)) {
      min_eye = std::min(min_eye, above);
      max_eye = std::max(max_eye, above);
    }
    min_reach = std::min(min_reach, f.max_distance);
    max_reach = std::max(max_reach, f.max_distance);
  }
  const std::size_t n = plan.frames.size();
  const char* what = accumulation == PreviewAccumulation::kCount ? "Cumulative viewshed"
                     : accumulation == PreviewAccumulation::kAny ? "Seen by any observer"
                                                                 : "Seen by every observer";
  o.title.push_back(std::string(what) + " over " + caption.dem);
  std::string details = std::to_string(n) + (n == 1 ? " observer" : " observers");
  if (std::isfinite(min_eye))
    details += "; eyes " + (min_eye == max_eye ? metres(min_eye) : metres(min_eye) + " to " + metres(max_eye)) +
               " above the ground";
  details += "; targets " + metres(plan.options.viewshed.target_height) + " above the ground";
  const FieldOfView& field_of_view = plan.options.viewshed.field_of_view;
  details += "; reach " +
             (min_reach == max_reach ? distance(min_reach) : distance(min_reach) + " to " + distance(max_reach)) +
             view(field_of_view);
  if (!caption.algorithm.empty()) details += "; algorithm " + caption.algorithm;
  o.title.push_back(details);

  o.classes.beyond = field_of_view.limits() ? "out of every range: beyond reach or outside the view"
                                            : "beyond every reach: not computed";
  if (accumulation == PreviewAccumulation::kCount) {
    const terrain::Grid<std::uint32_t> counts = observer_count(result);
    terrain::Grid<float> values(counts.width(), counts.height(), terrain::kUninitialized);
    for (std::size_t i = 0; i < counts.size(); ++i)
      values.values()[i] = counts.values()[i] == kNoCount ? std::numeric_limits<float>::quiet_NaN()
                                                          : static_cast<float>(counts.values()[i]);
    return terrain::write_ramp_preview(
        path, elevation, values, {terrain::PreviewRamp::kCount, "Observers that see the cell", "", "0: seen by none"},
        o);
  }
  const bool any = accumulation == PreviewAccumulation::kAny;
  o.classes.visible = any ? "seen by at least one" : "seen by every observer";
  o.classes.hidden = any ? "seen by none" : "not seen by every observer";
  return terrain::write_viewshed_preview(path, elevation, any ? seen_from_any(result) : seen_from_all(result), o);
}

}  // namespace horizon::visibility
