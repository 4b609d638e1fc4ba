// `horizon info DATASET --server HOST:PORT`: embedded mode's report, from GetDataset.
#include <cmath>
#include <iostream>
#include <optional>

#include "commands/command.hpp"
#include "output.hpp"
#include "remote/client.hpp"
#include "remote/module_abi.hpp"

namespace horizon::cli::remote {

int impl::run_info(const Args& args, const std::string& name, bool json) {
  Client client(args);
  v1::Dataset d;
  if (auto s = client.get_dataset(name, d); !s.ok()) return report_status(s, client.address());

  const auto& t = d.transform();
  const auto& e = d.extent();
  const std::uint64_t cells = static_cast<std::uint64_t>(d.width()) * static_cast<std::uint64_t>(d.height());
  const bool geographic = d.geographic();
  // The CRS as the daemon describes it (its WKT, read here through PROJ as a
  // local file's is), so both modes name it alike.
  std::optional<geodesy::Crs> crs;
  if (!d.crs_wkt().empty())
    if (auto c = geodesy::Crs::from_definition(d.crs_wkt()); c.ok()) crs = *c;
  if (json) {
    Json j;
    j["path"] = name;
    j["format"] = d.format();
    j["width"] = d.width();
    j["height"] = d.height();
    j["cells"] = cells;
    if (crs)
      j["crs"] = to_json(*crs);
    else
      j["crs"] =
          d.epsg() ? Json{{"epsg", d.epsg()}, {"name", d.crs_name()}, {"geographic", geographic}} : Json(nullptr);
    j["crs_unusable"] = nullptr;  // a daemon serves no dataset whose CRS it cannot use
    j["geotransform"] = to_json(terrain::GeoTransform{t.origin_x(), t.pixel_width(), t.origin_y(), t.pixel_height()});
    j["cell_size_m"] = {{"x", d.cell_size_x_m()}, {"y", d.cell_size_y_m()}};
    j["extent"] = {{"x_min", e.x_min()}, {"y_min", e.y_min()}, {"x_max", e.x_max()}, {"y_max", e.y_max()}};
    j["extent_lonlat"] = d.has_extent_lonlat() ? Json{{"west", d.extent_lonlat().west()},
                                                      {"south", d.extent_lonlat().south()},
                                                      {"east", d.extent_lonlat().east()},
                                                      {"north", d.extent_lonlat().north()}}
                                               : Json(nullptr);
    j["nodata"] = d.has_nodata() ? finite_or_null(d.nodata()) : Json(nullptr);
    j["elevation"] =
        d.has_elevation_min() ? Json{{"min", d.elevation_min()}, {"max", d.elevation_max()}} : Json(nullptr);
    j["valid_cells"] = d.valid_cells();
    j["void_cells"] = d.void_cells();
    j["server"] = {{"address", client.address()}, {"source", d.source()}, {"resident_bytes", d.resident_bytes()}};
    print_json(j);
    return kExitOk;
  }

  std::cout << "Dataset:     " << name << " on " << client.address() << " (" << d.source() << ", "
            << with_separators(d.resident_bytes()) << " bytes resident)\n"
            << "Format:      " << d.format() << '\n'
            << "Size:        " << d.width() << " x " << d.height() << " cells (" << with_separators(cells) << ")\n";
  if (crs) {
    std::cout << "CRS:         " << crs_label(*crs) << '\n';
    if (crs->is_compound())
      std::cout << "Heights:     " << heights_label(*crs) << " (the vertical part of " << crs->name() << ")\n";
  } else if (d.epsg() != 0 || !d.crs_name().empty()) {
    // A daemon that sends no WKT: its code and name.
    std::cout << "CRS:         "
              << (d.epsg() ? "EPSG:" + std::to_string(d.epsg()) + " (" + d.crs_name() + ")" : d.crs_name())
              << (geographic ? ", geographic" : ", projected") << '\n';
  } else {
    std::cout << "CRS:         none (grid coordinates only)\n";
  }
  std::cout << "Origin:      " << coordinate(t.origin_x(), geographic) << ", " << coordinate(t.origin_y(), geographic)
            << "  (outer corner of the first cell)\n"
            << "Pixel size:  " << fixed(t.pixel_width(), geographic ? 10 : 4) << ", "
            << fixed(t.pixel_height(), geographic ? 10 : 4) << '\n'
            << "Cell size:   " << fixed(d.cell_size_x_m(), 2) << " m east-west x " << fixed(d.cell_size_y_m(), 2)
            << " m north-south (at the centre)\n"
            << "Extent:      x " << coordinate(e.x_min(), geographic) << " .. " << coordinate(e.x_max(), geographic)
            << ", y " << coordinate(e.y_min(), geographic) << " .. " << coordinate(e.y_max(), geographic) << '\n';
  if (d.has_extent_lonlat())
    std::cout << "Lon/lat:     lon " << fixed(d.extent_lonlat().west(), 6) << " .. "
              << fixed(d.extent_lonlat().east(), 6) << ", lat " << fixed(d.extent_lonlat().south(), 6) << " .. "
              << fixed(d.extent_lonlat().north(), 6) << '\n';
  std::cout << "Nodata:      " << (d.has_nodata() ? fixed(d.nodata(), 6) : std::string("none")) << '\n';
  if (d.has_elevation_min())
    std::cout << "Elevation:   " << fixed(d.elevation_min(), 2) << " .. " << fixed(d.elevation_max(), 2) << " m\n";
  else
    std::cout << "Elevation:   no valid cells\n";
  std::cout << "Voids:       " << with_separators(d.void_cells()) << " cells ("
            << fixed(cells ? 100.0 * static_cast<double>(d.void_cells()) / static_cast<double>(cells) : 0.0, 2)
            << " %)\n";
  return kExitOk;
}

}  // namespace horizon::cli::remote
