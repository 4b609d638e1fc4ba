// horizon/terrain/preview.hpp — PNG previews a person can read at once.
//
// The picture: a title band (what was computed, over which DEM, from where,
// how high), the map, and a legend panel on its right (each colour's
// meaning, the observer's and the reach's marks, a scale bar in ground
// metres, a north arrow).
//
// The map is a grey hillshade of the DEM (sun from the north-west, 45
// degrees up, slopes from true metric cell sizes) drawn at its true aspect:
// a cell is metres_per_col wide and metres_per_row tall on the page, so a
// geographic DEM's cells (narrower east-west by cos(latitude)) are not
// stretched into squares. Over it, either
//   - a code raster (write_viewshed_preview): 1 visible, 0 hidden,
//     2 undetermined, anything else no answer; or
//   - a value raster (write_ramp_preview): a colour ramp with its own legend
//     bar and units (the occlusion height field, the minimum visible target
//     height, a count of observers), NaN for no answer.
// Colours are Okabe and Ito's colour-blind-safe set: visible blue, hidden
// vermillion, undetermined yellow; ramps are viridis, yellow-orange-red and
// blues, each monotonic in lightness. Cells without an answer show the
// terrain: voids (NaN elevation) hatched grey, cells beyond the reach in a
// lightened hillshade. Colours are modulated by the hillshade (a flat cell
// shows the legend's colour exactly).
//
// The map's longer side is at most `max_size` pixels (larger rasters are
// box-averaged) and at least `min_size` (smaller ones are enlarged, each
// pixel showing the cell under its centre). Text is drawn in DejaVu Sans
// (fonts-dejavu-core); without the font the picture is drawn without words.
// Words are ASCII: OpenImageIO 2.4's render_text draws other code points as
// the wrong glyphs ("°" as "0").
// Written through OpenImageIO (imageio.hpp, loaded on first use), atomically
// (temporary name + rename).
#pragma once

#include <array>
#include <cstdint>
#include <limits>
#include <optional>
#include <string>
#include <vector>

#include "horizon/common/error.hpp"
#include "horizon/terrain/grid.hpp"

namespace horizon::terrain {

using Rgb8 = std::array<std::uint8_t, 3>;

// The palette (Okabe & Ito 2008), exact on flat terrain and in the legend.
inline constexpr Rgb8 kPreviewVisible = {0, 114, 178};        // blue
inline constexpr Rgb8 kPreviewHidden = {213, 94, 0};          // vermillion
inline constexpr Rgb8 kPreviewUndetermined = {240, 228, 66};  // yellow
inline constexpr Rgb8 kPreviewBeyond = {222, 222, 222};       // no answer on flat terrain: lightened grey
inline constexpr Rgb8 kPreviewVoidDark = {96, 96, 96};        // voids: stripes of these two greys
inline constexpr Rgb8 kPreviewVoidLight = {232, 232, 232};

// An observer's mark: grid coordinates of the preview's rasters (cell
// centres at integers) and its reach in ground metres (a ring; infinite: none).
struct PreviewSite {
  double col = 0.0, row = 0.0;
  double reach_m = std::numeric_limits<double>::infinity();
};

// A rectangle in the rasters' grid coordinates (continuous, cell centres at
// integers: cell c spans c - 0.5 to c + 0.5), its edges where they lie.
struct PreviewRect {
  double col0 = 0.0, row0 = 0.0, col1 = 0.0, row1 = 0.0;
};

// The legend's words for the codes of write_viewshed_preview.
struct PreviewClasses {
  std::string visible = "visible";
  std::string hidden = "hidden";
  std::string undetermined = "undetermined";
  std::string beyond = "beyond reach: not computed";
};

struct PreviewOptions {
  double metres_per_col = 1.0;  // ground size of a cell: the hillshade, the aspect and the scale bar
  double metres_per_row = 1.0;
  // Observers (the first ringed at its reach; with more than 12 sites only
  // the marks are drawn), and a from-region box.
  std::vector<PreviewSite> observers;
  std::optional<PreviewRect> region;
  // Lines of text above the map: the first a heading, the rest details.
  // Lines wider than the picture wrap between words.
  std::vector<std::string> title;
  PreviewClasses classes;
  int max_size = 2048;  // longest side of the map, pixels
  int min_size = 480;   // shortest long side: smaller maps are enlarged
};

// A colour ramp for write_ramp_preview.
enum class PreviewRamp {
  kElevation,     // viridis from the least value to the greatest (an OHF: absolute metres)
  kHeightNeeded,  // 0: visible (blue); above 0 yellow to dark red on a log scale, to the greatest value rounded up
  kCount,         // 0: vermillion (none); 1..max: light to dark blue
};

struct PreviewRampSpec {
  PreviewRamp ramp = PreviewRamp::kElevation;
  std::string heading;  // legend heading, e.g. "Lowest visible elevation"
  std::string units;    // "m", "observers"
  std::string zero;     // kHeightNeeded / kCount: the legend's word for 0 ("0 m: ground visible")
};

// Where the parts of a written preview lie, pixels (origin top-left), for
// callers and tests that look at it.
struct PreviewLayout {
  int width = 0, height = 0;          // the whole picture
  int map_x = 0, map_y = 0;           // the map's top-left pixel
  int map_width = 0, map_height = 0;  // pixels
  int legend_x = 0, legend_y = 0;     // the legend panel's top-left
  int legend_width = 0, legend_height = 0;
  double metres_per_pixel = 0.0;                  // ground metres a map pixel spans (both axes)
  double ramp_low = 0.0, ramp_high = 0.0;         // write_ramp_preview: the values at the bar's ends (no bar: 0)
  int ramp_x = 0, ramp_top = 0, ramp_bottom = 0;  // the bar's left column, its top and bottom rows
};

// elevation and codes must have the same size; an empty `codes` draws the
// terrain alone. `layout` (may be null) receives the picture's geometry.
Status write_viewshed_preview(const std::string& path, const Grid<float>& elevation, const Grid<std::uint8_t>& codes,
                              const PreviewOptions& options, PreviewLayout* layout = nullptr);

// `values` (NaN: no answer) over `elevation`, the same size, with `ramp`.
Status write_ramp_preview(const std::string& path, const Grid<float>& elevation, const Grid<float>& values,
                          const PreviewRampSpec& ramp, const PreviewOptions& options, PreviewLayout* layout = nullptr);

// The ramp's colour at fraction t in [0, 1] of its bar (bottom 0, top 1),
// as drawn on flat terrain; for kHeightNeeded and kCount t covers the
// values above 0 (kHeightNeeded: t = log(1 + v) / log(1 + top)).
Rgb8 preview_ramp_colour(PreviewRamp ramp, double t);

}  // namespace horizon::terrain
