// geotiff_runtime.hpp — libgeotiff, opened with dlopen when first called.
//
// Horizon does not link libgeotiff (it links PROJ, whose dependencies cost
// every process's start); geotiff_runtime.cpp defines the libgeotiff
// functions Horizon calls as forwarders to the library opened on first use.
// Include libgeotiff's headers as usual and call its functions; should the
// library be missing, they return their failure values and this says why.
#pragma once

#include <string>

namespace horizon::terrain::detail {

// Why libgeotiff cannot be used ("libgeotiff cannot be loaded (...)"); empty when it can.
std::string geotiff_runtime_error();

}  // namespace horizon::terrain::detail
