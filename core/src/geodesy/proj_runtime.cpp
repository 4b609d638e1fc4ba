// proj_runtime.cpp — PROJ, opened when a PROJ function is first called.
//
// Horizon does not link libproj. libproj pulls SQLite and libcurl with its
// TLS and Kerberos stack into every process that links it (28 shared
// libraries, about 4 ms of each process's start), while most runs never call
// PROJ: the CRSs of most DEMs are built in (builtin_crs.hpp).
// So this file defines each PROJ function Horizon calls, with proj.h's own
// signature, as a forwarder to the same function in the library opened with
// dlopen on the first call: HORIZON_PROJ_SONAME, the soname of the libproj
// found at configure time. proj.h declares every one of them, so the
// compiler holds each forwarder to PROJ's signature.
//
// Should the library fail to open, or lack a function, every forwarder
// returns its type's zero (a null PJ or context, 0, PJ_TYPE_UNKNOWN): the
// values by which PROJ itself reports failure, so callers take their usual
// error paths, and ProjContext::take_error() names the reason
// (proj_runtime_error()).
//
// A function not in the list below is reported by the linker as undefined:
// add it here.
#include <proj.h>
#include <proj_experimental.h>

#include <string>

#include "common/shared_library.hpp"
#include "proj_support.hpp"

#ifndef HORIZON_PROJ_SONAME
#error "HORIZON_PROJ_SONAME must name the libproj to open (core/CMakeLists.txt sets it)"
#endif

