// geotiff_crs.cpp — GeoTIFF CRS keys to and from PROJ.
//
// Specifications:
//   * OGC GeoTIFF 1.1 (OGC 19-008r4), section 7 and annex B: GTModelTypeGeoKey,
//     ProjectedCSTypeGeoKey / GeographicTypeGeoKey (EPSG codes, 32767 =
//     user-defined), the user-defined geographic keys (datum, ellipsoid,
//     prime meridian, angular units), ProjCoordTransGeoKey (the CT_* method
//     codes) and its parameter keys (ProjNatOriginLatGeoKey, ...),
//     ProjLinearUnitsGeoKey, VerticalCSTypeGeoKey.
//   * GeogTOWGS84GeoKey (2062): libgeotiff's and GDAL's extension, 3 or 7
//     Helmert parameters to WGS 84.
//   * GDAL's conventions, followed so that gdalinfo reads back what we write:
//     which parameter key each method's parameters go to (LCC 2SP's false
//     origin keys, LAEA's and AEQD's centre keys, polar stereographic
//     variant B's standard parallel in ProjNatOriginLatGeoKey with a scale of
//     1), the projected CRS's name in GTCitationGeoKey, a user-defined
//     geographic CRS's names in GeogCitationGeoKey as "GCS Name = ...|Datum
//     = ...|Ellipsoid = ...|Primem = ...|", and ESRI's "ESRI PE String = WKT"
//     citation (read only).
//   * EPSG Guidance Note 7-2: the projection methods' EPSG codes and their
//     parameters' codes (8801 latitude of natural origin, ...), which is how
//     PROJ describes a projected CRS's conversion.
#include "geotiff_crs.hpp"

#include <geo_normalize.h>
#include <geovalues.h>
#include <proj.h>
#include <proj_experimental.h>

#include <cmath>
#include <cstdio>
#include <cstring>
#include <map>
#include <memory>
#include <numbers>
#include <optional>
#include <string>
#include <vector>

#include "geodesy/proj_support.hpp"
#include "geotiff_runtime.hpp"
#include "horizon/geodesy/crs.hpp"
#include "tiff_support.hpp"

