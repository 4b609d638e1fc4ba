// horizon/terrain/qgis_style.hpp — QGIS layer styles (.qml) for the rasters
// Horizon writes, so that a result opens in QGIS already drawn: QGIS loads
// "OUT.qml" as the default style of a layer read from "OUT.tif".
//
// Two renderers of QGIS's raster style format (QGIS 3.x, the
// <qgis><pipe><rasterrenderer> document its "Save Style..." writes):
//   - paletted: each listed value of band 1 in its colour with its label
//     (unique values: a visibility mask's 1/0, a region's 1/0/2); values not
//     listed, and the band's nodata, are not drawn;
//   - single-band pseudocolour: a colour-ramp shader, interpolated between
//     its items, or discrete (each item colours the values up to it).
// Nodata stays the GeoTIFF's own (GDAL_NODATA): QGIS draws it transparent.
#pragma once

#include <array>
#include <cstdint>
#include <future>
#include <memory>
#include <span>
#include <string>

#include "horizon/common/error.hpp"

namespace horizon::terrain {

struct StyleEntry {
  double value = 0.0;
  std::array<std::uint8_t, 3> colour{};
  std::string label;
};

// The paletted style's document.
std::string qml_paletted(std::span<const StyleEntry> entries);

// The pseudocolour style's document: `entries` in increasing value;
// `discrete`: an entry colours the values up to and including its own
// (above the previous one's), otherwise colours are interpolated between
// entries and values beyond the ends take the ends' colours.
std::string qml_pseudocolor(std::span<const StyleEntry> entries, bool discrete, int label_precision);

// "dir/out.tif" -> "dir/out.qml" (the style QGIS loads with the raster).
std::string qml_path_for(const std::string& raster_path);

// Writes `text` at `path` atomically (temporary name + rename); errors name the path.
Status write_text_file(const std::string& path, const std::string& text);

namespace detail {
class AtomicFile;
}

// write_text_file in two steps: stage() writes `text` under a temporary
// name beside `path` and flushes it to disk; commit() renames it over
// `path`. A staged file never committed is removed, and `path` is left as
// it was. So a raster's style can be written while the raster is encoded
// (the two flushes overlap) and put in place only once the raster is.
class StagedTextFile {
 public:
  static Result<StagedTextFile> stage(const std::string& path, const std::string& text);
  StagedTextFile(StagedTextFile&&) noexcept;
  StagedTextFile& operator=(StagedTextFile&&) noexcept;
  ~StagedTextFile();
  Status commit();

 private:
  StagedTextFile();
  std::unique_ptr<detail::AtomicFile> file_;
};

// A raster written by `write_raster` (a callable returning Status) and its
// QGIS style `style` beside it (qml_path_for(raster_path)): the style is
// staged on a thread of its own while the raster is written (the two
// flushes to disk overlap) and renamed into place only once the raster is.
// If the raster fails, its error is returned and an existing style stays.
template <class WriteRaster>
Status write_with_style(const std::string& raster_path, const std::string& style, WriteRaster&& write_raster) {
  auto staged = std::async(std::launch::async, [&] { return StagedTextFile::stage(qml_path_for(raster_path), style); });
  const Status raster = write_raster();
  auto style_file = staged.get();
  HORIZON_RETURN_IF_ERROR(raster);
  if (!style_file.ok()) return style_file.error();
  return style_file->commit();
}

}  // namespace horizon::terrain
