// geotiff_crs.hpp — a GeoTIFF's CRS GeoKeys <-> a Georeference's CRS.
//
// Reading: an EPSG code (ProjectedCSTypeGeoKey / GeographicTypeGeoKey) stays
// a code; a VerticalCSTypeGeoKey code beside it makes a compound CRS
// ("EPSG:27700+5701"); a user-defined CRS (code 32767) is built with PROJ
// from its keys (libgeotiff's GTIFGetDefn normalises them: datum,
// ellipsoid, prime meridian, TOWGS84, units, the projection method and its
// parameters in degrees and metres) into WKT2, or from an "ESRI PE String
// = WKT" citation. Its geographic CRS, datum, ellipsoid and prime meridian
// are named as GDAL names them (from GDAL's GeogCitationGeoKey, else the
// EPSG names of their codes), so it is PROJ-equivalent to what gdalinfo
// reports. Writing: the reverse, the keys GDAL writes for the same CRS (so
// gdalinfo reads the CRS it was given); with a vertical CRS, as GeoTIFF 1.1
// (key revision 1.1), the version GDAL reads a vertical CRS from by default.
//
// Projection methods carried by user-defined keys, both ways: transverse
// Mercator, Mercator (1SP, 2SP), Lambert conformal conic (1SP, 2SP), Lambert
// azimuthal equal area, Albers, azimuthal equidistant, equidistant conic,
// polar stereographic (variants A and B), oblique stereographic,
// equirectangular, Cassini-Soldner, orthographic, polyconic, sinusoidal,
// Lambert cylindrical equal area, Hotine oblique Mercator (variants A and
// B). Any CRS with an EPSG code is written as that code. A local
// (engineering) CRS, which GDAL writes as a citation without a model type,
// is named in `problem`.
#pragma once

#include <tiffio.h>

#include <string>

#include "geokeys.hpp"
#include "horizon/common/error.hpp"
#include "horizon/terrain/georef.hpp"

namespace horizon::terrain::detail {

struct CrsKeys {
  int epsg = 0;         // horizontal EPSG code
  std::string crs;      // the definition when the code alone does not say it
  std::string problem;  // why the keys give no CRS Horizon can use ("has no GTModelTypeGeoKey (no CRS)", ...)
  bool absent = false;  // the file names no CRS at all (no GTModelTypeGeoKey)
};

// The CRS the keys of `tif` describe, checked with geodesy::Crs; `problem`
// set when there is none or it cannot be used. Only a user-defined CRS
// calls libgeotiff, on `tif` (geotiff_runtime.hpp).
CrsKeys read_crs_keys(const GeoKeys& keys, TIFF* tif);

// Sets the keys of `georef`'s CRS (nothing without one): GTModelTypeGeoKey
// and the CRS's codes or user-defined keys. kUnsupported when a
// user-defined CRS's projection is not among those above.
Status write_crs_keys(GeoKeys& keys, const Georeference& georef);

}  // namespace horizon::terrain::detail