// X(return type, name, (parameters), (arguments)) for each PROJ function Horizon calls.
#define HORIZON_PROJ_FUNCTIONS(X)                                                                                      \
  X(PJ*, proj_alter_name, (PJ_CONTEXT * ctx, const PJ* obj, const char* name), (ctx, obj, name))                       \
  X(const char*, proj_as_proj_string,                                                                                  \
    (PJ_CONTEXT * ctx, const PJ* obj, PJ_PROJ_STRING_TYPE type, const char* const* options),                           \
    (ctx, obj, type, options))                                                                                         \
  X(const char*, proj_as_wkt, (PJ_CONTEXT * ctx, const PJ* obj, PJ_WKT_TYPE type, const char* const* options),         \
    (ctx, obj, type, options))                                                                                         \
  X(PJ*, proj_clone, (PJ_CONTEXT * ctx, const PJ* obj), (ctx, obj))                                                    \
  X(PJ_CONTEXT*, proj_context_create, (), ())                                                                          \
  X(PJ_CONTEXT*, proj_context_destroy, (PJ_CONTEXT * ctx), (ctx))                                                      \
  X(const char*, proj_context_errno_string, (PJ_CONTEXT * ctx, int err), (ctx, err))                                   \
  X(PJ_COORD, proj_coord, (double x, double y, double z, double t), (x, y, z, t))                                      \
  X(int, proj_coordoperation_get_method_info,                                                                          \
    (PJ_CONTEXT * ctx, const PJ* coordoperation, const char** out_method_name, const char** out_method_auth_name,      \
     const char** out_method_code),                                                                                    \
    (ctx, coordoperation, out_method_name, out_method_auth_name, out_method_code))                                     \
  X(int, proj_coordoperation_get_param,                                                                                \
    (PJ_CONTEXT * ctx, const PJ* coordoperation, int index, const char** out_name, const char** out_auth_name,         \
     const char** out_code, double* out_value, const char** out_value_string, double* out_unit_conv_factor,            \
     const char** out_unit_name, const char** out_unit_auth_name, const char** out_unit_code,                          \
     const char** out_unit_category),                                                                                  \
    (ctx, coordoperation, index, out_name, out_auth_name, out_code, out_value, out_value_string, out_unit_conv_factor, \
     out_unit_name, out_unit_auth_name, out_unit_code, out_unit_category))                                             \
  X(int, proj_coordoperation_get_param_count, (PJ_CONTEXT * ctx, const PJ* coordoperation), (ctx, coordoperation))     \
  X(int, proj_coordoperation_get_towgs84_values,                                                                       \
    (PJ_CONTEXT * ctx, const PJ* coordoperation, double* out_values, int value_count, int emit_error_if_incompatible), \
    (ctx, coordoperation, out_values, value_count, emit_error_if_incompatible))                                        \
  X(PJ*, proj_create, (PJ_CONTEXT * ctx, const char* definition), (ctx, definition))                                   \
  X(PJ*, proj_create_compound_crs, (PJ_CONTEXT * ctx, const char* crs_name, PJ* horiz_crs, PJ* vert_crs),              \
    (ctx, crs_name, horiz_crs, vert_crs))                                                                              \
  X(PJ*, proj_create_crs_to_crs_from_pj,                                                                               \
    (PJ_CONTEXT * ctx, const PJ* source_crs, const PJ* target_crs, PJ_AREA* area, const char* const* options),         \
    (ctx, source_crs, target_crs, area, options))                                                                      \
  X(PJ*, proj_create_ellipsoidal_2D_cs,                                                                                \
    (PJ_CONTEXT * ctx, PJ_ELLIPSOIDAL_CS_2D_TYPE type, const char* unit_name, double unit_conv_factor),                \
    (ctx, type, unit_name, unit_conv_factor))                                                                          \
  X(PJ*, proj_create_from_database,                                                                                    \
    (PJ_CONTEXT * ctx, const char* auth_name, const char* code, PJ_CATEGORY category, int usePROJAlternativeGridNames, \
     const char* const* options),                                                                                      \
    (ctx, auth_name, code, category, usePROJAlternativeGridNames, options))                                            \
  X(PJ*, proj_create_geographic_crs,                                                                                   \
    (PJ_CONTEXT * ctx, const char* crs_name, const char* datum_name, const char* ellps_name, double semi_major_metre,  \
     double inv_flattening, const char* prime_meridian_name, double prime_meridian_offset,                             \
     const char* pm_angular_units, double pm_units_conv, PJ* ellipsoidal_cs),                                          \
    (ctx, crs_name, datum_name, ellps_name, semi_major_metre, inv_flattening, prime_meridian_name,                     \
     prime_meridian_offset, pm_angular_units, pm_units_conv, ellipsoidal_cs))                                          \
  X(PJ*, proj_create_geographic_crs_from_datum,                                                                        \
    (PJ_CONTEXT * ctx, const char* crs_name, PJ* datum_or_datum_ensemble, PJ* ellipsoidal_cs),                         \
    (ctx, crs_name, datum_or_datum_ensemble, ellipsoidal_cs))                                                          \
  X(PJ*, proj_crs_alter_cs_angular_unit,                                                                               \
    (PJ_CONTEXT * ctx, const PJ* obj, const char* angular_units, double angular_units_conv,                            \
     const char* unit_auth_name, const char* unit_code),                                                               \
    (ctx, obj, angular_units, angular_units_conv, unit_auth_name, unit_code))                                          \
  X(PJ*, proj_crs_alter_cs_linear_unit,                                                                                \
    (PJ_CONTEXT * ctx, const PJ* obj, const char* linear_units, double linear_units_conv, const char* unit_auth_name,  \
     const char* unit_code),                                                                                           \
    (ctx, obj, linear_units, linear_units_conv, unit_auth_name, unit_code))                                            \
  X(PJ*, proj_crs_alter_geodetic_crs, (PJ_CONTEXT * ctx, const PJ* obj, const PJ* new_geod_crs),                       \
    (ctx, obj, new_geod_crs))                                                                                          \
  X(PJ*, proj_crs_create_bound_crs,                                                                                    \
    (PJ_CONTEXT * ctx, const PJ* base_crs, const PJ* hub_crs, const PJ* transformation),                               \
    (ctx, base_crs, hub_crs, transformation))                                                                          \
  X(PJ*, proj_crs_demote_to_2D, (PJ_CONTEXT * ctx, const char* crs_2D_name, const PJ* crs_3D),                         \
    (ctx, crs_2D_name, crs_3D))                                                                                        \
  X(PJ*, proj_crs_get_coordinate_system, (PJ_CONTEXT * ctx, const PJ* crs), (ctx, crs))                                \
  X(PJ*, proj_crs_get_coordoperation, (PJ_CONTEXT * ctx, const PJ* crs), (ctx, crs))                                   \
  X(PJ*, proj_crs_get_datum_forced, (PJ_CONTEXT * ctx, const PJ* crs), (ctx, crs))                                     \
  X(PJ*, proj_crs_get_geodetic_crs, (PJ_CONTEXT * ctx, const PJ* crs), (ctx, crs))                                     \
  X(PJ*, proj_crs_get_sub_crs, (PJ_CONTEXT * ctx, const PJ* crs, int index), (ctx, crs, index))                        \
  X(int, proj_cs_get_axis_count, (PJ_CONTEXT * ctx, const PJ* cs), (ctx, cs))                                          \
  X(int, proj_cs_get_axis_info,                                                                                        \
    (PJ_CONTEXT * ctx, const PJ* cs, int index, const char** out_name, const char** out_abbrev,                        \
     const char** out_direction, double* out_unit_conv_factor, const char** out_unit_name,                             \
     const char** out_unit_auth_name, const char** out_unit_code),                                                     \
    (ctx, cs, index, out_name, out_abbrev, out_direction, out_unit_conv_factor, out_unit_name, out_unit_auth_name,     \
     out_unit_code))                                                                                                   \
  X(PJ*, proj_destroy, (PJ * P), (P))                                                                                  \
  X(int, proj_ellipsoid_get_parameters,                                                                                \
    (PJ_CONTEXT * ctx, const PJ* ellipsoid, double* out_semi_major_metre, double* out_semi_minor_metre,                \
     int* out_is_semi_minor_computed, double* out_inv_flattening),                                                     \
    (ctx, ellipsoid, out_semi_major_metre, out_semi_minor_metre, out_is_semi_minor_computed, out_inv_flattening))      \
  X(int, proj_errno, (const PJ* P), (P))                                                                               \
  X(int, proj_errno_reset, (const PJ* P), (P))                                                                         \
  X(PJ_FACTORS, proj_factors, (PJ * P, PJ_COORD lp), (P, lp))                                                          \
  X(const char*, proj_get_celestial_body_name, (PJ_CONTEXT * ctx, const PJ* obj), (ctx, obj))                          \
  X(PJ*, proj_get_ellipsoid, (PJ_CONTEXT * ctx, const PJ* obj), (ctx, obj))                                            \
  X(const char*, proj_get_id_auth_name, (const PJ* obj, int index), (obj, index))                                      \
  X(const char*, proj_get_id_code, (const PJ* obj, int index), (obj, index))                                           \
  X(const char*, proj_get_name, (const PJ* obj), (obj))                                                                \
  X(PJ*, proj_get_prime_meridian, (PJ_CONTEXT * ctx, const PJ* obj), (ctx, obj))                                       \
  X(PJ*, proj_get_source_crs, (PJ_CONTEXT * ctx, const PJ* obj), (ctx, obj))                                           \
  X(PJ*, proj_get_target_crs, (PJ_CONTEXT * ctx, const PJ* obj), (ctx, obj))                                           \
  X(PJ_TYPE, proj_get_type, (const PJ* obj), (obj))                                                                    \
  X(int, proj_is_crs, (const PJ* obj), (obj))                                                                          \
  X(int, proj_is_equivalent_to_with_ctx,                                                                               \
    (PJ_CONTEXT * ctx, const PJ* obj, const PJ* other, PJ_COMPARISON_CRITERION criterion),                             \
    (ctx, obj, other, criterion))                                                                                      \
  X(void, proj_log_func, (PJ_CONTEXT * ctx, void* app_data, PJ_LOG_FUNCTION logf), (ctx, app_data, logf))              \
  X(PJ*, proj_normalize_for_visualization, (PJ_CONTEXT * ctx, const PJ* obj), (ctx, obj))                              \
  X(int, proj_prime_meridian_get_parameters,                                                                           \
    (PJ_CONTEXT * ctx, const PJ* prime_meridian, double* out_longitude, double* out_unit_conv_factor,                  \
     const char** out_unit_name),                                                                                      \
    (ctx, prime_meridian, out_longitude, out_unit_conv_factor, out_unit_name))                                         \
  X(PJ_COORD, proj_trans, (PJ * P, PJ_DIRECTION direction, PJ_COORD coord), (P, direction, coord))                     \
  X(PJ*, proj_trans_get_last_used_operation, (PJ * P), (P))                                                            \
  X(int, proj_uom_get_info_from_database,                                                                              \
    (PJ_CONTEXT * ctx, const char* auth_name, const char* code, const char** out_name, double* out_conv_factor,        \
     const char** out_category),                                                                                       \
    (ctx, auth_name, code, out_name, out_conv_factor, out_category))

