// geotiff_runtime.cpp — libgeotiff, opened when one of its functions is first called.
//
// Horizon reads and writes GeoKeys itself (geokeys.hpp). libgeotiff is
// needed only to normalise a user-defined CRS's keys (GTIFGetDefn: datum,
// ellipsoid, units and projection parameters resolved through PROJ's
// database), which most files never have; and libgeotiff links PROJ, with
// its SQLite and libcurl chain. So, as for PROJ (geodesy/proj_runtime.cpp),
// this file defines the few libgeotiff functions Horizon calls, with their
// own headers' signatures, as forwarders to the library opened with dlopen
// on the first call: HORIZON_GEOTIFF_SONAME, found at configure time.
//
// Should it fail to open, each forwarder returns its type's zero (a null
// GTIF or GTIFDefn, 0: libgeotiff's own failure values) and
// geotiff_runtime_error() says why.
#include <geo_normalize.h>
#include <geotiffio.h>

#include <string>

#include "common/shared_library.hpp"
#include "geotiff_runtime.hpp"

#ifndef HORIZON_GEOTIFF_SONAME
#error "HORIZON_GEOTIFF_SONAME must name the libgeotiff to open (CMakeLists.txt sets it)"
#endif

// X(return type, name, (parameters), (arguments)) for each libgeotiff function Horizon calls.
#define HORIZON_GEOTIFF_FUNCTIONS(X)                                            \
  X(GTIF*, GTIFNew, (void* tif), (tif))                                         \
  X(void, GTIFFree, (GTIF * gtif), (gtif))                                      \
  X(void, GTIFAttachPROJContext, (GTIF * gtif, void* context), (gtif, context)) \
  X(GTIFDefn*, GTIFAllocDefn, (), ())                                           \
  X(int, GTIFGetDefn, (GTIF * gtif, GTIFDefn * defn), (gtif, defn))             \
  X(void, GTIFFreeDefn, (GTIFDefn * defn), (defn))                              \
  X(const char*, GTIFValueNameEx, (GTIF * gtif, geokey_t key, int value), (gtif, key, value))

namespace horizon::terrain::detail {
namespace {

struct GeotiffLibrary {
  std::string error;  // why libgeotiff cannot be used; empty when it can
#define HORIZON_GEOTIFF_POINTER(ret, name, params, args) decltype(&::name) name = nullptr;
  HORIZON_GEOTIFF_FUNCTIONS(HORIZON_GEOTIFF_POINTER)
#undef HORIZON_GEOTIFF_POINTER
};

GeotiffLibrary open_library() {
  GeotiffLibrary lib;
  horizon::detail::SharedLibrary so(HORIZON_GEOTIFF_SONAME, "libgeotiff");
#define HORIZON_GEOTIFF_RESOLVE(ret, name, params, args) lib.name = so.function<decltype(lib.name)>(#name);
  HORIZON_GEOTIFF_FUNCTIONS(HORIZON_GEOTIFF_RESOLVE)
#undef HORIZON_GEOTIFF_RESOLVE
  if (!so.ok()) {
    GeotiffLibrary none;
    none.error = so.error();
    return none;
  }
  return lib;
}

const GeotiffLibrary& library() {
  static const GeotiffLibrary lib = open_library();
  return lib;
}

}  // namespace

std::string geotiff_runtime_error() {
  return library().error;
}

}  // namespace horizon::terrain::detail

#define HORIZON_GEOTIFF_FORWARD(ret, name, params, args)                  \
  extern "C" ret name params {                                            \
    const auto& lib = horizon::terrain::detail::library();                \
    return lib.name ? lib.name args : horizon::detail::zero_value<ret>(); \
  }
HORIZON_GEOTIFF_FUNCTIONS(HORIZON_GEOTIFF_FORWARD)
#undef HORIZON_GEOTIFF_FORWARD
