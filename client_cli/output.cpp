#include "output.hpp"

#include <cmath>
#include <cstdio>
#include <iostream>

namespace horizon::cli {

void print_json(const Json& document) {
  std::cout << document.dump(2) << '\n';
}

Json finite_or_null(double value) {
  return std::isfinite(value) ? Json(value) : Json(nullptr);
}

Json viewshed_options_json(const geodesy::PointSpec& observer, const visibility::ViewshedOptions& options,
                           const std::string& nodata) {
  const visibility::FieldOfView& view = options.field_of_view;
  return {{"height", observer.height},
          {"height_mode", observer.height_mode == geodesy::HeightMode::kAbsolute ? "absolute" : "above_ground"},
          {"observer_ground", observer.ground == geodesy::GroundSample::kCell ? "cell" : "bilinear"},
          {"target_height", options.target_height},
          {"max_distance", finite_or_null(options.max_distance)},
          {"curvature", options.curvature_coefficient},
          {"field_of_view",
           {{"azimuth", {view.azimuth_start, view.azimuth_end}},
            {"min_distance", view.min_distance},
            {"pitch", {view.pitch_min, view.pitch_max}}}},
          {"nodata", nodata},
          {"ray_spacing", options.radial.ray_spacing},
          {"threads", options.threads},
          {"backend", visibility::backend_name(options.backend)},
          // null: the device's measured fastest variant (stats.gpu_variant says which ran)
          {"gpu_method", options.gpu ? Json(visibility::gpu_method_name(options.gpu->method)) : Json(nullptr)},
          {"gpu_propagation", options.gpu ? Json(options.gpu->log_step ? "log-step" : "one-step") : Json(nullptr)}};
}

Json to_json(const terrain::GeoTransform& t) {
  return Json::array({t.origin_x, t.pixel_width, 0.0, t.origin_y, 0.0, t.pixel_height});
}

Json to_json(const terrain::Window& w) {
  return Json{{"col0", w.col0}, {"row0", w.row0},     {"col1", w.col1},
              {"row1", w.row1}, {"width", w.width()}, {"height", w.height()}};
}

Json to_json(const visibility::ValueCodes& codes) {
  return Json{{"visible", codes.visible},
              {"hidden", codes.hidden},
              {"out_of_range", codes.out_of_range},
              {"nodata", codes.nodata}};
}

Json to_json(const visibility::WorkStats& s) {
  return Json{{"dem_cells", s.dem_cells},
              {"window_cells", s.window_cells},
              {"cells_evaluated", s.cells_evaluated},
              {"terrain_samples", s.terrain_samples},
              {"rays", s.rays},
              {"seconds", s.seconds},
              {"backend", s.backend},
              {"gpu_variant", s.gpu_variant.empty() ? Json(nullptr) : Json(s.gpu_variant)},
              {"device_seconds", s.device_seconds},
              {"gpu_fallback", s.gpu_fallback.empty() ? Json(nullptr) : Json(s.gpu_fallback)}};
}

Json to_json(const visibility::ProfileSample& s) {
  return Json{{"distance", s.distance},
              {"col", s.col},
              {"row", s.row},
              {"x", s.x},
              {"y", s.y},
              {"terrain", finite_or_null(s.terrain)},
              {"sight_line", s.sight_line}};
}

Json to_json(const geodesy::GridPoint& p, const std::optional<geodesy::LonLat>& lonlat) {
  Json j{{"x", p.x}, {"y", p.y}};
  j["lon"] = lonlat ? Json(lonlat->lon) : Json(nullptr);
  j["lat"] = lonlat ? Json(lonlat->lat) : Json(nullptr);
  j["col"] = p.col;
  j["row"] = p.row;
  j["ground"] = finite_or_null(p.ground);
  j["elevation"] = p.elevation;
  return j;
}

std::string with_separators(std::uint64_t count) {
  const std::string digits = std::to_string(count);
  std::string out;
  out.reserve(digits.size() + digits.size() / 3);
  for (std::size_t i = 0; i < digits.size(); ++i) {
    if (i > 0 && (digits.size() - i) % 3 == 0) out.push_back(',');
    out.push_back(digits[i]);
  }
  return out;
}

std::string fixed(double value, int decimals) {
  if (std::isnan(value)) return "n/a";
  if (std::isinf(value)) return value > 0 ? "inf" : "-inf";
  char buffer[64];
  std::snprintf(buffer, sizeof buffer, "%.*f", decimals, value);
  return buffer;
}

std::string coordinate(double value, bool geographic) {
  return fixed(value, geographic ? 7 : 2);
}

std::string crs_name(const geodesy::Crs& crs) {
  if (crs.horizontal_epsg() != 0)
    return "EPSG:" + std::to_string(crs.horizontal_epsg()) + " (" + crs.horizontal_name() + ")";
  const std::string& name = crs.horizontal_name();
  return name.empty() || name == "unknown" ? std::string("user-defined") : name + " (user-defined)";
}

std::string crs_label(const geodesy::Crs& crs) {
  return crs_name(crs) + (crs.is_geographic() ? ", geographic" : ", projected (" + crs.projection() + ")") +
         ", units: " + crs.unit_name();
}

std::string heights_label(const geodesy::Crs& crs) {
  if (!crs.is_compound()) return "";
  if (crs.vertical_epsg() == 0) return crs.vertical_name();
  return "EPSG:" + std::to_string(crs.vertical_epsg()) + " (" + crs.vertical_name() + ")";
}

Json to_json(const geodesy::Crs& crs) {
  const auto code = [](int epsg) { return epsg != 0 ? Json(epsg) : Json(nullptr); };
  Json j = {{"epsg", code(crs.horizontal_epsg())},
            {"name", crs.name()},
            {"geographic", crs.is_geographic()},
            {"units", crs.unit_name()},
            {"unit_size", crs.unit_size()},
            {"projection", crs.is_geographic() ? Json(nullptr) : Json(crs.projection())},
            {"vertical", crs.is_compound() ? Json{{"epsg", code(crs.vertical_epsg())}, {"name", crs.vertical_name()}}
                                           : Json(nullptr)}};
  if (crs.epsg() != 0 && crs.epsg() != crs.horizontal_epsg()) j["compound_epsg"] = crs.epsg();
  j["wkt"] = crs.wkt();
  return j;
}

}  // namespace horizon::cli
