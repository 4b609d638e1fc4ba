// crs.cpp — coordinate reference systems through PROJ, ellipsoid geometry through GeographicLib.
//
// References:
//   * PROJ 9 C API (proj.org/development/reference): proj_create,
//     proj_create_crs_to_crs_from_pj (the operation gdaltransform picks:
//     per point, the most accurate one whose area of use holds it),
//     proj_normalize_for_visualization (x = east/longitude, as GeoTIFF and
//     GDAL's "traditional GIS order"), proj_factors (the partial derivatives
//     of a projection, evaluated on the ellipsoid scaled to a = 1).
//   * EPSG Guidance Note 7-2: projection methods and parameters.
//   * Metric from the Jacobian. A projection maps geodetic (lambda, phi) to
//     (X, Y) = (x, y) / a; J = d(X, Y) / d(lambda, phi). A step of one unit
//     of X moves (dlambda, dphi) = J^-1 (1, 0), whose length on the
//     ellipsoid is a sqrt((n cos(phi) dlambda)^2 + (m dphi)^2), with
//     n = N / a = 1 / sqrt(1 - e^2 sin^2 phi) and m = M / a = (1 - e^2) /
//     (1 - e^2 sin^2 phi)^(3/2) the radii of curvature in the prime vertical
//     and the meridian. Per metre of x that is sqrt(...) alone, and the same
//     for y with J^-1 (0, 1). For a conformal projection both are 1/k; for
//     any other (LAEA, azimuthal equidistant, web Mercator on WGS 84) they
//     are the true ground lengths of the grid's own axes, whatever angle
//     the grid makes with the meridian there.
//   * Geographic CRSs: one unit of longitude is N cos(phi) and of latitude M
//     (GeographicLib::Ellipsoid's CircleRadius and MeridionalCurvatureRadius)
//     times the unit's size in radians.
//
// PROJ 9.1's proj_factors() on a projected CRS mishandles CRSs in feet or in
// northing/easting order (its derivatives come out in raw metres). So each
// projected CRS gets its own operation from its base geographic CRS in
// radians to the projected CRS in metres, GIS order — a single projection
// step, whose derivatives proj_factors gives on a = 1. A non-Greenwich prime
// meridian turns that operation into a pipeline whose derivatives are in
// metres: divided by a, they are the same.
#include "horizon/geodesy/crs.hpp"

#include <proj.h>
#include <proj_experimental.h>
#include <GeographicLib/Ellipsoid.hpp>
#include <GeographicLib/Math.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <mutex>
#include <numbers>
#include <optional>
#include <string>
#include <unordered_map>
#include <vector>

#include "builtin_crs.hpp"
#include "proj_support.hpp"

namespace horizon::geodesy {
namespace detail {

// ---------------------------------------------------------------- PROJ context

ProjContext::ProjContext() : ctx_(proj_context_create()) {
  if (ctx_) proj_log_func(ctx_, this, &ProjContext::log);
}

ProjContext::~ProjContext() {
  proj_context_destroy(ctx_);
}

void ProjContext::log(void* self, int level, const char* message) {
  if (level > PJ_LOG_ERROR || message == nullptr) return;
  static_cast<ProjContext*>(self)->last_ = message;
}

std::string ProjContext::take_error() {
  std::string message = without_directories(last_);
  last_.clear();
  if (message.empty()) message = without_directories(proj_runtime_error());
  return message.empty() ? std::string("no reason given") : message;
}

std::string without_directories(const std::string& text) {
  std::string out;
  out.reserve(text.size());
  std::size_t i = 0;
  while (i < text.size()) {
    const bool starts_word = i == 0 || text[i - 1] == ' ' || text[i - 1] == '\'' || text[i - 1] == '"' ||
                             text[i - 1] == '(' || text[i - 1] == '=' || text[i - 1] == ':';
    if (text[i] == '/' && starts_word) {
      // An absolute path: keep what follows its last '/'.
      std::size_t end = i;
      while (end < text.size() && text[end] != ' ' && text[end] != '\'' && text[end] != '"' && text[end] != ')' &&
             text[end] != ',')
        ++end;
      const std::size_t last = text.rfind('/', end - 1);
      out.append(text, last + 1, end - last - 1);
      i = end;
      continue;
    }
    out += text[i++];
  }
  return out;
}

ProjContext& thread_context() {
  thread_local ProjContext context;
  return context;
}

std::string quote_definition(const std::string& definition) {
  constexpr std::size_t kMax = 96;
  std::string text = definition;
  std::replace(text.begin(), text.end(), '\n', ' ');
  if (text.size() > kMax) text = text.substr(0, kMax) + "...";
  return "'" + text + "'";
}

// ---------------------------------------------------------------- descriptions

// What one context needs to serve a CRS: the operations, bound to `context`.
// Members die in reverse order: the PJs before their context.
struct ProjSet {
  ProjContext context;
  PjPtr bound;       // the horizontal CRS as it goes to WGS 84, until to_wgs84 is made from it
  PjPtr to_wgs84;    // horizontal CRS (GIS order, CRS units) -> EPSG:4326 (lon, lat degrees); see wgs84_operation
  PjPtr projection;  // projected only: base CRS (lon, lat radians) -> projected (x, y metres, GIS order)
  bool projection_is_pipeline = false;
};

struct CrsData {
  std::string definition, name, horizontal_name, vertical_name, projection, unit_name;
  int epsg = 0, horizontal_epsg = 0, vertical_epsg = 0;
  bool geographic = false;
  double unit_size = 1.0;  // metres (projected) or degrees (geographic) per unit
  double a = kEarthRadiusMetres, e2 = 0.0;
  std::optional<GeographicLib::Ellipsoid> ellipsoid;  // set with a and e2
  // A CRS described without PROJ (builtin_crs.hpp): its WKT is PROJ's, made
  // on first use.
  std::optional<BuiltinCrs> builtin;
  mutable std::once_flag wkt_once;
  mutable std::string wkt;

