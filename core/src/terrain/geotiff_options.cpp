// GeoTIFF creation options from GDAL-style NAME=VALUE items (geotiff_options.hpp).
#include "horizon/terrain/geotiff_options.hpp"

#include <tiffio.h>

#include <algorithm>
#include <cctype>
#include <charconv>
#include <utility>
#include <vector>

namespace horizon::terrain {
namespace {

constexpr const char* kField = "creation_options";

std::string upper(std::string_view s) {
  std::string out(s);
  std::transform(out.begin(), out.end(), out.begin(), [](unsigned char c) { return static_cast<char>(std::toupper(c)); });
  return out;
}

Error bad(const std::string& item, const std::string& what, ErrorCode code = ErrorCode::kInvalidArgument) {
  return make_error(code, item + ": " + what, kField);
}

std::optional<int> whole_number(std::string_view text) {
  int v = 0;
  const auto [ptr, ec] = std::from_chars(text.data(), text.data() + text.size(), v);
  if (text.empty() || ec != std::errc() || ptr != text.data() + text.size()) return std::nullopt;
  return v;
}

std::optional<bool> yes_no(const std::string& v) {
  if (v == "YES" || v == "TRUE" || v == "ON" || v == "1") return true;
  if (v == "NO" || v == "FALSE" || v == "OFF" || v == "0") return false;
  return std::nullopt;
}

struct Codec {
  const char* name;
  TiffCompression compression;
  int tiff_code;
};
constexpr Codec kCodecs[] = {
    {"DEFLATE", TiffCompression::kDeflate, COMPRESSION_ADOBE_DEFLATE},
    {"LZW", TiffCompression::kLzw, COMPRESSION_LZW},
    {"ZSTD", TiffCompression::kZstd, COMPRESSION_ZSTD},
    {"LZMA", TiffCompression::kLzma, COMPRESSION_LZMA},
    {"PACKBITS", TiffCompression::kPackBits, COMPRESSION_PACKBITS},
    {"NONE", TiffCompression::kNone, COMPRESSION_NONE},
};

// The options each format takes, as GDAL's drivers name them.
const std::vector<std::string_view>& names_of(TiffFormat format) {
  static const std::vector<std::string_view> gtiff = {"COMPRESS", "PREDICTOR",  "ZLEVEL",     "ZSTD_LEVEL", "LZMA_PRESET",
                                                      "TILED",    "BLOCKXSIZE", "BLOCKYSIZE", "BIGTIFF"};
  static const std::vector<std::string_view> cog = {"COMPRESS",  "PREDICTOR", "LEVEL",
                                                    "BLOCKSIZE", "BIGTIFF",   "OVERVIEWS",
                                                    "OVERVIEW_RESAMPLING", "RESAMPLING"};
  return format == TiffFormat::kCog ? cog : gtiff;
}

std::string list(const std::vector<std::string_view>& names) {
  std::string out;
  for (std::string_view n : names) {
    if (!out.empty()) out += ", ";
    out += n;
  }
  return out;
}

// A level option's value in [lo, hi].
Result<int> level_in(const std::string& item, const std::string& value, int lo, int hi) {
  const auto v = whole_number(value);
  if (!v || *v < lo || *v > hi)
    return bad(item, "expected a whole number from " + std::to_string(lo) + " to " + std::to_string(hi));
  return *v;
}

}  // namespace

bool GeoTiffOptions::is_default() const {
  return format == TiffFormat::kGTiff && compression == TiffCompression::kDeflate && !level &&
         predictor == TiffPredictor::kDefault && tiled && block_width == 256 &&
         (block_height == 0 || block_height == 256) && bigtiff == BigTiff::kIfNeeded && !overviews;
}

std::optional<TiffFormat> parse_tiff_format(std::string_view name) {
  const std::string n = upper(name);
  if (n == "GTIFF") return TiffFormat::kGTiff;
  if (n == "COG") return TiffFormat::kCog;
  return std::nullopt;
}

std::string_view tiff_format_name(TiffFormat format) {
  return format == TiffFormat::kCog ? "COG" : "GTiff";
}

Result<GeoTiffOptions> parse_creation_options(TiffFormat format, std::span<const std::string> items) {
  GeoTiffOptions o;
  o.format = format;
  const bool cog = format == TiffFormat::kCog;
  if (cog) {
    o.block_width = 512;  // GDAL's COG driver's default
    o.overviews = true;
  }
  std::optional<int> level;  // checked against the codec once all items are read
  std::string level_item;
  std::vector<std::string> seen;
  for (const std::string& item : items) {
    const auto eq = item.find('=');
    if (eq == std::string::npos || eq == 0)
      return bad("'" + item + "'", "expected NAME=VALUE (e.g. COMPRESS=ZSTD)");
    const std::string name = upper(std::string_view(item).substr(0, eq));
    const std::string value = upper(std::string_view(item).substr(eq + 1));
    const auto& names = names_of(format);
    if (std::find(names.begin(), names.end(), name) == names.end()) {
      const auto& other = names_of(cog ? TiffFormat::kGTiff : TiffFormat::kCog);
      const bool elsewhere = std::find(other.begin(), other.end(), name) != other.end();
      return bad(item, elsewhere ? std::string("an option of the ") + (cog ? "GTiff" : "COG") + " format, not of " +
                                       std::string(tiff_format_name(format)) + " (" + list(names) + ")"
                                 : "unknown creation option; " + std::string(tiff_format_name(format)) + " takes " +
                                       list(names));
    }
    if (std::find(seen.begin(), seen.end(), name) != seen.end()) return bad(item, name + " is given more than once");
    seen.push_back(name);

    if (name == "COMPRESS") {
      const auto codec = std::find_if(std::begin(kCodecs), std::end(kCodecs),
                                      [&](const Codec& c) { return value == c.name; });
      if (codec == std::end(kCodecs))
        return bad(item, "not a lossless codec this writer offers; use DEFLATE, LZW, ZSTD, LZMA, PACKBITS or NONE");
      if (!TIFFIsCODECConfigured(static_cast<std::uint16_t>(codec->tiff_code)))
        return bad(item, "this build's libtiff has no " + value + " codec", ErrorCode::kUnsupported);
      o.compression = codec->compression;
    } else if (name == "PREDICTOR") {
      if (value == "1" || value == "NO" || value == "NONE")
        o.predictor = TiffPredictor::kNone;
      else if (value == "2" || value == "YES" || value == "STANDARD" || value == "HORIZONTAL")
        o.predictor = TiffPredictor::kHorizontal;
      else if (value == "3" || value == "FLOATING_POINT")
        o.predictor = TiffPredictor::kFloatingPoint;
      else
        return bad(item, "expected 1 (none), 2 (horizontal) or 3 (floating point)");
    } else if (name == "ZLEVEL" || name == "ZSTD_LEVEL" || name == "LZMA_PRESET" || name == "LEVEL") {
      const auto v = whole_number(value);
      if (!v) return bad(item, "expected a whole number");
      level = *v;
      level_item = item;
      if (name == "ZLEVEL") {
        auto l = level_in(item, value, 1, 12);
        if (!l.ok()) return l.error();
      } else if (name == "ZSTD_LEVEL") {
        auto l = level_in(item, value, 1, 22);
        if (!l.ok()) return l.error();
      } else if (name == "LZMA_PRESET") {
        auto l = level_in(item, value, 0, 9);
        if (!l.ok()) return l.error();
      }
    } else if (name == "TILED") {
      const auto v = yes_no(value);
      if (!v) return bad(item, "expected YES or NO");
      o.tiled = *v;
    } else if (name == "BLOCKXSIZE" || name == "BLOCKYSIZE" || name == "BLOCKSIZE") {
      const auto v = whole_number(value);
      if (!v || *v < 1 || *v > 32768) return bad(item, "expected a whole number of cells from 1 to 32768");
      if (name == "BLOCKXSIZE" || name == "BLOCKSIZE") o.block_width = *v;
      if (name == "BLOCKYSIZE" || name == "BLOCKSIZE") o.block_height = *v;
    } else if (name == "BIGTIFF") {
      if (value == "IF_NEEDED")
        o.bigtiff = BigTiff::kIfNeeded;
      else if (value == "IF_SAFER")
        o.bigtiff = BigTiff::kIfSafer;
      else if (const auto v = yes_no(value))
        o.bigtiff = *v ? BigTiff::kYes : BigTiff::kNo;
      else
        return bad(item, "expected IF_NEEDED, IF_SAFER, YES or NO");
    } else if (name == "OVERVIEWS") {
      if (value == "AUTO")
        o.overviews = true;
      else if (value == "NONE")
        o.overviews = false;
      else
        return bad(item, "expected AUTO or NONE");
    } else if (name == "OVERVIEW_RESAMPLING" || name == "RESAMPLING") {
      if (value == "NEAREST")
        o.resampling = OverviewResampling::kNearest;
      else if (value == "MODE")
        o.resampling = OverviewResampling::kMode;
      else if (value == "AVERAGE")
        o.resampling = OverviewResampling::kAverage;
      else
        return bad(item, "expected NEAREST, MODE or AVERAGE (the overviews of a visibility raster are classes: "
                         "MODE or NEAREST keep them codes)");
    }
  }
  // Tiles are multiples of 16 cells (TIFF 6.0, section 15).
  if (o.tiled && (o.block_width % 16 != 0 || (o.block_height != 0 && o.block_height % 16 != 0)))
    return bad(cog ? "BLOCKSIZE" : "BLOCKXSIZE/BLOCKYSIZE", "tiles must be multiples of 16 cells, got " +
                                                              std::to_string(o.block_width) + " x " +
                                                              std::to_string(o.block_height ? o.block_height
                                                                                            : o.block_width));
  if (level) {
    // ZLEVEL, ZSTD_LEVEL and LZMA_PRESET belong to one codec each; COG's LEVEL to the codec chosen.
    const std::string name = upper(level_item.substr(0, level_item.find('=')));
    const std::string value = level_item.substr(level_item.find('=') + 1);
    const char* chosen = std::find_if(std::begin(kCodecs), std::end(kCodecs), [&](const Codec& c) {
                           return c.compression == o.compression;
                         })->name;
    struct Range {
      TiffCompression codec;
      const char* option;
      int lo, hi;
    };
    constexpr Range kRanges[] = {{TiffCompression::kDeflate, "ZLEVEL", 1, 12},
                                 {TiffCompression::kZstd, "ZSTD_LEVEL", 1, 22},
                                 {TiffCompression::kLzma, "LZMA_PRESET", 0, 9}};
    const Range* range = nullptr;
    for (const Range& r : kRanges)
      if (r.codec == o.compression) range = &r;
    if (name != "LEVEL") {
      const Range* own = nullptr;
      for (const Range& r : kRanges)
        if (name == r.option) own = &r;
      if (own != range)
        return bad(level_item, std::string("applies to COMPRESS=") +
                                   std::find_if(std::begin(kCodecs), std::end(kCodecs), [&](const Codec& c) {
                                     return c.compression == own->codec;
                                   })->name +
                                   ", not " + chosen);
    }
    if (!range) return bad(level_item, std::string(chosen) + " has no level (DEFLATE, ZSTD and LZMA have)");
    auto checked = level_in(level_item, value, range->lo, range->hi);
    if (!checked.ok()) return checked.error();
    o.level = *checked;
  }
  return o;
}

}  // namespace horizon::terrain
