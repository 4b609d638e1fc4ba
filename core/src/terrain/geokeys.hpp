// geokeys.hpp — a GeoTIFF's GeoKey directory, read and written by Horizon.
//
// OGC GeoTIFF 1.1 (OGC 19-008r4), section 7.1. GeoKeyDirectoryTag (34735)
// holds SHORTs: a header {KeyDirectoryVersion = 1, KeyRevision,
// MinorRevision, NumberOfKeys}, then one entry {KeyID, TIFFTagLocation,
// Count, ValueOffset} per key. TIFFTagLocation says where the values are:
//   0      ValueOffset is the value (one SHORT);
//   34735  Count SHORTs from index ValueOffset of the directory itself;
//   34736  Count DOUBLEs from index ValueOffset of GeoDoubleParamsTag;
//   34737  Count characters from ValueOffset of GeoAsciiParamsTag, the last
//          one the '|' that ends the string.
//
// Read as libgeotiff 1.7 reads them, so that a file it accepts is accepted:
// an ASCII value whose '|' falls on the string's terminating NUL, or that
// runs past the end, is cut at the end; a later entry for a key replaces an
// earlier one. The one difference: a directory shorter than its header or
// its entries, which libgeotiff reads past, is refused. A directory is
// corrupt (read() fails, naming why) when its
// version is not 1, its entries run past it, a key's values lie outside
// their tag, a value in an entry counts other than 1, or a location is none
// of the four.
//
// Written as libgeotiff writes them: keys in ascending order, one SHORT
// in its entry, several after the entries, DOUBLEs and strings appended to
// their tags in key order, each string ended by '|'.
//
// The GeoTIFF tags must be registered with libtiff before the file is
// opened (tiff_support.hpp's open_tiff does).
#pragma once

#include <tiffio.h>

#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "horizon/common/error.hpp"

namespace horizon::terrain::detail {

class GeoKeys {
 public:
  // The keys of `tif`'s current directory; none when it has no
  // GeoKeyDirectoryTag. A corrupt directory's error says what is wrong
  // ("GeoKey 3072's values lie beyond its end"), for the caller to prefix.
  static Result<GeoKeys> read(TIFF* tif);

  bool empty() const { return keys_.empty(); }

  // A key's value when it holds one of these types, else nullopt.
  std::optional<int> short_value(int key) const;    // the first SHORT
  std::optional<std::string> ascii(int key) const;  // without the ending '|'
  std::optional<std::vector<double>> doubles(int key) const;

  void set_short(int key, int value);
  void set_double(int key, double value) { set_doubles(key, {value}); }
  void set_doubles(int key, std::vector<double> values);
  void set_ascii(int key, std::string text);
  // KeyRevision.MinorRevision: 1.0 unless set (GeoTIFF 1.0); 1.1 is GeoTIFF 1.1.
  void set_revision(int major, int minor);

  // Sets GeoKeyDirectoryTag, and GeoDoubleParamsTag / GeoAsciiParamsTag
  // when a key needs them, on `tif`'s current directory. False when libtiff
  // refuses one (its handler has the message) or the keys do not fit a
  // directory (over 65,535 SHORTs).
  bool write(TIFF* tif) const;

 private:
  enum class Type { kShort, kDouble, kAscii };
  struct Value {
    Type type = Type::kShort;
    std::vector<std::uint16_t> shorts;
    std::vector<double> doubles;
    std::string ascii;
  };
  std::map<int, Value> keys_;
  int revision_ = 1, minor_revision_ = 0;
};

// The values of a TIFF tag registered with a count (TIFF_VARIABLE or
// TIFF_VARIABLE2, as the GeoTIFF tags are); empty when absent.
std::vector<double> tiff_doubles(TIFF* tif, ttag_t tag);

}  // namespace horizon::terrain::detail