  mutable std::mutex mutex;
  mutable std::vector<std::unique_ptr<ProjSet>> idle;  // sets not in use
};

}  // namespace detail

namespace {

using detail::CrsData;
using detail::PjPtr;
using detail::ProjContext;
using detail::ProjSet;

constexpr double kDegree = std::numbers::pi / 180.0;
// A position must convert back to itself within this (degrees; ~0.1 m).
constexpr double kRoundTripDegrees = 1e-6;
// ... and a CRS position within this many metres.
constexpr double kRoundTripMetres = 0.01;
// Distinct CRSs kept process-wide; beyond, a CRS is described per handle.
constexpr std::size_t kMaxRegistered = 512;

Error unsupported(const std::string& what) {
  return make_error(ErrorCode::kUnsupported, what);
}

Error out_of_range(const std::string& crs_name, const std::string& what) {
  return make_error(ErrorCode::kOutOfRange, crs_name + ": " + what);
}

std::string format_lonlat(LonLat p) {
  char buf[96];
  std::snprintf(buf, sizeof buf, "lon %.9g, lat %.9g", p.lon, p.lat);
  return buf;
}

std::string format_xy(XY p) {
  char buf[96];
  std::snprintf(buf, sizeof buf, "x %.10g, y %.10g", p.x, p.y);
  return buf;
}

std::string string_or_empty(const char* s) {
  return s ? std::string(s) : std::string();
}

int epsg_code_of(const PJ* pj) {
  const char* auth = proj_get_id_auth_name(pj, 0);
  const char* code = proj_get_id_code(pj, 0);
  if (!auth || !code || std::strcmp(auth, "EPSG") != 0) return 0;
  char* end = nullptr;
  const long v = std::strtol(code, &end, 10);
  return (end && *end == '\0' && v > 0 && v < 1'000'000'000) ? static_cast<int>(v) : 0;
}

const char* kind_of(PJ_TYPE type) {
  switch (type) {
    case PJ_TYPE_GEOCENTRIC_CRS:
      return "a geocentric CRS (X, Y, Z from the Earth's centre), not a map's";
    case PJ_TYPE_ENGINEERING_CRS:
      return "an engineering (local) CRS, which has no place on the Earth";
    case PJ_TYPE_VERTICAL_CRS:
      return "a vertical CRS alone, with no horizontal position";
    case PJ_TYPE_TEMPORAL_CRS:
      return "a temporal CRS";
    default:
      return "neither geographic nor projected";
  }
}

PjPtr clone(PJ_CONTEXT* ctx, const PJ* pj) {
  return PjPtr(proj_clone(ctx, pj));
}

// The horizontal CRS of a CRS as the engine uses it: a compound CRS's first
// part, a 3D geographic CRS made 2D; BoundCRSs (towgs84) kept bound, so the
// transformation to WGS 84 honours them. `plain` is the same without the
// binding. Errors say why it is refused.
struct Horizontal {
  PjPtr bound;  // what goes to WGS 84
  PjPtr plain;  // what it is
  PjPtr vertical;
};

Result<Horizontal> horizontal_of(ProjContext& context, const PJ* crs, const std::string& label) {
  PJ_CONTEXT* ctx = context.get();
  Horizontal h;
  if (proj_get_type(crs) == PJ_TYPE_COMPOUND_CRS) {
    h.bound.reset(proj_crs_get_sub_crs(ctx, crs, 0));
    h.vertical.reset(proj_crs_get_sub_crs(ctx, crs, 1));
    if (!h.bound || !h.vertical) return unsupported(label + ": a compound CRS without two parts");
  } else {
    h.bound = clone(ctx, crs);
  }
  h.plain = proj_get_type(h.bound.get()) == PJ_TYPE_BOUND_CRS ? PjPtr(proj_get_source_crs(ctx, h.bound.get()))
                                                              : clone(ctx, h.bound.get());
  if (!h.plain) return unsupported(label + ": PROJ cannot read it (" + context.take_error() + ")");
  switch (proj_get_type(h.plain.get())) {
    case PJ_TYPE_GEOGRAPHIC_3D_CRS: {
      PjPtr flat(proj_crs_demote_to_2D(ctx, nullptr, h.plain.get()));
      if (!flat) return unsupported(label + ": a 3D geographic CRS PROJ cannot make 2D");
      if (proj_get_type(h.bound.get()) != PJ_TYPE_BOUND_CRS) h.bound = clone(ctx, flat.get());
      h.plain = std::move(flat);
      break;
    }
    case PJ_TYPE_GEOGRAPHIC_2D_CRS: {
      // A derived geographic CRS (rotated pole) carries its deriving conversion.
      PjPtr deriving(proj_crs_get_coordoperation(ctx, h.plain.get()));
      context.take_error();
      if (deriving) return unsupported(label + ": a derived (e.g. rotated-pole) geographic CRS is not supported");
      break;
    }
    case PJ_TYPE_PROJECTED_CRS:
      break;
    default:
      return unsupported(label + " is " + kind_of(proj_get_type(h.plain.get())));
  }
  return h;
}

struct AxisUnit {
  std::string name;
  double factor = 1.0;  // SI (metres or radians) per unit
};

Result<AxisUnit> axis_unit(ProjContext& context, const PJ* crs, const std::string& label, int axis) {
  PJ_CONTEXT* ctx = context.get();
  PjPtr cs(proj_crs_get_coordinate_system(ctx, crs));
  if (!cs || proj_cs_get_axis_count(ctx, cs.get()) <= axis)
    return unsupported(label + ": its coordinate system has too few axes");
  const char* unit_name = nullptr;
  double factor = 0;
  if (!proj_cs_get_axis_info(ctx, cs.get(), axis, nullptr, nullptr, nullptr, &factor, &unit_name, nullptr, nullptr) ||
      !(factor > 0))
    return unsupported(label + ": its axes have no unit");
  return AxisUnit{string_or_empty(unit_name), factor};
}

// Builds one context's operations for `definition`; with `facts`, also
// checks the CRS and describes it there (the first build of a description).
Result<std::unique_ptr<ProjSet>> build_set(const std::string& definition, CrsData* facts) {
  auto set = std::make_unique<ProjSet>();
  ProjContext& context = set->context;
  PJ_CONTEXT* ctx = context.get();
  std::string label = "CRS " + detail::quote_definition(definition);

  PjPtr crs(proj_create(ctx, definition.c_str()));
  if (!crs) return unsupported(label + " is not a CRS PROJ can read (" + context.take_error() + ")");
  // From here on messages name it: "CRS EPSG:5714 (MSL height)", "CRS 'unknown'".
  const std::string crs_name = string_or_empty(proj_get_name(crs.get()));
  if (definition.starts_with("EPSG:") && definition.size() < 32)
    label = "CRS " + definition + " (" + crs_name + ")";
  else
    label = "CRS '" + crs_name + "'";
  if (!proj_is_crs(crs.get())) return unsupported(label + " is not a coordinate reference system");
  auto h = horizontal_of(context, crs.get(), label);
  if (!h.ok()) return h.error();
  const bool geographic = proj_get_type(h->plain.get()) == PJ_TYPE_GEOGRAPHIC_2D_CRS;

  // The transformation to WGS 84 is searched for when a position is first
  // converted (wgs84_operation); PROJ finds one (a "ballpark" one at worst)
  // for every CRS on the Earth, so only another body is refused here.
  {
    const char* body = proj_get_celestial_body_name(ctx, h->plain.get());
    if (body && std::strcmp(body, "Earth") != 0)
      return unsupported(label + ": PROJ knows no way from it to WGS 84 (it lies on " + body + ", not the Earth)");
    context.take_error();
  }
  set->bound = std::move(h->bound);

  if (!geographic) {
    PjPtr gis(proj_normalize_for_visualization(ctx, h->plain.get()));
    PjPtr metric(gis ? proj_crs_alter_cs_linear_unit(ctx, gis.get(), "metre", 1.0, "EPSG", "9001") : nullptr);
    PjPtr base(metric ? proj_crs_get_geodetic_crs(ctx, metric.get()) : nullptr);
    PjPtr base_gis(base ? proj_normalize_for_visualization(ctx, base.get()) : nullptr);
    PjPtr base_rad(base_gis ? proj_crs_alter_cs_angular_unit(ctx, base_gis.get(), "radian", 1.0, "EPSG", "9101")
                            : nullptr);
    // The projection as its PROJ string ("+proj=utm +zone=25 +south
    // +ellps=GRS80 +units=m"): made without searching the database, which
    // proj_create_crs_to_crs does (5-12 ms for SIRGAS 2000 / UTM 25S) to
    // find the same single step. A CRS PROJ cannot write so, or whose string
    // is more than one step, takes the search.
    if (metric) {
      const char* text = proj_as_proj_string(ctx, metric.get(), PJ_PROJ_5, nullptr);
      std::string step = text ? text : "";
      if (const auto at = step.find(" +type=crs"); at != std::string::npos) step.erase(at, 10);
      if (!step.empty() && step.find("+proj=pipeline") == std::string::npos &&
          step.find("+towgs84") == std::string::npos && step.find("+nadgrids") == std::string::npos)
        set->projection.reset(proj_create(ctx, step.c_str()));
      context.take_error();
    }
    if (!set->projection && base_rad)
      set->projection.reset(proj_create_crs_to_crs_from_pj(ctx, base_rad.get(), metric.get(), nullptr, nullptr));
    if (!set->projection)
      return unsupported(label + ": PROJ cannot separate its projection (" + context.take_error() + ")");
    const char* steps = proj_as_proj_string(ctx, set->projection.get(), PJ_PROJ_5, nullptr);
    set->projection_is_pipeline = steps == nullptr || std::strstr(steps, "+proj=pipeline") != nullptr;
    context.take_error();
  }
  if (!facts) return set;

  // Describe it: names, codes, units, ellipsoid, WKT.
  CrsData& d = *facts;
  d.geographic = geographic;
  d.name = crs_name;
  d.epsg = epsg_code_of(crs.get());
  d.horizontal_name = string_or_empty(proj_get_name(h->plain.get()));
  d.horizontal_epsg = epsg_code_of(h->plain.get());
  if (h->vertical) {
    PjPtr vertical = proj_get_type(h->vertical.get()) == PJ_TYPE_BOUND_CRS
                         ? PjPtr(proj_get_source_crs(ctx, h->vertical.get()))
                         : clone(ctx, h->vertical.get());
    if (!vertical || proj_get_type(vertical.get()) != PJ_TYPE_VERTICAL_CRS)
      return unsupported(label + ": the second part of a compound CRS must be a vertical CRS");
    d.vertical_name = string_or_empty(proj_get_name(vertical.get()));
    d.vertical_epsg = epsg_code_of(vertical.get());
    auto unit = axis_unit(context, vertical.get(), label, 0);
    if (!unit.ok()) return unit.error();
    if (std::abs(unit->factor - 1.0) > 1e-12)
      return unsupported(label + ": its heights (" + d.vertical_name + ") are in " + unit->name +
                         "; elevations must be in metres");
  }
  auto x_unit = axis_unit(context, h->plain.get(), label, 0);
  if (!x_unit.ok()) return x_unit.error();
  auto y_unit = axis_unit(context, h->plain.get(), label, 1);
  if (!y_unit.ok()) return y_unit.error();
  if (std::abs(x_unit->factor - y_unit->factor) > 1e-15 * x_unit->factor)
    return unsupported(label + ": its axes have different units (" + x_unit->name + ", " + y_unit->name + ")");
  d.unit_name = x_unit->name;
  d.unit_size = geographic ? x_unit->factor / kDegree : x_unit->factor;
  if (!geographic) {
    PjPtr conversion(proj_crs_get_coordoperation(ctx, h->plain.get()));
    const char* method = nullptr;
    if (conversion) proj_coordoperation_get_method_info(ctx, conversion.get(), &method, nullptr, nullptr);
    d.projection = string_or_empty(method);
  }
  PjPtr ellipsoid(proj_get_ellipsoid(ctx, h->plain.get()));
  double a = 0, b = 0, inv_f = 0;
  int b_computed = 0;
  if (!ellipsoid || !proj_ellipsoid_get_parameters(ctx, ellipsoid.get(), &a, &b, &b_computed, &inv_f) || !(a > 0) ||
      !(b > 0) || b > a)
    return unsupported(label + ": its ellipsoid cannot be read");
  const double f = (a - b) / a;
  d.a = a;
  d.e2 = f * (2.0 - f);
  d.ellipsoid.emplace(a, f);
  const char* options[] = {"MULTILINE=NO", nullptr};
  d.wkt = string_or_empty(proj_as_wkt(ctx, crs.get(), PJ_WKT2_2019, options));
  context.take_error();
  return set;
}

// The set's transformation to WGS 84, made on first use: PROJ's search of
// its database for it costs 3-15 ms (NAD83: 14 ms), which a viewshed that
// never converts a position does not pay. Null, with the reason in `why`,
// when PROJ finds none.
PJ* wgs84_operation(ProjSet& set, std::string& why) {
  if (!set.to_wgs84 && set.bound) {
    PJ_CONTEXT* ctx = set.context.get();
    PjPtr wgs84(proj_create(ctx, "EPSG:4326"));
    PjPtr op(wgs84 ? proj_create_crs_to_crs_from_pj(ctx, set.bound.get(), wgs84.get(), nullptr, nullptr) : nullptr);
    if (op) set.to_wgs84.reset(proj_normalize_for_visualization(ctx, op.get()));
    why = op ? "PROJ cannot order its axes east, north"
             : "PROJ knows no way from it to WGS 84 (" + set.context.take_error() + ")";
    set.context.take_error();
    if (set.to_wgs84) set.bound.reset();
  }
  return set.to_wgs84.get();
}

// Borrows a ProjSet of `data` for one call, building one when none is idle.
class Lease {
 public:
  explicit Lease(const CrsData& data) : data_(data) {
    {
      std::lock_guard lock(data_.mutex);
      if (!data_.idle.empty()) {
        set_ = std::move(data_.idle.back());
        data_.idle.pop_back();
        return;
      }
    }
    if (auto built = build_set(data_.definition, nullptr); built.ok()) set_ = std::move(*built);
  }
  ~Lease() {
    if (!set_) return;
    std::lock_guard lock(data_.mutex);
    data_.idle.push_back(std::move(set_));
  }
  Lease(const Lease&) = delete;
  Lease& operator=(const Lease&) = delete;
  ProjSet* get() const { return set_.get(); }

 private:
  const CrsData& data_;
  std::unique_ptr<ProjSet> set_;
};

struct Registry {
  std::mutex mutex;
  std::unordered_map<std::string, std::shared_ptr<const CrsData>> by_definition;
};

Registry& registry() {
  static Registry* r = new Registry;  // never destroyed: handles may outlive static destruction
  return *r;
}

// The facts of a built-in CRS, as PROJ gives them; no PROJ object is made
// until a call needs one.
void describe_builtin(const detail::BuiltinCrs& crs, CrsData& d) {
  d.builtin = crs;
  d.geographic = crs.geographic();
  d.name = d.horizontal_name = detail::builtin_crs_name(crs);
  d.epsg = d.horizontal_epsg = crs.epsg;
  d.unit_name = crs.geographic() ? "degree" : "metre";
  d.unit_size = 1.0;
  switch (crs.kind) {
    case detail::BuiltinKind::kGeographic:
      d.projection = "";
      break;
    case detail::BuiltinKind::kTransverseMercator:
      d.projection = "Transverse Mercator";
      break;
    case detail::BuiltinKind::kWebMercator:
      d.projection = "Popular Visualisation Pseudo Mercator";
      break;
  }
  // The flattening in build_set's arithmetic, from the semi-minor axis as
  // PROJ derives it, so that both describe the ellipsoid to the last bit.
  const detail::EllipsoidFacts e = detail::ellipsoid_of(crs.datum);
  const double b = e.a * (1.0 - 1.0 / e.inverse_flattening);
  const double f = (e.a - b) / e.a;
  d.a = e.a;
  d.e2 = f * (2.0 - f);
  d.ellipsoid.emplace(d.a, f);
}

Result<std::shared_ptr<const CrsData>> describe(const std::string& definition) {
  Registry& r = registry();
  {
    std::lock_guard lock(r.mutex);
    if (auto it = r.by_definition.find(definition); it != r.by_definition.end()) return it->second;
  }
  auto data = std::make_shared<CrsData>();
  data->definition = definition;
  if (auto builtin = detail::builtin_crs(definition)) {
    describe_builtin(*builtin, *data);
  } else {
    auto set = build_set(definition, data.get());  // outside the lock: a database query
    if (!set.ok()) return set.error();
    data->idle.push_back(std::move(*set));
  }
  std::lock_guard lock(r.mutex);
  if (auto it = r.by_definition.find(definition); it != r.by_definition.end()) return it->second;
  if (r.by_definition.size() < kMaxRegistered) r.by_definition.emplace(definition, data);
  return std::shared_ptr<const CrsData>(std::move(data));
}

bool finite(const PJ_COORD& c) {
  return std::isfinite(c.xy.x) && std::isfinite(c.xy.y) && c.xy.x != HUGE_VAL && c.xy.y != HUGE_VAL;
}

// Whether `out` (= `op` applied to `in` in direction `dir`) converts back to
// `in`, as `same` judges. With several candidate operations PROJ picks one
// per point by its area of use, and near the edge of an area the way back
// may pick another (a Helmert shift one way, the datum-less "ballpark" the
// other: ~150 m apart for OSGB36 east of Shetland), which is no fault of
// the position: then the operation that carried it out is asked to take it
// back (PROJ hands out a copy of it, so only when the first answer fails).
template <class Same>
bool converts_back(PJ* op, PJ_DIRECTION dir, const PJ_COORD& in, const PJ_COORD& out, const Same& same) {
  const PJ_DIRECTION back = dir == PJ_FWD ? PJ_INV : PJ_FWD;
  proj_errno_reset(op);
  const bool direct = same(proj_trans(op, back, out));
  proj_errno_reset(op);
  if (direct) return true;
  (void)proj_trans(op, dir, in);  // the same choice as the first time
  PjPtr used(proj_trans_get_last_used_operation(op));
  proj_errno_reset(op);
  return used && same(proj_trans(used.get(), back, out));
}

// What PROJ said about the last failed call on `op`, as " (PROJ: ...)"; cleared.
std::string proj_reason(PJ* op, ProjContext& context) {
  const int err = proj_errno(op);
  proj_errno_reset(op);
  context.take_error();
  return err ? std::string(" (PROJ: ") + proj_context_errno_string(context.get(), err) + ")" : "";
}

}  // namespace

Result<Crs> Crs::from_definition(const std::string& definition) {
  if (definition.empty()) return make_error(ErrorCode::kInvalidArgument, "an empty text is not a CRS definition");
  auto data = describe(definition);
  if (!data.ok()) return data.error();
  return Crs(std::move(*data));
}

Result<Crs> Crs::from_epsg(int epsg) {
  if (epsg <= 0) return unsupported("EPSG:" + std::to_string(epsg) + " is not a CRS code");
  return from_definition("EPSG:" + std::to_string(epsg));
}

Result<Crs> Crs::of(const terrain::Georeference& georef) {
  if (!georef.crs.empty()) return from_definition(georef.crs);
  if (georef.epsg != 0) return from_epsg(georef.epsg);
  return make_error(ErrorCode::kInvalidArgument, "the georeference has no CRS");
}

const std::string& Crs::definition() const {
  return data_->definition;
}
int Crs::epsg() const {
  return data_->epsg;
}
int Crs::horizontal_epsg() const {
  return data_->horizontal_epsg;
}
int Crs::vertical_epsg() const {
  return data_->vertical_epsg;
}
const std::string& Crs::name() const {
  return data_->name;
}
const std::string& Crs::horizontal_name() const {
  return data_->horizontal_name;
}
const std::string& Crs::vertical_name() const {
  return data_->vertical_name;
}
bool Crs::is_geographic() const {
  return data_->geographic;
}
const std::string& Crs::projection() const {
  return data_->projection;
}
const std::string& Crs::unit_name() const {
  return data_->unit_name;
}
double Crs::unit_size() const {
  return data_->unit_size;
}
const std::string& Crs::wkt() const {
  const CrsData& d = *data_;
  if (d.builtin)
    std::call_once(d.wkt_once, [&d] {
      CrsData full;
      if (build_set(d.definition, &full).ok()) d.wkt = std::move(full.wkt);
    });
  return d.wkt;
}

Result<XY> Crs::from_lonlat(LonLat p) const {
  const std::string& name = data_->name;
  if (!std::isfinite(p.lon) || !std::isfinite(p.lat) || std::abs(p.lat) > 90.0)
    return out_of_range(name, "position (" + format_lonlat(p) + ") is not a valid longitude/latitude");
  if (const auto& builtin = data_->builtin; builtin && detail::identity_to_wgs84(builtin->datum)) {
    if (builtin->geographic()) return XY{p.lon, p.lat};
    if (auto xy = builtin->kind == detail::BuiltinKind::kWebMercator ? detail::web_mercator_from_lonlat(p)
                                                                     : detail::tm_from_lonlat(*builtin, p))
      return *xy;
  }
  Lease lease(*data_);
  ProjSet* set = lease.get();
  if (!set) return make_error(ErrorCode::kInternal, name + ": PROJ could not set up its transformation");
  std::string why;
  PJ* op = wgs84_operation(*set, why);
  if (!op) return unsupported(name + ": " + why);
  const PJ_COORD in = proj_coord(p.lon, p.lat, 0.0, HUGE_VAL);
  const auto same_place = [&](const PJ_COORD& back) {
    return finite(back) && std::abs(std::remainder(back.lp.lam - p.lon, 360.0)) <= kRoundTripDegrees &&
           std::abs(back.lp.phi - p.lat) <= kRoundTripDegrees;
  };
  proj_errno_reset(op);
  const PJ_COORD xy = proj_trans(op, PJ_INV, in);
  if (!finite(xy))
    return out_of_range(
        name, "position (" + format_lonlat(p) + ") has no coordinates in this CRS" + proj_reason(op, set->context));
  if (!converts_back(op, PJ_INV, in, xy, same_place))
    return out_of_range(name, "position (" + format_lonlat(p) +
                                  ") is outside the projection's domain (its coordinates do not convert back)");
  return XY{xy.xy.x, xy.xy.y};
}

Result<LonLat> Crs::to_lonlat(XY p) const {
  const CrsData& d = *data_;
  if (!std::isfinite(p.x) || !std::isfinite(p.y))
    return out_of_range(d.name, "position (" + format_xy(p) + ") is not finite");
  if (d.geographic && std::abs(p.y * d.unit_size) > 90.0)
    return out_of_range(d.name, "position (" + format_xy(p) + ") has a latitude beyond 90 degrees");
  if (d.builtin && detail::identity_to_wgs84(d.builtin->datum)) {
    if (d.builtin->geographic()) return LonLat{GeographicLib::Math::AngNormalize(p.x), p.y};
    if (d.builtin->kind == detail::BuiltinKind::kWebMercator) {
      if (auto ll = detail::web_mercator_to_lonlat(p)) return ll->lonlat;
    } else if (auto ll = detail::tm_to_lonlat(*d.builtin, p)) {
      return ll->lonlat;
    }
  }
  Lease lease(d);
  ProjSet* set = lease.get();
  if (!set) return make_error(ErrorCode::kInternal, d.name + ": PROJ could not set up its transformation");
  std::string why;
  PJ* op = wgs84_operation(*set, why);
  if (!op) return unsupported(d.name + ": " + why);
  const PJ_COORD in = proj_coord(p.x, p.y, 0.0, HUGE_VAL);
  // The differences in degrees (geographic) or metres (projected).
  const auto same_place = [&](const PJ_COORD& back) {
    const double dx =
        d.geographic ? std::remainder((back.xy.x - p.x) * d.unit_size, 360.0) : (back.xy.x - p.x) * d.unit_size;
    const double dy = (back.xy.y - p.y) * d.unit_size;
    const double tolerance = d.geographic ? kRoundTripDegrees : kRoundTripMetres;
    return finite(back) && std::abs(dx) <= tolerance && std::abs(dy) <= tolerance;
  };
  proj_errno_reset(op);
  const PJ_COORD ll = proj_trans(op, PJ_FWD, in);
  if (!finite(ll) || std::abs(ll.lp.phi) > 90.0)
    return out_of_range(d.name,
                        "position (" + format_xy(p) + ") has no geographic equivalent" + proj_reason(op, set->context));
  if (!converts_back(op, PJ_FWD, in, ll, same_place))
    return out_of_range(d.name, "position (" + format_xy(p) +
                                    ") is outside the projection's domain (it does not convert back to itself)");
  return LonLat{GeographicLib::Math::AngNormalize(ll.lp.lam), ll.lp.phi};
}

GroundScale Crs::ground_scale(XY p) const {
  const CrsData& d = *data_;
  if (d.geographic) {
    // Lengths of one unit along a parallel (radius N cos(lat)) and along a
    // meridian (radius of curvature M) at this latitude.
    const double lat = std::isfinite(p.y) ? std::clamp(p.y * d.unit_size, -90.0, 90.0) : 0.0;
    const double per_radian = d.unit_size * kDegree;
    return GroundScale{d.ellipsoid->CircleRadius(lat) * per_radian,
                       d.ellipsoid->MeridionalCurvatureRadius(lat) * per_radian};
  }
  const GroundScale nominal{d.unit_size, d.unit_size};
  if (!std::isfinite(p.x) || !std::isfinite(p.y)) return nominal;
  if (d.builtin && d.builtin->kind == detail::BuiltinKind::kWebMercator) {
    if (auto ll = detail::web_mercator_to_lonlat(p)) return ll->scale;
  } else if (d.builtin) {  // transverse Mercator is conformal: one scale k both ways
    if (auto ll = detail::tm_to_lonlat(*d.builtin, p)) return GroundScale{1.0 / ll->k, 1.0 / ll->k};
  }
  Lease lease(d);
  ProjSet* set = lease.get();
  if (!set) return nominal;
  PJ* op = set->projection.get();
  proj_errno_reset(op);
  const PJ_COORD lp = proj_trans(op, PJ_INV, proj_coord(p.x * d.unit_size, p.y * d.unit_size, 0.0, HUGE_VAL));
  if (!finite(lp)) {
    proj_errno_reset(op);
    return nominal;
  }
  const PJ_FACTORS f = proj_factors(op, lp);
  const bool failed = proj_errno(op) != 0;
  proj_errno_reset(op);
  // Derivatives of (x, y) / a; a pipeline's come in metres.
  const double scale = set->projection_is_pipeline ? 1.0 / d.a : 1.0;
  const double xl = f.dx_dlam * scale, xp = f.dx_dphi * scale, yl = f.dy_dlam * scale, yp = f.dy_dphi * scale;
  const double det = xl * yp - xp * yl;
  const double phi = lp.lp.phi, s = std::sin(phi), w = 1.0 - d.e2 * s * s;
  const double n_cos = std::cos(phi) / std::sqrt(w), m = (1.0 - d.e2) / (w * std::sqrt(w));
  if (failed || !std::isfinite(det) || std::abs(det) < 1e-12) {
    // No Jacobian (a pole of an azimuthal projection): the point scale, if any.
    const double k = std::sqrt(f.meridional_scale * f.parallel_scale);
    return !failed && std::isfinite(k) && k > 0 ? GroundScale{d.unit_size / k, d.unit_size / k} : nominal;
  }
  const double per_x = std::hypot(n_cos * yp / det, m * -yl / det);
  const double per_y = std::hypot(n_cos * -xp / det, m * xl / det);
  if (!std::isfinite(per_x) || !std::isfinite(per_y) || !(per_x > 0) || !(per_y > 0)) return nominal;
  return GroundScale{per_x * d.unit_size, per_y * d.unit_size};
}

bool Crs::equivalent_to(const Crs& other) const {
  if (data_ == other.data_ || data_->definition == other.data_->definition) return true;
  ProjContext& context = detail::thread_context();
  PjPtr a(proj_create(context.get(), data_->definition.c_str()));
  PjPtr b(proj_create(context.get(), other.data_->definition.c_str()));
  const bool same = a && b &&
                    proj_is_equivalent_to_with_ctx(context.get(), a.get(), b.get(),
                                                   PJ_COMP_EQUIVALENT_EXCEPT_AXIS_ORDER_GEOGCRS) != 0;
  context.take_error();
  return same;
}

std::optional<LonLatBounds> lonlat_bounds(const Crs& crs, double x_min, double y_min, double x_max, double y_max) {
  const double xm = (x_min + x_max) / 2, ym = (y_min + y_max) / 2;
  const XY points[] = {{x_min, y_min}, {x_max, y_min}, {x_min, y_max}, {x_max, y_max},
                       {xm, y_min},    {xm, y_max},    {x_min, ym},    {x_max, ym}};
  std::optional<LonLatBounds> b;
  for (const XY& p : points) {
    auto ll = crs.to_lonlat(p);
    if (!ll.ok()) return std::nullopt;
    if (!b) b = LonLatBounds{ll->lon, ll->lat, ll->lon, ll->lat};
    b->west = std::min(b->west, ll->lon);
    b->east = std::max(b->east, ll->lon);
    b->south = std::min(b->south, ll->lat);
    b->north = std::max(b->north, ll->lat);
  }
  return b;
}

}  // namespace horizon::geodesy
