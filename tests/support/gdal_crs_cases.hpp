// gdal_crs_cases.hpp — real GeoTIFFs in many CRSs, made at test time by GDAL.
//
// Each case is the bundled Rainier DEM (a 160 x 160 crop of real SRTM
// heights) given a CRS by gdal_translate -a_srs with a corner placed inside
// that CRS's area (-a_ullr), or warped into it by gdalwarp -t_srs: national
// grids, LAEA, Lambert conformal, polar stereographic (north and south),
// oblique Mercator, web Mercator, UTM, WGS 84, US feet, user-defined PROJ
// strings (odd transverse Mercator, azimuthal equidistant, Lambert in feet
// with a TOWGS84 shift, polar stereographic) and compound CRSs (horizontal
// + vertical). Tests skip (GTEST_SKIP) only when gdal-bin is missing.
#pragma once

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <sstream>
#include <string>
#include <vector>

#include "test_support.hpp"

namespace horizon::testing {

struct GdalCrsCase {
  std::string name;   // gtest name
  std::string srs;    // what GDAL is given
  bool warp = false;  // gdalwarp -t_srs; else gdal_translate -a_srs (-a_ullr when `west` is a number)
  double west = std::numeric_limits<double>::quiet_NaN(), north = 0.0, cell = 0.0;  // CRS units
  int epsg = 0;           // the horizontal EPSG code the file carries; 0 for a user-defined CRS
  int vertical_epsg = 0;  // a compound CRS's vertical code
};

inline const std::vector<GdalCrsCase>& gdal_crs_cases() {
  constexpr double kKeep = std::numeric_limits<double>::quiet_NaN();
  static const std::vector<GdalCrsCase> cases = {
      {"BritishNationalGrid", "EPSG:27700", false, 250000, 720000, 30, 27700, 0},
      {"LaeaEurope", "EPSG:3035", false, 2660000, 1950000, 30, 3035, 0},
      {"Lambert93", "EPSG:2154", false, 640000, 6870000, 25, 2154, 0},
      {"PolarStereographicNorth", "EPSG:3413", false, -340000, -2815000, 30, 3413, 0},
      {"PolarStereographicSouth", "EPSG:3031", false, 300000, -1284000, 30, 3031, 0},
      {"SwissLv95", "EPSG:2056", false, 2615000, 1095000, 10, 2056, 0},
      {"CaliforniaUsFeet", "EPSG:2227", false, 5985000, 2135000, 100, 2227, 0},
      {"WebMercator", "EPSG:3857", true, kKeep, 0, 0, 3857, 0},
      {"UtmZone10N", "EPSG:32610", true, kKeep, 0, 90, 32610, 0},
      {"Wgs84", "EPSG:4326", false, kKeep, 0, 0, 4326, 0},
      {"CustomTransverseMercator",
       "+proj=tmerc +lat_0=49.5 +lon_0=-121.25 +k=0.99951 +x_0=312345 +y_0=-87654 +ellps=GRS80 +units=m", false, 270000,
       -380000, 30, 0, 0},
      {"CustomAzimuthalEquidistant", "+proj=aeqd +lat_0=46.85 +lon_0=-121.76 +x_0=0 +y_0=0 +datum=WGS84 +units=m",
       false, -2400, 2400, 30, 0, 0},
      {"CustomLambertFeetTowgs84",
       "+proj=lcc +lat_0=46.5 +lon_0=3 +lat_1=49 +lat_2=44 +x_0=700000 +y_0=6600000 +ellps=GRS80 "
       "+towgs84=1,2,3,0,0,0,0 +units=us-ft",
       false, 2296000, 21654000, 100, 0, 0},
      {"CustomPolarStereographic", "+proj=stere +lat_0=-90 +lat_ts=-71 +lon_0=0 +x_0=0 +y_0=0 +datum=WGS84 +units=m",
       false, 300000, -1284000, 30, 0, 0},
      {"CompoundBritishGridOdnHeight", "EPSG:27700+5701", false, 250000, 720000, 30, 27700, 5701},
      {"CompoundSwissLv95Ln02Height", "EPSG:2056+5728", false, 2615000, 1095000, 10, 2056, 5728},
  };
  return cases;
}

inline bool have_gdal() {
  return run_command("command -v gdal_translate && command -v gdalinfo && command -v gdaltransform").exit_code == 0;
}

constexpr int kGdalCrsCropSize = 160;

// The case's GeoTIFF in `dir` (made once per dir), or "" with `error` set.
inline std::string make_gdal_crs_file(const GdalCrsCase& c, const std::string& dir, std::string* error) {
  const std::string source = bundled_dem("rainier_summit_srtm3_400x400.tif");
  const std::string out = dir + "/" + c.name + ".tif";
  std::ostringstream cmd;
  cmd.precision(17);
  if (c.warp) {
    cmd << "gdalwarp -q -overwrite -r bilinear -t_srs " << shell_quote(c.srs);
    if (c.cell > 0) cmd << " -tr " << c.cell << " " << c.cell;
    cmd << " " << shell_quote(source) << " " << shell_quote(out);
  } else {
    cmd << "gdal_translate -q -srcwin 120 120 " << kGdalCrsCropSize << " " << kGdalCrsCropSize << " -a_srs "
        << shell_quote(c.srs);
    if (!std::isnan(c.west))
      cmd << " -a_ullr " << c.west << " " << c.north << " " << c.west + kGdalCrsCropSize * c.cell << " "
          << c.north - kGdalCrsCropSize * c.cell;
    cmd << " " << shell_quote(source) << " " << shell_quote(out);
  }
  const CommandResult r = run_command(cmd.str());
  if (r.exit_code != 0) {
    if (error) *error = cmd.str() + ":\n" + r.output;
    return "";
  }
  return out;
}

}  // namespace horizon::testing
