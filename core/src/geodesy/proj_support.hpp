// proj_support.hpp — private glue between PROJ and Horizon (geodesy and the
// GeoTIFF reader and writer).
//
// * ProjContext: a PJ_CONTEXT whose log messages are kept (the last one, for
//   our error messages) instead of printed on stderr. Its other settings are
//   PROJ's defaults, as gdaltransform's: grids from the installed proj-data,
//   no network unless PROJ_NETWORK=ON says so.
// * thread_context(): this thread's context for one-off work (parsing a
//   definition, reading or writing GeoKeys). PROJ contexts are not
//   thread-safe and a PJ stays bound to the context it was made with, so a
//   PJ made with it must stay on this thread and die before it.
// * PjPtr: RAII owner of a PJ.
// * proj_runtime_error(): why PROJ cannot be used, empty when it can. PROJ
//   is opened with dlopen on its first call (proj_runtime.cpp); should that
//   fail, every PROJ function returns its failure value and take_error()
//   gives this reason.
#pragma once

#include <proj.h>

#include <memory>
#include <string>

namespace horizon::geodesy::detail {

struct PjDestroyer {
  void operator()(PJ* pj) const {
    if (pj) proj_destroy(pj);
  }
};
using PjPtr = std::unique_ptr<PJ, PjDestroyer>;

class ProjContext {
 public:
  ProjContext();
  ~ProjContext();
  ProjContext(const ProjContext&) = delete;
  ProjContext& operator=(const ProjContext&) = delete;

  PJ_CONTEXT* get() const { return ctx_; }
  // What PROJ last logged as an error ("crs not found: EPSG:99999"), with
  // directories cut from any path (without_directories); cleared.
  std::string take_error();

 private:
  static void log(void* self, int level, const char* message);
  PJ_CONTEXT* ctx_ = nullptr;
  std::string last_;
};

ProjContext& thread_context();

std::string proj_runtime_error();

// `text` with every absolute path cut to its file name: PROJ's messages may
// name files under its data directory ("/usr/share/proj/proj.db"), which a
// daemon's error must not show its clients.
std::string without_directories(const std::string& text);

// A definition shortened for messages (WKT can run to kilobytes).
std::string quote_definition(const std::string& definition);

}  // namespace horizon::geodesy::detail