namespace horizon::geodesy::detail {
namespace {

struct ProjLibrary {
  std::string error;  // why PROJ cannot be used; empty when it can
#define HORIZON_PROJ_POINTER(ret, name, params, args) decltype(&::name) name = nullptr;
  HORIZON_PROJ_FUNCTIONS(HORIZON_PROJ_POINTER)
#undef HORIZON_PROJ_POINTER
};

ProjLibrary open_library() {
  ProjLibrary lib;
  horizon::detail::SharedLibrary so(HORIZON_PROJ_SONAME, "PROJ");
#define HORIZON_PROJ_RESOLVE(ret, name, params, args) lib.name = so.function<decltype(lib.name)>(#name);
  HORIZON_PROJ_FUNCTIONS(HORIZON_PROJ_RESOLVE)
#undef HORIZON_PROJ_RESOLVE
  if (!so.ok()) {
    ProjLibrary none;
    none.error = so.error();
    return none;
  }
  return lib;
}

const ProjLibrary& library() {
  static const ProjLibrary lib = open_library();
  return lib;
}

}  // namespace

std::string proj_runtime_error() {
  return library().error;
}

}  // namespace horizon::geodesy::detail

#define HORIZON_PROJ_FORWARD(ret, name, params, args)                     \
  extern "C" ret name params {                                            \
    const auto& lib = horizon::geodesy::detail::library();                \
    return lib.name ? lib.name args : horizon::detail::zero_value<ret>(); \
  }
HORIZON_PROJ_FUNCTIONS(HORIZON_PROJ_FORWARD)
#undef HORIZON_PROJ_FORWARD
