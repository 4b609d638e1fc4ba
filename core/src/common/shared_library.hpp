// shared_library.hpp — a shared library opened with dlopen, its functions
// looked up by name.
//
// For the libraries core calls without linking them (PROJ in
// geodesy/proj_runtime.cpp, libgeotiff in terrain/geotiff_runtime.cpp):
// opened with RTLD_NOW | RTLD_LOCAL and never closed, since objects it made
// may live until the process exits. error() says why it cannot be used: it
// did not open ("PROJ cannot be loaded (libproj.so.25: cannot open shared
// object file ...)"), or it lacks a function asked for ("PROJ
// (libproj.so.25) lacks proj_foo").
#pragma once

#include <dlfcn.h>

#include <string>
#include <type_traits>

namespace horizon::detail {

class SharedLibrary {
 public:
  // Opens `soname`; `label` names it in error().
  SharedLibrary(const char* soname, const char* label) : soname_(soname), label_(label) {
    handle_ = ::dlopen(soname, RTLD_NOW | RTLD_LOCAL);
    if (!handle_) {
      const char* why = ::dlerror();
      error_ = label_ + " cannot be loaded (" + std::string(why ? why : soname) + ")";
    }
  }

  // The function `name` as F; null when the library did not open or lacks
  // it (then named in error()).
  template <class F>
  F function(const char* name) {
    if (!handle_) return nullptr;
    void* symbol = ::dlsym(handle_, name);
    if (!symbol) {
      missing_ += (missing_.empty() ? "" : ", ") + std::string(name);
      error_ = label_ + " (" + soname_ + ") lacks " + missing_;
    }
    return reinterpret_cast<F>(symbol);
  }

  bool ok() const { return error_.empty(); }
  const std::string& error() const { return error_; }

 private:
  std::string soname_, label_;
  void* handle_ = nullptr;
  std::string missing_, error_;
};

// What a forwarder returns when its library cannot be used: a null
// pointer, 0, the zero enumerator; nothing for void.
template <class T>
T zero_value() {
  if constexpr (!std::is_void_v<T>) return T{};
}

}  // namespace horizon::detail
