// horizon/visibility/viewshed_preview.hpp — the PNG of a viewshed, as the
// CLI and the daemon draw it (terrain/preview.hpp draws; this says what).
//
// One observer: the visible/hidden raster over the terrain, or, for the OHF
// and the minimum-target-height outputs, that raster as a colour ramp with
// its legend and units; the observer and its reach ringed. Many observers:
// the count as a ramp (or the any/all mask), every site marked. The title
// names the DEM as the reader knows it (a file's name, a dataset's name:
// never a path the reader did not give), the observer in WGS84 (and in the
// DEM's CRS when projected, named by its EPSG code, or by its name when it
// has none), the eye's and the targets' heights, the reach, the field of
// view when it limits what is seen (the legend then says "out of range"),
// and the algorithm, so the same request draws the same picture embedded or
// through the daemon.
#pragma once

#include <cstdint>
#include <limits>
#include <optional>
#include <string>

#include "horizon/common/error.hpp"
#include "horizon/geodesy/crs.hpp"
#include "horizon/terrain/geotiff_writer.hpp"
#include "horizon/terrain/grid.hpp"
#include "horizon/terrain/preview.hpp"
#include "horizon/visibility/many_observers.hpp"
#include "horizon/visibility/viewshed.hpp"
#include "horizon/visibility/viewshed_outputs.hpp"

namespace horizon::visibility {

// The raster a viewshed writes, and so what its preview shows (the boolean
// raster's preview is kVisibility's: its picture tells out of range apart).
enum class PreviewRaster { kVisibility, kOhf, kMinTargetHeight, kVerticalAngle, kElevationDifference };

// The preview of a viewshed output (viewshed_outputs.hpp).
PreviewRaster preview_raster(ViewshedOutput output);

struct PreviewCaption {
  std::string dem;          // the DEM's name for the title (a file's stem, a dataset's name)
  std::string algorithm;    // "fast", "exact", "conservative", "r3"
  std::optional<geodesy::Crs> crs{};                         // the observer's CRS (none: grid coordinates)
  double x = 0.0, y = 0.0;                                   // one observer, in that CRS
  double ground = std::numeric_limits<double>::quiet_NaN();  // metres under the eye
};

// The title lines of a one-observer preview.
std::vector<std::string> viewshed_title(const ViewshedResult& result, PreviewRaster raster,
                                        const PreviewCaption& caption);

// Writes the preview of `result` at `path` (`mask`: visibility_mask of the
// result, used for kVisible).
Status write_viewshed_picture(const std::string& path, const ViewshedResult& result, PreviewRaster raster,
                              const terrain::Grid<std::uint8_t>& mask, const PreviewCaption& caption);

enum class PreviewAccumulation { kCount, kAny, kAll };

// Writes the preview of a many-observer run: `elevation` is the DEM's crop
// to result.window; caption.x/y/ground are unused (each site is marked).
Status write_many_observers_picture(const std::string& path, const ManyObserversPlan& plan,
                                    const ManyObserversResult& result, const terrain::Grid<float>& elevation,
                                    PreviewAccumulation accumulation, const PreviewCaption& caption);

// The QGIS styles (.qml, terrain/qgis_style.hpp) of the rasters written,
// in the previews' colours and words, for "OUT.qml" beside "OUT.tif".
// `min`, `max`: the raster's finite values (kOhf, kVerticalAngle,
// kElevationDifference: the ramp's ends; kMinTargetHeight: its classes
// reach max). kVisibility is the default codes' (visibility_style).
std::string viewshed_style(PreviewRaster raster, double min, double max);
// The visible raster's style in `codes`: visible and hidden, and out of
// range where it has a code of its own (not the nodata, which QGIS leaves
// transparent); with r.viewshed's boolean codes hidden reads "not visible".
std::string visibility_style(const ValueCodes& codes);
// The same with the range taken from the raster written (NaN: no answer).
std::string viewshed_style(PreviewRaster raster, const terrain::Grid<float>& values);
// `max_count`: the greatest count (kCount).
std::string many_observers_style(PreviewAccumulation accumulation, std::uint32_t max_count);
// The region raster's 0 always hidden, 1 always visible, 2 undetermined.
std::string region_style();
// The colour table of every UInt8 code raster (1 visible, 0 hidden, 2
// undetermined, 255 no answer), for terrain::write_geotiff.
terrain::ColourTable code_colour_table();
// The visible raster's in `codes`: where two codes share a value the more
// telling wins (visible over hidden over out of range over no data); the
// default codes give code_colour_table() itself.
terrain::ColourTable code_colour_table(const ValueCodes& codes);

// The stem of a DEM path for PreviewCaption::dem: "data/dem/a.tif" -> "a",
// a folder of tiles by its own name.
std::string dem_label(const std::string& path);

}  // namespace horizon::visibility
