// imageio.hpp — the images a person looks at (PNG previews and charts) and
// the PNG/8-bit images Horizon reads (terrain-RGB tiles), through
// OpenImageIO, which is loaded on first use.
//
// Why loaded late: OpenImageIO 2.4 as Debian builds it pulls ~260 shared
// libraries into a process (OpenCV, OpenVDB, FFmpeg, DCMTK, ...), which costs
// every process ~0.3 s at start-up whether it draws a picture or not. So
// OpenImageIO lives in a small plugin module, libhorizon_imageio.so, opened
// with dlopen the first time one of these functions is called; a `horizon
// viewshed` that writes only a GeoTIFF, a `horizon los` or the daemon never
// load it. GeoTIFF pixels are read and written with libtiff (terrain/).
//
// Where the module is looked for: at $HORIZON_IMAGEIO_PLUGIN (a path to the
// module itself) and nowhere else when that is set; otherwise, in order, next
// to the running executable, in ../lib/horizon/ from it (the installed
// layout: bin/horizon, lib/horizon/libhorizon_imageio.so), and in the build
// tree it was built in.
// When none loads, every function returns a kInternal error that names the
// places tried and dlopen's reason; nothing else in Horizon is affected.
//
// Thread safety: the module is loaded once (std::call_once); every function
// may be called from any thread. A Canvas is used by one thread at a time.
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "horizon/common/error.hpp"

namespace horizon::imageio {

// An 8-bit image, row-major, `channels` interleaved samples per pixel.
struct Image8 {
  int width = 0, height = 0, channels = 0;
  std::vector<std::uint8_t> pixels;
  std::string format;  // the file format OpenImageIO recognised ("png", ...)
};

// Reads an image with 8-bit channels. kDataError when the file is not an
// image OpenImageIO can read, or its channels are not 8-bit; the message
// names `path` and the reason.
Result<Image8> read_image8(const std::string& path);

// Writes `width` x `height` pixels of `channels` (1-4) 8-bit samples as a PNG
// at `path`, directly (callers wanting atomicity write a temporary and
// rename). kIoError names the path.
Status write_png(const std::string& path, int width, int height, int channels, const std::uint8_t* pixels);

// An RGB colour, components in [0, 1].
struct Colour {
  float r = 0, g = 0, b = 0;
};

// An RGB drawing surface, white until drawn on; coordinates in pixels, origin
// at the top-left, y down.
class Canvas {
 public:
  virtual ~Canvas() = default;
  virtual void line(int x0, int y0, int x1, int y1, Colour c) = 0;
  virtual void box(int x0, int y0, int x1, int y1, Colour c, bool fill) = 0;
  // Text with its top-left corner at (x, y_top) in `font` at `size` pixels;
  // align 0 = left, 1 = centred on x, 2 = right. False when the font cannot
  // be found or drawn (nothing drawn then).
  virtual bool text(int x, int y_top, const std::string& s, int size, const std::string& font, int align, Colour c) = 0;
  // The same with the text's baseline at y (lines of words that share a baseline).
  virtual bool text_baseline(int x, int baseline, const std::string& s, int size, const std::string& font, int align,
                             Colour c) = 0;
  // Copies w x h RGB pixels (row-major, 3 bytes each) onto the canvas with
  // their top-left at (x, y); the part off the canvas is dropped.
  virtual void paste(int x, int y, int w, int h, const std::uint8_t* rgb) = 0;
  // Writes the canvas as a PNG at `path` (directly; see write_png).
  virtual Status write_png(const std::string& path) = 0;
};

Result<std::unique_ptr<Canvas>> make_canvas(int width, int height);

// The width in pixels of `s` drawn by Canvas::text in `font` at `size`;
// nullopt when the font (or the module) cannot be found.
std::optional<int> text_width(const std::string& s, int size, const std::string& font);

// Where the module was loaded from, or the error of loading it (for `horizon
// --version` and diagnostics). Loads it when not yet loaded.
Result<std::string> plugin_path();

}  // namespace horizon::imageio
