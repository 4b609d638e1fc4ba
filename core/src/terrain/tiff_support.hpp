// tiff_support.hpp — private glue between libtiff, libgeotiff and Horizon.
//
// * Registers the GeoTIFF tags (ModelPixelScale 33550, the old Intergraph
//   matrix 33920, ModelTiepoint 33922, ModelTransformation 34264,
//   GeoKeyDirectory 34735, GeoDoubleParams 34736, GeoAsciiParams 34737,
//   each as libgeotiff's XTIFF extender registers it, so that libgeotiff
//   reads them from a handle opened here) and GDAL's ASCII GDAL_NODATA tag
//   (42113, see https://gdal.org/drivers/raster/gtiff.html) once per
//   process, for every TIFF handle opened afterwards.
// * Opens files with per-handle error/warning handlers (libtiff >= 4.5
//   TIFFOpenExt), so messages land in the Error we return instead of stderr,
//   and concurrent readers do not share a global handler.
// * Bounds, for readers, every single allocation libtiff makes for a handle
//   (libtiff >= 4.5 TIFFOpenOptionsSetMaxSingleMemAlloc): a codec's whole-
//   strip buffer (PixarLog, LogLuv, LERC, WebP), a predictor's copy, tag
//   arrays. A header may claim any size; this keeps libtiff's share of a
//   read near the reader's own limit (ReadOptions::max_block_bytes) rather
//   than near what the header claims. libjpeg's own allocations and the raw
//   strip bytes are not counted: the reader bounds JPEG strips before
//   decoding, and raw bytes come from the memory-mapped file.
// * RAII owners for TIFF* and GTIF*, so every error path closes them.
#pragma once

#include <geotiffio.h>
#include <tiffio.h>

#include <algorithm>
#include <cstdarg>
#include <cstdint>
#include <cstdio>
#include <limits>
#include <memory>
#include <mutex>
#include <string>

namespace horizon::terrain::detail {

// The GeoTIFF tags (OGC 19-008r4, section 7) and GDAL's nodata tag.
inline constexpr ttag_t kTagModelPixelScale = 33550;
inline constexpr ttag_t kTagIntergraphMatrix = 33920;  // ModelTransformation's old number
inline constexpr ttag_t kTagModelTiepoint = 33922;
inline constexpr ttag_t kTagModelTransformation = 34264;
inline constexpr ttag_t kTagGeoKeyDirectory = 34735;
inline constexpr ttag_t kTagGeoDoubleParams = 34736;
inline constexpr ttag_t kTagGeoAsciiParams = 34737;
inline constexpr ttag_t kTagGdalNodata = 42113;

inline TIFFExtendProc& previous_tag_extender() {
  static TIFFExtendProc previous = nullptr;
  return previous;
}

inline void horizon_tag_extender(TIFF* tif) {
  // {tag, read count, write count, type, bit, ok to change, pass count, name}:
  // -1 counts (TIFF_VARIABLE) pass a uint16 count, as libgeotiff expects.
  static const TIFFFieldInfo kFields[] = {
      {kTagModelPixelScale, -1, -1, TIFF_DOUBLE, FIELD_CUSTOM, 1, 1, const_cast<char*>("GeoPixelScale")},
      {kTagIntergraphMatrix, -1, -1, TIFF_DOUBLE, FIELD_CUSTOM, 1, 1,
       const_cast<char*>("Intergraph TransformationMatrix")},
      {kTagModelTransformation, -1, -1, TIFF_DOUBLE, FIELD_CUSTOM, 1, 1, const_cast<char*>("GeoTransformationMatrix")},
      {kTagModelTiepoint, -1, -1, TIFF_DOUBLE, FIELD_CUSTOM, 1, 1, const_cast<char*>("GeoTiePoints")},
      {kTagGeoKeyDirectory, -1, -1, TIFF_SHORT, FIELD_CUSTOM, 1, 1, const_cast<char*>("GeoKeyDirectory")},
      {kTagGeoDoubleParams, -1, -1, TIFF_DOUBLE, FIELD_CUSTOM, 1, 1, const_cast<char*>("GeoDoubleParams")},
      {kTagGeoAsciiParams, -1, -1, TIFF_ASCII, FIELD_CUSTOM, 1, 0, const_cast<char*>("GeoASCIIParams")},
      {kTagGdalNodata, -1, -1, TIFF_ASCII, FIELD_CUSTOM, 1, 0, const_cast<char*>("GDAL_NODATA")},
  };
  TIFFMergeFieldInfo(tif, kFields, sizeof kFields / sizeof kFields[0]);
  if (TIFFExtendProc previous = previous_tag_extender()) previous(tif);
}

// Idempotent and thread-safe; call before opening any TIFF.
inline void register_tiff_tags() {
  static std::once_flag once;
  std::call_once(once, [] { previous_tag_extender() = TIFFSetTagExtender(horizon_tag_extender); });
}

struct TiffCloser {
  void operator()(TIFF* tif) const {
    if (tif) TIFFClose(tif);
  }
};
using TiffPtr = std::unique_ptr<TIFF, TiffCloser>;

struct GtifFreer {
  void operator()(GTIF* gtif) const {
    if (gtif) GTIFFree(gtif);
  }
};
using GtifPtr = std::unique_ptr<GTIF, GtifFreer>;

// Collects libtiff's messages for one handle. Must outlive the handle, as
// libtiff keeps a pointer to it; the unique_ptr order in callers ensures that.
struct TiffMessages {
  std::string errors;
  std::string warnings;

  static int append(std::string& into, const char* module, const char* fmt, va_list ap) {
    char buf[512];
    std::vsnprintf(buf, sizeof buf, fmt, ap);
    if (!into.empty()) into += "; ";
    if (module && *module) {
      into += module;
      into += ": ";
    }
    into += buf;
    return 1;  // handled: do not call the global stderr handler
  }
  static int on_error(TIFF*, void* self, const char* module, const char* fmt, va_list ap) {
    return append(static_cast<TiffMessages*>(self)->errors, module, fmt, ap);
  }
  static int on_warning(TIFF*, void* self, const char* module, const char* fmt, va_list ap) {
    return append(static_cast<TiffMessages*>(self)->warnings, module, fmt, ap);
  }
};

// Opens `path` with libtiff mode `mode` ("r", "w", "w8"), GeoTIFF and GDAL
// tags registered, messages routed to `messages`. `max_single_alloc` bytes
// (0: no limit) bound each allocation libtiff makes for the handle; one
// beyond it fails the call that needed it with a libtiff error ("Memory
// allocation of N bytes is beyond the M byte limit defined in open
// options"). Null on failure.
inline TiffPtr open_tiff(const std::string& path, const char* mode, TiffMessages& messages,
                         std::uint64_t max_single_alloc = 0) {
  register_tiff_tags();
  TIFFOpenOptions* opts = TIFFOpenOptionsAlloc();
  if (!opts) return nullptr;
  if (max_single_alloc > 0)
    TIFFOpenOptionsSetMaxSingleMemAlloc(
        opts, static_cast<tmsize_t>(std::min<std::uint64_t>(max_single_alloc, std::numeric_limits<tmsize_t>::max())));
  TIFFOpenOptionsSetErrorHandlerExtR(opts, &TiffMessages::on_error, &messages);
  TIFFOpenOptionsSetWarningHandlerExtR(opts, &TiffMessages::on_warning, &messages);
  TiffPtr tif(TIFFOpenExt(path.c_str(), mode, opts));
  TIFFOpenOptionsFree(opts);
  return tif;
}

}  // namespace horizon::terrain::detail
