#include "observers_file.hpp"

#include <unistd.h>

#include <cctype>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>

#include <nlohmann/json.hpp>

#include "args.hpp"
#include "inputs.hpp"
#include "output.hpp"

namespace horizon::cli {
namespace {

std::string lower(std::string s) {
  for (char& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

bool is_geojson(const std::string& path) {
  const std::string p = lower(path);
  return p.ends_with(".geojson") || p.ends_with(".json");
}

// A height or reach: finite, and for a reach > 0.
void check_values(const std::string& where, double height, double max_distance, bool has_reach) {
  if (!std::isfinite(height)) throw UsageError(where + ": height must be a finite number of metres");
  if (has_reach && !(std::isfinite(max_distance) && max_distance > 0))
    throw UsageError(where + ": max_distance must be a positive number of metres, got " + std::to_string(max_distance));
}

std::vector<NamedObserver> read_csv(const std::string& path, std::istream& in, double height, geodesy::HeightMode mode,
                                    double max_distance) {
  std::vector<NamedObserver> out;
  bool lonlat = false, seen = false;
  std::string line;
  int number = 0;
  while (std::getline(in, line)) {
    ++number;
    const CsvNumbers row = parse_csv_numbers(line);
    if (row.blank) continue;
    const std::string where = "--observers: '" + path + "' line " + std::to_string(number);
    if (!row.numeric) {  // the header, when it is the first line that is not blank
      if (seen) throw UsageError(where + ": expected numbers x,y[,height[,max_distance]]");
      seen = true;
      const std::string header = lower(line);
      const auto first = header.find_first_not_of(" \t");
      lonlat = first != std::string::npos && header.compare(first, 3, "lon") == 0;
      continue;
    }
    seen = true;
    const std::size_t n = row.values.size();
    if (n < 2 || n > 4)
      throw UsageError(where + ": expected x,y[,height[,max_distance]], got " + std::to_string(n) + " numbers");
    NamedObserver o;
    o.site.point.frame = lonlat ? geodesy::PointFrame::kWgs84 : geodesy::PointFrame::kDatasetCrs;
    o.site.point.x = row.values[0];
    o.site.point.y = row.values[1];
    if (lonlat && std::abs(o.site.point.y) > 90)
      throw UsageError(where + ": latitude " + std::to_string(o.site.point.y) + " is outside [-90, 90]");
    o.site.point.height = n >= 3 ? row.values[2] : height;
    o.site.point.height_mode = mode;
    o.site.max_distance = n >= 4 ? row.values[3] : max_distance;
    check_values(where, o.site.point.height, o.site.max_distance, n >= 4);
    o.name = "line " + std::to_string(number);
    out.push_back(std::move(o));
  }
  return out;
}

std::vector<NamedObserver> read_geojson(const std::string& path, std::istream& in, double height,
                                        geodesy::HeightMode mode, double max_distance) {
  using Json = nlohmann::json;
  const std::string file = "--observers: '" + path + "'";
  Json doc;
  try {
    doc = Json::parse(in);
  } catch (const Json::parse_error& e) {
    throw UsageError(file + ": not JSON (" + std::string(e.what()) + ")");
  }
  if (!doc.is_object() || doc.value("type", "") != "FeatureCollection" || !doc.contains("features") ||
      !doc["features"].is_array())
    throw UsageError(file + ": expected a GeoJSON FeatureCollection with a \"features\" array");
  std::vector<NamedObserver> out;
  const Json& features = doc["features"];
  for (std::size_t i = 0; i < features.size(); ++i) {
    const Json& f = features[i];
    const std::string where = file + " features[" + std::to_string(i) + "]";
    const Json* geometry = f.is_object() && f.contains("geometry") ? &f["geometry"] : nullptr;
    if (!geometry || !geometry->is_object() || geometry->value("type", "") != "Point" ||
        !geometry->contains("coordinates"))
      throw UsageError(where + ": expected a Feature with a Point geometry");
    const Json& c = (*geometry)["coordinates"];
    if (!c.is_array() || c.size() < 2 || !c[0].is_number() || !c[1].is_number())
      throw UsageError(where + ": coordinates must be [longitude, latitude]");
    NamedObserver o;
    o.site.point.frame = geodesy::PointFrame::kWgs84;
    o.site.point.x = c[0].get<double>();
    o.site.point.y = c[1].get<double>();
    if (!std::isfinite(o.site.point.x) || !(std::abs(o.site.point.y) <= 90))
      throw UsageError(where + ": coordinates must be [longitude, latitude] with latitude in [-90, 90]");
    o.site.point.height = height;
    o.site.point.height_mode = mode;
    o.site.max_distance = max_distance;
    bool has_reach = false;
    o.name = "feature " + std::to_string(i);
    if (f.contains("properties") && f["properties"].is_object()) {
      const Json& p = f["properties"];
      for (const char* key : {"height", "max_distance"}) {
        if (!p.contains(key) || p[key].is_null()) continue;
        if (!p[key].is_number()) throw UsageError(where + ": property \"" + key + "\" must be a number of metres");
        (std::string(key) == "height" ? o.site.point.height : o.site.max_distance) = p[key].get<double>();
        has_reach = has_reach || std::string(key) == "max_distance";
      }
      for (const char* key : {"name", "id"}) {
        if (!p.contains(key)) continue;
        o.name = p[key].is_string() ? p[key].get<std::string>() : p[key].dump();
        break;
      }
    }
    check_values(where, o.site.point.height, o.site.max_distance, has_reach);
    out.push_back(std::move(o));
  }
  return out;
}

}  // namespace

std::vector<NamedObserver> read_observers_file(const std::string& path, double height, geodesy::HeightMode mode,
                                               double max_distance) {
  std::ifstream in(path);
  if (!in) throw UsageError("--observers: cannot open '" + path + "'");
  std::vector<NamedObserver> out = is_geojson(path) ? read_geojson(path, in, height, mode, max_distance)
                                                    : read_csv(path, in, height, mode, max_distance);
  if (out.empty()) throw UsageError("--observers: '" + path + "' holds no observers");
  return out;
}

std::string in_user_words(const std::string& where, const std::string& message,
                          const std::vector<NamedObserver>& observers) {
  const std::string key = "observers[";
  const auto at = where.find(key);
  if (at == std::string::npos) return message;
  const std::size_t i = std::strtoul(where.c_str() + at + key.size(), nullptr, 10);
  if (i >= observers.size()) return message;
  return "observer " + std::to_string(i + 1) + " (" + observers[i].name + "): " + message;
}

Status write_observer_summary(const std::string& path, const std::vector<ObserverLine>& lines, bool geographic) {
  const std::string temp = path + ".tmp-" + std::to_string(::getpid());
  {
    std::ofstream out(temp, std::ios::trunc);
    if (!out) return make_error(ErrorCode::kIoError, "--summary: cannot create '" + temp + "'", "summary");
    out << "observer,name,x,y,lon,lat,ground_m,eye_m,max_distance_m,cells_answered,cells_visible,visible_km2,"
           "visible_percent,seconds\n";
    for (std::size_t i = 0; i < lines.size(); ++i) {
      const ObserverLine& l = lines[i];
      std::string name = l.name;
      for (char& c : name)
        if (c == '"') c = '\'';
      const double percent =
          l.cells_answered ? 100.0 * static_cast<double>(l.cells_visible) / static_cast<double>(l.cells_answered) : 0.0;
      out << i + 1 << ",\"" << name << "\"," << coordinate(l.x, geographic) << ',' << coordinate(l.y, geographic) << ','
          << (l.lon ? fixed(*l.lon, 7) : "") << ',' << (l.lat ? fixed(*l.lat, 7) : "") << ',' << fixed(l.ground, 2)
          << ',' << fixed(l.eye, 2) << ',' << (l.max_distance ? fixed(*l.max_distance, 1) : "") << ','
          << l.cells_answered << ',' << l.cells_visible << ',' << fixed(l.visible_km2, 4) << ',' << fixed(percent, 2)
          << ',' << fixed(l.seconds, 4) << '\n';
    }
    out.close();
    if (!out) {
      std::filesystem::remove(temp);
      return make_error(ErrorCode::kIoError, "--summary: cannot write '" + path + "'", "summary");
    }
  }
  std::error_code ec;
  std::filesystem::rename(temp, path, ec);
  if (ec) {
    std::filesystem::remove(temp);
    return make_error(ErrorCode::kIoError, "--summary: cannot write '" + path + "' (" + ec.message() + ")", "summary");
  }
  return Status::Ok();
}

}  // namespace horizon::cli