namespace horizon::terrain::detail {
namespace {

using geodesy::detail::PjPtr;
using geodesy::detail::ProjContext;

constexpr double kDegree = std::numbers::pi / 180.0;
constexpr double kUsSurveyFoot = 1200.0 / 3937.0;
constexpr char kEsriPrefix[] = "ESRI PE String = ";

// ---------------------------------------------------------------- the methods

enum class Kind { kAngle, kLength, kScale };

struct Param {
  const char* proj;  // PROJ string parameter
  int read_key;      // its key in libgeotiff's normalised GTIFDefn
  int write_key;     // the key written (0: not written)
  int epsg;          // EPSG parameter code in PROJ's description of the conversion
  Kind kind;
  double fallback;
};

struct Method {
  int ct;            // ProjCoordTransGeoKey value
  const char* proj;  // PROJ +proj= name
  int epsg[2];       // EPSG method codes PROJ may describe it by (0: none)
  const char* name;  // method name, matched when PROJ gives no code
  std::vector<Param> params;
  const char* extra = "";  // fixed PROJ string terms
};

Param lat(const char* proj, int read_key, int epsg, int write_key = 0) {
  return {proj, read_key, write_key ? write_key : read_key, epsg, Kind::kAngle, 0.0};
}
Param length(const char* proj, int read_key, int epsg, int write_key = 0) {
  return {proj, read_key, write_key ? write_key : read_key, epsg, Kind::kLength, 0.0};
}
Param scale(const char* proj, int read_key, int epsg) {
  return {proj, read_key, read_key, epsg, Kind::kScale, 1.0};
}
Param false_easting() {
  return length("x_0", ProjFalseEastingGeoKey, 8806);
}
Param false_northing() {
  return length("y_0", ProjFalseNorthingGeoKey, 8807);
}

const std::vector<Method>& methods() {
  static const std::vector<Method> table = {
      {CT_TransverseMercator,
       "tmerc",
       {9807, 0},
       "Transverse Mercator",
       {lat("lat_0", ProjNatOriginLatGeoKey, 8801), lat("lon_0", ProjNatOriginLongGeoKey, 8802),
        scale("k", ProjScaleAtNatOriginGeoKey, 8805), false_easting(), false_northing()}},
      {CT_Mercator,
       "merc",
       {9804, 0},
       "Mercator (variant A)",
       {lat("lon_0", ProjNatOriginLongGeoKey, 8802), scale("k", ProjScaleAtNatOriginGeoKey, 8805), false_easting(),
        false_northing()}},
      {CT_Mercator,
       "merc",
       {9805, 0},
       "Mercator (variant B)",
       {lat("lat_ts", ProjStdParallel1GeoKey, 8823), lat("lon_0", ProjNatOriginLongGeoKey, 8802), false_easting(),
        false_northing()}},
      {CT_LambertConfConic_1SP,
       "lcc",
       {9801, 0},
       "Lambert Conic Conformal (1SP)",
       {lat("lat_1", ProjNatOriginLatGeoKey, 8801),
        {"lat_0", ProjNatOriginLatGeoKey, 0, 8801, Kind::kAngle, 0.0},
        lat("lon_0", ProjNatOriginLongGeoKey, 8802),
        scale("k_0", ProjScaleAtNatOriginGeoKey, 8805),
        false_easting(),
        false_northing()}},
      {CT_LambertConfConic_2SP,
       "lcc",
       {9802, 0},
       "Lambert Conic Conformal (2SP)",
       {lat("lat_0", ProjFalseOriginLatGeoKey, 8821), lat("lon_0", ProjFalseOriginLongGeoKey, 8822),
        lat("lat_1", ProjStdParallel1GeoKey, 8823), lat("lat_2", ProjStdParallel2GeoKey, 8824),
        length("x_0", ProjFalseEastingGeoKey, 8826, ProjFalseOriginEastingGeoKey),
        length("y_0", ProjFalseNorthingGeoKey, 8827, ProjFalseOriginNorthingGeoKey)}},
      {CT_LambertAzimEqualArea,
       "laea",
       {9820, 0},
       "Lambert Azimuthal Equal Area",
       {lat("lat_0", ProjCenterLatGeoKey, 8801), lat("lon_0", ProjCenterLongGeoKey, 8802), false_easting(),
        false_northing()}},
      {CT_AlbersEqualArea,
       "aea",
       {9822, 0},
       "Albers Equal Area",
       {lat("lat_1", ProjStdParallel1GeoKey, 8823), lat("lat_2", ProjStdParallel2GeoKey, 8824),
        lat("lat_0", ProjNatOriginLatGeoKey, 8821), lat("lon_0", ProjNatOriginLongGeoKey, 8822),
        length("x_0", ProjFalseEastingGeoKey, 8826), length("y_0", ProjFalseNorthingGeoKey, 8827)}},
      {CT_AzimuthalEquidistant,
       "aeqd",
       {9832, 1125},
       "Azimuthal Equidistant",
       {lat("lat_0", ProjCenterLatGeoKey, 8801), lat("lon_0", ProjCenterLongGeoKey, 8802), false_easting(),
        false_northing()}},
      {CT_EquidistantConic,
       "eqdc",
       {1119, 0},
       "Equidistant Conic",
       {lat("lat_1", ProjStdParallel1GeoKey, 8823), lat("lat_2", ProjStdParallel2GeoKey, 8824),
        lat("lat_0", ProjNatOriginLatGeoKey, 8821), lat("lon_0", ProjNatOriginLongGeoKey, 8822),
        length("x_0", ProjFalseEastingGeoKey, 8826), length("y_0", ProjFalseNorthingGeoKey, 8827)}},
      {CT_PolarStereographic,
       "stere",
       {9810, 0},
       "Polar Stereographic (variant A)",
       {lat("lat_0", ProjNatOriginLatGeoKey, 8801), lat("lon_0", ProjStraightVertPoleLongGeoKey, 8802),
        scale("k", ProjScaleAtNatOriginGeoKey, 8805), false_easting(), false_northing()}},
      {CT_PolarStereographic,
       "stere",
       {9829, 0},
       "Polar Stereographic (variant B)",
       {lat("lat_ts", ProjNatOriginLatGeoKey, 8832), lat("lon_0", ProjStraightVertPoleLongGeoKey, 8833),
        false_easting(), false_northing()}},
      {CT_ObliqueStereographic,
       "sterea",
       {9809, 0},
       "Oblique Stereographic",
       {lat("lat_0", ProjNatOriginLatGeoKey, 8801), lat("lon_0", ProjNatOriginLongGeoKey, 8802),
        scale("k", ProjScaleAtNatOriginGeoKey, 8805), false_easting(), false_northing()}},
      {CT_Equirectangular,
       "eqc",
       {1028, 1029},
       "Equidistant Cylindrical",
       {lat("lat_ts", ProjStdParallel1GeoKey, 8823), lat("lat_0", ProjCenterLatGeoKey, 8801),
        lat("lon_0", ProjCenterLongGeoKey, 8802), false_easting(), false_northing()}},
      {CT_CassiniSoldner,
       "cass",
       {9806, 0},
       "Cassini-Soldner",
       {lat("lat_0", ProjNatOriginLatGeoKey, 8801), lat("lon_0", ProjNatOriginLongGeoKey, 8802), false_easting(),
        false_northing()}},
      {CT_Orthographic,
       "ortho",
       {9840, 0},
       "Orthographic",
       {lat("lat_0", ProjCenterLatGeoKey, 8801), lat("lon_0", ProjCenterLongGeoKey, 8802), false_easting(),
        false_northing()}},
      {CT_Polyconic,
       "poly",
       {9818, 0},
       "American Polyconic",
       {lat("lat_0", ProjNatOriginLatGeoKey, 8801), lat("lon_0", ProjNatOriginLongGeoKey, 8802), false_easting(),
        false_northing()}},
      {CT_Sinusoidal,
       "sinu",
       {0, 0},
       "Sinusoidal",
       {lat("lon_0", ProjCenterLongGeoKey, 8802), false_easting(), false_northing()}},
      {CT_CylindricalEqualArea,
       "cea",
       {9835, 0},
       "Lambert Cylindrical Equal Area",
       {lat("lat_ts", ProjStdParallel1GeoKey, 8823), lat("lon_0", ProjNatOriginLongGeoKey, 8802), false_easting(),
        false_northing()}},
      {CT_ObliqueMercator,
       "omerc",
       {9812, 0},
       "Hotine Oblique Mercator (variant A)",
       {lat("lat_0", ProjCenterLatGeoKey, 8811), lat("lonc", ProjCenterLongGeoKey, 8812),
        lat("alpha", ProjAzimuthAngleGeoKey, 8813), lat("gamma", ProjRectifiedGridAngleGeoKey, 8814),
        scale("k", ProjScaleAtCenterGeoKey, 8815), false_easting(), false_northing()},
       " +no_uoff"},
      {CT_HotineObliqueMercatorAzimuthCenter,
       "omerc",
       {9815, 0},
       "Hotine Oblique Mercator (variant B)",
       {lat("lat_0", ProjCenterLatGeoKey, 8811), lat("lonc", ProjCenterLongGeoKey, 8812),
        lat("alpha", ProjAzimuthAngleGeoKey, 8813), lat("gamma", ProjRectifiedGridAngleGeoKey, 8814),
        scale("k", ProjScaleAtCenterGeoKey, 8815), length("x_0", ProjFalseEastingGeoKey, 8816),
        length("y_0", ProjFalseNorthingGeoKey, 8817)}},
  };
  return table;
}

std::string method_list() {
  std::string out;
  for (const Method& m : methods()) {
    if (!out.empty()) out += ", ";
    out += m.name;
  }
  return out;
}

// Keys a generator may have used for the same parameter (libgeotiff reads
// them as alternatives too).
std::vector<int> alternates(int key) {
  switch (key) {
    case ProjNatOriginLatGeoKey:
    case ProjCenterLatGeoKey:
    case ProjFalseOriginLatGeoKey:
      return {key, ProjNatOriginLatGeoKey, ProjCenterLatGeoKey, ProjFalseOriginLatGeoKey};
    case ProjNatOriginLongGeoKey:
    case ProjCenterLongGeoKey:
    case ProjFalseOriginLongGeoKey:
    case ProjStraightVertPoleLongGeoKey:
      return {key, ProjNatOriginLongGeoKey, ProjCenterLongGeoKey, ProjFalseOriginLongGeoKey,
              ProjStraightVertPoleLongGeoKey};
    case ProjFalseEastingGeoKey:
      return {key, ProjFalseOriginEastingGeoKey, ProjCenterEastingGeoKey};
    case ProjFalseNorthingGeoKey:
      return {key, ProjFalseOriginNorthingGeoKey, ProjCenterNorthingGeoKey};
    case ProjScaleAtNatOriginGeoKey:
    case ProjScaleAtCenterGeoKey:
      return {key, ProjScaleAtNatOriginGeoKey, ProjScaleAtCenterGeoKey};
    default:
      return {key};
  }
}

// ---------------------------------------------------------------- helpers

std::string text(const char* s) {
  return s ? std::string(s) : std::string();
}

std::string number(double v) {
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.17g", v);
  return buf;
}

// An ASCII key's text up to its first NUL, trailing '|' and spaces cut.
std::optional<std::string> ascii_key(const GeoKeys& keys, geokey_t key) {
  auto text = keys.ascii(key);
  if (!text) return std::nullopt;
  std::string s(text->c_str());
  while (!s.empty() && (s.back() == '|' || s.back() == ' ')) s.pop_back();
  return s;
}

Error unsupported(const std::string& what) {
  return make_error(ErrorCode::kUnsupported, what);
}

bool is_code(int v) {
  return v > 0 && v != KvUserDefined;
}

// A name worth keeping from a citation: not empty, not "unknown", not WKT.
std::optional<std::string> citation_name(const std::optional<std::string>& citation) {
  if (!citation) return std::nullopt;
  std::string s = *citation;
  // GDAL's "GCS Name = X|Datum = ...|" form.
  if (const auto at = s.find("GCS Name = "); at != std::string::npos) {
    s = s.substr(at + std::strlen("GCS Name = "));
    s = s.substr(0, s.find('|'));
  } else if (s.find('|') != std::string::npos) {
    s = s.substr(0, s.find('|'));
  }
  if (s.empty() || s == "unknown" || s.starts_with(kEsriPrefix)) return std::nullopt;
  return s;
}

int epsg_code_of(const PJ* pj) {
  const char* auth = proj_get_id_auth_name(pj, 0);
  const char* code = proj_get_id_code(pj, 0);
  if (!auth || !code || std::strcmp(auth, "EPSG") != 0) return 0;
  return std::atoi(code);
}

PjPtr from_database(PJ_CONTEXT* ctx, int code, PJ_CATEGORY category) {
  const std::string c = std::to_string(code);
  return PjPtr(proj_create_from_database(ctx, "EPSG", c.c_str(), category, 0, nullptr));
}

struct DefnFreer {
  void operator()(GTIFDefn* d) const { GTIFFreeDefn(d); }
};

// ---------------------------------------------------------------- reading

// The value of `key` in a normalised definition (degrees, metres), trying
// the keys other generators use for it.
std::optional<double> defn_param(const GTIFDefn& defn, int key) {
  for (int k : alternates(key))
    for (int i = 0; i < MAX_GTIF_PROJPARMS; ++i)
      if (defn.ProjParmId[i] == k) return defn.ProjParm[i];
  return std::nullopt;
}

const Method* method_for_keys(const GTIFDefn& defn) {
  for (const Method& m : methods()) {
    if (m.ct != defn.CTProjection) continue;
    if (m.ct == CT_Mercator) {
      // A standard parallel makes variant B.
      const bool two = defn_param(defn, ProjStdParallel1GeoKey).has_value();
      if ((m.epsg[0] == 9805) != two) continue;
    }
    if (m.ct == CT_PolarStereographic) {
      // The origin at a pole makes variant A; elsewhere it is variant B's standard parallel.
      const double origin = defn_param(defn, ProjNatOriginLatGeoKey).value_or(90.0);
      const bool at_pole = std::abs(std::abs(origin) - 90.0) < 1e-9;
      if ((m.epsg[0] == 9810) != at_pole) continue;
    }
    return &m;
  }
  return nullptr;
}

// PROJ string of the geodetic part of a user-defined CRS: ellipsoid, prime
// meridian and TOWGS84 (when the keys give no known datum).
std::string geodetic_terms(const GTIFDefn& defn) {
  std::string s;
  if (defn.SemiMajor > 0 && defn.SemiMinor > 0)
    s += " +a=" + number(defn.SemiMajor) + " +b=" + number(defn.SemiMinor);
  else
    s += " +ellps=WGS84";
  if (defn.PMLongToGreenwich != 0.0) s += " +pm=" + number(defn.PMLongToGreenwich);
  if (defn.TOWGS84Count == 3 || defn.TOWGS84Count == 7) {
    s += " +towgs84=";
    for (int i = 0; i < defn.TOWGS84Count; ++i) {
      if (i) s += ',';
      s += number(defn.TOWGS84[i]);
    }
  }
  return s;
}

// The value of `field` in GDAL's "GCS Name = X|Datum = Y|Ellipsoid = Z|Primem = W|"
// citation, if there.
std::optional<std::string> citation_field(const std::optional<std::string>& citation, const std::string& field) {
  if (!citation) return std::nullopt;
  const std::string key = field + " = ";
  std::size_t at = citation->find(key);
  // The field starts the citation or follows a '|'.
  while (at != std::string::npos && at != 0 && (*citation)[at - 1] != '|') at = citation->find(key, at + 1);
  if (at == std::string::npos) return std::nullopt;
  const std::size_t begin = at + key.size();
  std::string value = citation->substr(begin, citation->find('|', begin) - begin);
  if (value.empty()) return std::nullopt;
  return value;
}

// The name of the EPSG object `code` of `category`, if PROJ has it.
std::optional<std::string> database_name(PJ_CONTEXT* ctx, int code, PJ_CATEGORY category) {
  if (!is_code(code)) return std::nullopt;
  PjPtr object = from_database(ctx, code, category);
  if (!object) return std::nullopt;
  return text(proj_get_name(object.get()));
}

// The geographic CRS under a user-defined CRS: an EPSG code's; or its
// datum's code with the keys' names; or built from the keys' ellipsoid and
// prime meridian, named as GDAL names them (GeogCitationGeoKey's "GCS Name
// = ...|Datum = ...|Ellipsoid = ...|Primem = ...|", the EPSG names of any
// codes), so that it reads as the same CRS gdalinfo reports. Longitude and
// latitude in degrees.
Result<PjPtr> base_geographic(PJ_CONTEXT* ctx, const GeoKeys& keys, const GTIFDefn& defn) {
  if (is_code(defn.GCS)) {
    PjPtr base = from_database(ctx, defn.GCS, PJ_CATEGORY_CRS);
    if (!base) return unsupported("on geographic CRS EPSG:" + std::to_string(defn.GCS) + ", unknown to PROJ");
    return base;
  }
  const auto citation = ascii_key(keys, GeogCitationGeoKey);
  const std::string name = citation_field(citation, "GCS Name").value_or(citation_name(citation).value_or("unknown"));
  PjPtr cs(proj_create_ellipsoidal_2D_cs(ctx, PJ_ELLPS2D_LATITUDE_LONGITUDE, nullptr, 0));
  if (!cs) return unsupported("on a geographic CRS PROJ cannot build");
  PjPtr base;
  if (is_code(defn.Datum)) {
    PjPtr datum = from_database(ctx, defn.Datum, PJ_CATEGORY_DATUM);
    if (!datum) return unsupported("on datum EPSG:" + std::to_string(defn.Datum) + ", unknown to PROJ");
    base.reset(proj_create_geographic_crs_from_datum(ctx, name.c_str(), datum.get(), cs.get()));
  } else {
    if (!(defn.SemiMajor > 0) || !(defn.SemiMinor > 0) || defn.SemiMinor > defn.SemiMajor)
      return unsupported("with no valid ellipsoid (semi-major axis " + number(defn.SemiMajor) + " m, semi-minor " +
                         number(defn.SemiMinor) + " m)");
    const double inv_f = defn.SemiMinor == defn.SemiMajor ? 0.0 : defn.SemiMajor / (defn.SemiMajor - defn.SemiMinor);
    const std::string datum = citation_field(citation, "Datum").value_or("unknown");
    const std::string ellipsoid =
        citation_field(citation, "Ellipsoid")
            .value_or(database_name(ctx, defn.Ellipsoid, PJ_CATEGORY_ELLIPSOID).value_or("unknown"));
    const std::string meridian = citation_field(citation, "Primem")
                                     .value_or(database_name(ctx, defn.PM, PJ_CATEGORY_PRIME_MERIDIAN)
                                                   .value_or(defn.PMLongToGreenwich == 0.0 ? "Greenwich" : "unknown"));
    base.reset(proj_create_geographic_crs(ctx, name.c_str(), datum.c_str(), ellipsoid.c_str(), defn.SemiMajor, inv_f,
                                          meridian.c_str(), defn.PMLongToGreenwich, "degree", kDegree, cs.get()));
  }
  if (!base) return unsupported("on a geographic CRS PROJ cannot build");
  return base;
}

// `crs` (geographic or projected, from a PROJ string) on the geographic CRS
// `base`, and renamed `name` when given. A CRS bound to WGS 84 by a TOWGS84
// shift stays bound, by the same transformation: PROJ alters only unbound
// CRSs, so its source CRS is altered and bound again.
PjPtr with_base(PJ_CONTEXT* ctx, const PJ* crs, const PJ* base, const char* name) {
  const auto alter = [&](const PJ* plain) {
    PjPtr altered(proj_crs_alter_geodetic_crs(ctx, plain, base));
    if (altered && name) altered.reset(proj_alter_name(ctx, altered.get(), name));
    return altered;
  };
  if (proj_get_type(crs) != PJ_TYPE_BOUND_CRS) return alter(crs);
  PjPtr source(proj_get_source_crs(ctx, crs));
  PjPtr hub(proj_get_target_crs(ctx, crs));
  PjPtr shift(proj_crs_get_coordoperation(ctx, crs));
  PjPtr altered = source ? alter(source.get()) : nullptr;
  if (!altered || !hub || !shift) return nullptr;
  return PjPtr(proj_crs_create_bound_crs(ctx, altered.get(), hub.get(), shift.get()));
}

Result<std::string> user_defined_crs(const GeoKeys& keys, TIFF* tif, int model, int vertical) {
  ProjContext& context = geodesy::detail::thread_context();
  PJ_CONTEXT* ctx = context.get();
  const auto fail = [&](const std::string& what) {
    return make_error(ErrorCode::kUnsupported, "a user-defined CRS " + what);
  };

  PjPtr horizontal;
  // An ESRI PE string (WKT) in a citation says it all.
  for (geokey_t key : {PCSCitationGeoKey, GTCitationGeoKey}) {
    auto citation = ascii_key(keys, key);
    if (!citation || !citation->starts_with(kEsriPrefix)) continue;
    horizontal.reset(proj_create(ctx, citation->c_str() + std::strlen(kEsriPrefix)));
    if (!horizontal) return fail("in an ESRI PE string PROJ cannot read (" + context.take_error() + ")");
    break;
  }

  if (!horizontal) {
    // libgeotiff normalises the keys (codes resolved through PROJ's database).
    GtifPtr owned_gtif(GTIFNew(tif));
    std::unique_ptr<GTIFDefn, DefnFreer> owned(owned_gtif ? GTIFAllocDefn() : nullptr);
    if (!owned_gtif || !owned) {
      const std::string why = geotiff_runtime_error();
      return fail("whose keys libgeotiff cannot read" + (why.empty() ? std::string() : " (" + why + ")"));
    }
    GTIF* gtif = owned_gtif.get();
    GTIFAttachPROJContext(gtif, ctx);
    GTIFDefn& defn = *owned;
    if (!GTIFGetDefn(gtif, &defn)) return fail("whose keys libgeotiff cannot read");
    auto base = base_geographic(ctx, keys, defn);
    if (!base.ok()) return fail(base.error().message);
    // A TOWGS84 shift makes the CRS a BoundCRS: PROJ builds that from a PROJ
    // string (geodetic_terms), whose geographic CRS `base` then replaces.
    const bool shifted = defn.TOWGS84Count == 3 || defn.TOWGS84Count == 7;

    if (model == ModelTypeGeographic) {
      if (std::abs(defn.UOMAngleInDegrees - 1.0) > 1e-12 && !is_code(defn.GCS))
        return fail("in an angular unit other than degrees, which is not supported");
      if (shifted) {
        const std::string s = "+proj=longlat" + geodetic_terms(defn) + " +no_defs +type=crs";
        PjPtr bound(proj_create(ctx, s.c_str()));
        if (bound) horizontal = with_base(ctx, bound.get(), base->get(), nullptr);
      } else {
        horizontal = std::move(*base);
      }
    } else {
      const Method* method = method_for_keys(defn);
      if (!method) {
        const char* ct = GTIFValueNameEx(gtif, ProjCoordTransGeoKey, defn.CTProjection);
        return fail("whose projection (ProjCoordTransGeoKey " + std::to_string(defn.CTProjection) +
                    (ct ? " " + std::string(ct) : std::string()) +
                    ") Horizon cannot read from GeoTIFF keys (it reads: " + method_list() + ")");
      }
      std::string s = std::string("+proj=") + method->proj;
      for (const Param& p : method->params)
        s += std::string(" +") + p.proj + "=" + number(defn_param(defn, p.read_key).value_or(p.fallback));
      s += method->extra;
      if (method->epsg[0] == 9829) {
        const double standard = defn_param(defn, ProjNatOriginLatGeoKey).value_or(90.0);
        s += standard < 0 ? " +lat_0=-90" : " +lat_0=90";
      }
      if (!(defn.UOMLengthInMeters > 0)) return fail("with no valid linear unit");
      s += defn.UOMLengthInMeters == 1.0 ? std::string(" +units=m") : " +to_meter=" + number(defn.UOMLengthInMeters);
      s += geodetic_terms(defn) + " +no_defs +type=crs";
      horizontal.reset(proj_create(ctx, s.c_str()));
      if (!horizontal) return fail("PROJ cannot build from '" + s + "' (" + context.take_error() + ")");
      std::optional<std::string> name;
      for (geokey_t key : {PCSCitationGeoKey, GTCitationGeoKey})
        if ((name = citation_name(ascii_key(keys, key)))) break;
      horizontal = with_base(ctx, horizontal.get(), base->get(), name ? name->c_str() : nullptr);
      if (!horizontal) return fail("PROJ cannot set its geographic CRS (" + context.take_error() + ")");
    }
    if (!horizontal) return fail("PROJ cannot build (" + context.take_error() + ")");
  }

  PjPtr crs = std::move(horizontal);
  if (vertical) {
    PjPtr v = from_database(ctx, vertical, PJ_CATEGORY_CRS);
    if (!v) return fail("with vertical CRS EPSG:" + std::to_string(vertical) + ", unknown to PROJ");
    const std::string name = text(proj_get_name(crs.get())) + " + " + text(proj_get_name(v.get()));
    crs.reset(proj_create_compound_crs(ctx, name.c_str(), crs.get(), v.get()));
    if (!crs) return fail("PROJ cannot combine with vertical CRS EPSG:" + std::to_string(vertical));
  }
  const char* options[] = {"MULTILINE=NO", nullptr};
  std::string wkt = text(proj_as_wkt(ctx, crs.get(), PJ_WKT2_2019, options));
  context.take_error();
  if (wkt.empty()) return fail("PROJ cannot write as WKT");
  return wkt;
}

// ---------------------------------------------------------------- writing

// EPSG parameter code -> value in degrees, metres or unity.
std::map<int, double> conversion_params(PJ_CONTEXT* ctx, const PJ* conversion) {
  std::map<int, double> out;
  const int n = proj_coordoperation_get_param_count(ctx, conversion);
  for (int i = 0; i < n; ++i) {
    const char* auth = nullptr;
    const char* code = nullptr;
    const char* category = nullptr;
    double value = 0, factor = 1;
    if (!proj_coordoperation_get_param(ctx, conversion, i, nullptr, &auth, &code, &value, nullptr, &factor, nullptr,
                                       nullptr, nullptr, &category))
      continue;
    if (!code || !auth || std::strcmp(auth, "EPSG") != 0) continue;
    const bool angular = category && std::strcmp(category, "angular") == 0;
    out[std::atoi(code)] = angular ? value * factor / kDegree : value * factor;
  }
  return out;
}

// The linear unit key for `metres` per unit: a code, or user-defined with its size.
void set_linear_unit(GeoKeys& keys, double metres) {
  if (std::abs(metres - 1.0) < 1e-15)
    keys.set_short(ProjLinearUnitsGeoKey, Linear_Meter);
  else if (std::abs(metres - 0.3048) < 1e-15)
    keys.set_short(ProjLinearUnitsGeoKey, Linear_Foot);
  else if (std::abs(metres - kUsSurveyFoot) < 1e-15)
    keys.set_short(ProjLinearUnitsGeoKey, Linear_Foot_US_Survey);
  else {
    keys.set_short(ProjLinearUnitsGeoKey, KvUserDefined);
    keys.set_double(ProjLinearUnitSizeGeoKey, metres);
  }
}

Status write_geographic(GeoKeys& keys, PJ_CONTEXT* ctx, const PJ* base, const std::vector<double>& towgs84) {
  if (const int code = epsg_code_of(base); code != 0 && towgs84.empty()) {
    keys.set_short(GeographicTypeGeoKey, code);
    return Status::Ok();
  }
  PjPtr datum(proj_crs_get_datum_forced(ctx, base));
  PjPtr ellipsoid(proj_get_ellipsoid(ctx, base));
  PjPtr meridian(proj_get_prime_meridian(ctx, base));
  double a = 0, b = 0, inv_f = 0, pm = 0, pm_factor = 1;
  int b_computed = 0;
  if (!datum || !ellipsoid || !meridian ||
      !proj_ellipsoid_get_parameters(ctx, ellipsoid.get(), &a, &b, &b_computed, &inv_f) ||
      !proj_prime_meridian_get_parameters(ctx, meridian.get(), &pm, &pm_factor, nullptr))
    return unsupported("its geographic CRS '" + text(proj_get_name(base)) + "' has no readable datum");
  keys.set_short(GeographicTypeGeoKey, KvUserDefined);
  keys.set_ascii(GeogCitationGeoKey, "GCS Name = " + text(proj_get_name(base)) +
                                         "|Datum = " + text(proj_get_name(datum.get())) +
                                         "|Ellipsoid = " + text(proj_get_name(ellipsoid.get())) +
                                         "|Primem = " + text(proj_get_name(meridian.get())) + "|");
  const int datum_code = towgs84.empty() ? epsg_code_of(datum.get()) : 0;
  keys.set_short(GeogGeodeticDatumGeoKey, datum_code ? datum_code : KvUserDefined);
  const int ellipsoid_code = epsg_code_of(ellipsoid.get());
  keys.set_short(GeogEllipsoidGeoKey, ellipsoid_code ? ellipsoid_code : KvUserDefined);
  keys.set_double(GeogSemiMajorAxisGeoKey, a);
  if (inv_f > 0)
    keys.set_double(GeogInvFlatteningGeoKey, inv_f);
  else
    keys.set_double(GeogSemiMinorAxisGeoKey, b);
  const double pm_degrees = pm * pm_factor / kDegree;
  if (const int pm_code = epsg_code_of(meridian.get()); pm_code != 0 && pm_code != 8901)
    keys.set_short(GeogPrimeMeridianGeoKey, pm_code);
  else if (pm_degrees != 0.0)
    keys.set_double(GeogPrimeMeridianLongGeoKey, pm_degrees);
  keys.set_short(GeogAngularUnitsGeoKey, Angular_Degree);
  if (!towgs84.empty()) keys.set_doubles(GeogTOWGS84GeoKey, towgs84);
  return Status::Ok();
}

// The method of a conversion PROJ describes by EPSG method code, or, for
// methods PROJ 9.1 gives no code (Equidistant Conic, Sinusoidal), by name.
const Method* method_for_conversion(const std::string& name, int code) {
  if (code != 0)
    for (const Method& m : methods())
      if (m.epsg[0] == code || m.epsg[1] == code) return &m;
  for (const Method& m : methods())
    if (name == m.name) return &m;
  return nullptr;
}

Status write_user_defined(GeoKeys& keys, const geodesy::Crs& crs) {
  ProjContext& context = geodesy::detail::thread_context();
  PJ_CONTEXT* ctx = context.get();
  const std::string label = "CRS '" + crs.name() + "'";
  PjPtr whole(proj_create(ctx, crs.definition().c_str()));
  if (!whole) return unsupported(label + ": PROJ cannot read it (" + context.take_error() + ")");
  PjPtr horizontal(proj_get_type(whole.get()) == PJ_TYPE_COMPOUND_CRS ? proj_crs_get_sub_crs(ctx, whole.get(), 0)
                                                                      : proj_clone(ctx, whole.get()));
  std::vector<double> towgs84;
  PjPtr plain;
  if (horizontal && proj_get_type(horizontal.get()) == PJ_TYPE_BOUND_CRS) {
    PjPtr helmert(proj_crs_get_coordoperation(ctx, horizontal.get()));
    double values[7] = {};
    if (helmert && proj_coordoperation_get_towgs84_values(ctx, helmert.get(), values, 7, 0)) {
      towgs84.assign(values, values + 7);
      if (values[3] == 0 && values[4] == 0 && values[5] == 0 && values[6] == 0) towgs84.resize(3);
    }
    plain.reset(proj_get_source_crs(ctx, horizontal.get()));
  } else if (horizontal) {
    plain.reset(proj_clone(ctx, horizontal.get()));
  }
  context.take_error();
  if (!plain) return unsupported(label + ": PROJ cannot take its horizontal part");

  if (crs.is_geographic()) {
    if (std::abs(crs.unit_size() - 1.0) > 1e-12)
      return unsupported(label + ": a user-defined geographic CRS in " + crs.unit_name() +
                         " cannot be written as GeoTIFF keys (degrees only)");
    keys.set_short(GTModelTypeGeoKey, ModelTypeGeographic);
    return write_geographic(keys, ctx, plain.get(), towgs84);
  }

  PjPtr conversion(proj_crs_get_coordoperation(ctx, plain.get()));
  PjPtr base(proj_crs_get_geodetic_crs(ctx, plain.get()));
  if (!conversion || !base) return unsupported(label + ": PROJ cannot separate its projection");
  const char* method_name = nullptr;
  const char* method_code = nullptr;
  proj_coordoperation_get_method_info(ctx, conversion.get(), &method_name, nullptr, &method_code);
  const Method* method = method_for_conversion(text(method_name), method_code ? std::atoi(method_code) : 0);
  if (!method)
    return unsupported(label + " uses the " + text(method_name) +
                       " projection, which Horizon cannot write as GeoTIFF keys (it writes: " + method_list() +
                       "; or any CRS with an EPSG code)");
  keys.set_short(GTModelTypeGeoKey, ModelTypeProjected);
  keys.set_ascii(GTCitationGeoKey, crs.horizontal_name());
  HORIZON_RETURN_IF_ERROR(write_geographic(keys, ctx, base.get(), towgs84));
  keys.set_short(ProjectedCSTypeGeoKey, KvUserDefined);
  keys.set_short(ProjectionGeoKey, KvUserDefined);
  keys.set_short(ProjCoordTransGeoKey, method->ct);
  set_linear_unit(keys, crs.unit_size());
  const std::map<int, double> values = conversion_params(ctx, conversion.get());
  // PROJ 9.1 describes Equidistant Conic by its natural origin (8801, 8802,
  // 8806, 8807); EPSG's method 1119 by its false origin (8821, 8822, 8826, 8827).
  const auto value_of = [&](int code) -> std::optional<double> {
    for (const auto& [a, b] : {std::pair{8821, 8801}, {8822, 8802}, {8826, 8806}, {8827, 8807}})
      if (code == a || code == b)
        for (int c : {code, code == a ? b : a})
          if (const auto it = values.find(c); it != values.end()) return it->second;
    if (const auto it = values.find(code); it != values.end()) return it->second;
    return std::nullopt;
  };
  for (const Param& p : method->params) {
    if (p.write_key == 0) continue;
    double v = value_of(p.epsg).value_or(p.fallback);
    if (p.kind == Kind::kLength) v /= crs.unit_size();  // keys are in ProjLinearUnits
    keys.set_double(p.write_key, v);
  }
  if (method->epsg[0] == 9829) keys.set_double(ProjScaleAtNatOriginGeoKey, 1.0);  // as GDAL writes variant B
  context.take_error();
  return Status::Ok();
}

}  // namespace

CrsKeys read_crs_keys(const GeoKeys& geokeys, TIFF* tif) {
  CrsKeys keys;
  const auto model = geokeys.short_value(GTModelTypeGeoKey);
  if (!model) {
    // GDAL writes a local (engineering) CRS as a citation and units alone.
    if (auto name = citation_name(ascii_key(geokeys, GTCitationGeoKey))) {
      keys.problem =
          "CRS '" + *name + "' has no GTModelTypeGeoKey: a local (engineering) CRS, which has no place on the Earth";
      return keys;
    }
    keys.problem = "has no GTModelTypeGeoKey (no CRS)";
    keys.absent = true;
    return keys;
  }
  if (*model == ModelTypeGeocentric) {
    // GDAL writes a geocentric CRS as this model over its geographic CRS's code.
    const auto code = geokeys.short_value(GeographicTypeGeoKey);
    const auto name = citation_name(ascii_key(geokeys, GTCitationGeoKey));
    keys.problem = "CRS " + (name ? "'" + *name + "' " : std::string()) +
                   (code && is_code(*code) ? "(on EPSG:" + std::to_string(*code) + ") " : std::string()) +
                   "is geocentric (X, Y, Z from the Earth's centre), not a map's";
    return keys;
  }
  if (*model != ModelTypeProjected && *model != ModelTypeGeographic) {
    keys.problem = "the GeoTIFF model type (GTModelTypeGeoKey) is " + std::to_string(*model) +
                   ", neither projected (1) nor geographic (2)";
    return keys;
  }
  const auto code = geokeys.short_value(*model == ModelTypeProjected ? ProjectedCSTypeGeoKey : GeographicTypeGeoKey);
  const int horizontal = code && is_code(*code) ? *code : 0;
  const auto vertical_key = geokeys.short_value(VerticalCSTypeGeoKey);
  const int vertical = vertical_key && is_code(*vertical_key) ? *vertical_key : 0;
  if (!vertical)
    if (const auto units = geokeys.short_value(VerticalUnitsGeoKey);
        units && is_code(*units) && *units != Linear_Meter) {
      // The unit's EPSG name ("foot", "US survey foot"), as PROJ knows it.
      const char* name = nullptr;
      const std::string unit = std::to_string(*units);
      ProjContext& context = geodesy::detail::thread_context();
      proj_uom_get_info_from_database(context.get(), "EPSG", unit.c_str(), &name, nullptr, nullptr);
      context.take_error();
      keys.problem = "its elevations are in " + (name ? std::string(name) : "unit EPSG:" + unit) +
                     " (VerticalUnitsGeoKey " + unit + "); elevations must be in metres";
      return keys;
    }

  if (horizontal) {
    const std::string named =
        "EPSG:" + std::to_string(horizontal) + (vertical ? "+" + std::to_string(vertical) : std::string());
    auto crs = vertical ? geodesy::Crs::from_definition(named) : geodesy::Crs::from_epsg(horizontal);
    if (!crs.ok()) {
      keys.problem = crs.error().message;
      return keys;
    }
    keys.epsg = horizontal;
    if (vertical) keys.crs = named;
    return keys;
  }
  auto wkt = user_defined_crs(geokeys, tif, *model, vertical);
  if (!wkt.ok()) {
    keys.problem = wkt.error().message;
    return keys;
  }
  auto crs = geodesy::Crs::from_definition(*wkt);
  if (!crs.ok()) {
    keys.problem = "a user-defined " + crs.error().message;
    return keys;
  }
  // Its code, should the definition carry one (an ESRI PE string may).
  keys.epsg = crs->horizontal_epsg();
  keys.crs = *wkt;
  return keys;
}

Status write_crs_keys(GeoKeys& keys, const Georeference& georef) {
  if (!georef.has_crs()) return Status::Ok();
  auto crs = geodesy::Crs::of(georef);
  if (!crs.ok()) return crs.error();
  if (const int code = crs->horizontal_epsg(); code != 0) {
    if (crs->is_geographic()) {
      keys.set_short(GTModelTypeGeoKey, ModelTypeGeographic);
      keys.set_short(GeographicTypeGeoKey, code);
      if (std::abs(crs->unit_size() - 1.0) < 1e-12) keys.set_short(GeogAngularUnitsGeoKey, Angular_Degree);
    } else {
      keys.set_short(GTModelTypeGeoKey, ModelTypeProjected);
      keys.set_short(ProjectedCSTypeGeoKey, code);
      set_linear_unit(keys, crs->unit_size());
    }
  } else {
    HORIZON_RETURN_IF_ERROR(write_user_defined(keys, *crs));
  }
  if (crs->vertical_epsg() != 0) {
    // GeoTIFF 1.1 (key revision 1.1), as GDAL writes a compound CRS: GDAL
    // reads a vertical CRS from 1.1 files only.
    keys.set_revision(GEOTIFF_SPEC_1_1_KEY_REVISION, GEOTIFF_SPEC_1_1_MINOR_REVISION);
    keys.set_short(VerticalCSTypeGeoKey, crs->vertical_epsg());
    keys.set_short(VerticalUnitsGeoKey, Linear_Meter);
    if (crs->horizontal_epsg() != 0) keys.set_ascii(GTCitationGeoKey, crs->name());
  }
  return Status::Ok();
}

}  // namespace horizon::terrain::detail
