// plugin.cpp — libhorizon_imageio.so: OpenImageIO behind plugin_abi.hpp.
// Built as a MODULE library; only imageio.cpp opens it (with dlopen).
#include <OpenImageIO/imagebuf.h>
#include <OpenImageIO/imagebufalgo.h>
#include <OpenImageIO/imageio.h>

#include "plugin_abi.hpp"

namespace horizon::imageio::plugin {
namespace {

std::string read_image8(const std::string& path, ImageFacts& facts, std::vector<std::uint8_t>& pixels) {
  auto in = OIIO::ImageInput::open(path);
  if (!in) return "not an image OpenImageIO can read (" + OIIO::geterror() + ")";
  const OIIO::ImageSpec& spec = in->spec();
  facts.format = in->format_name();
  facts.width = spec.width;
  facts.height = spec.height;
  facts.channels = spec.nchannels;
  if (spec.format != OIIO::TypeDesc::UINT8) return std::string("channels are ") + spec.format.c_str() + ", not 8-bit";
  if (spec.width <= 0 || spec.height <= 0 || spec.depth > 1 || spec.nchannels <= 0) return "has no 2-D pixel grid";
  pixels.resize(static_cast<std::size_t>(spec.width) * spec.height * spec.nchannels);
  if (!in->read_image(0, 0, 0, spec.nchannels, OIIO::TypeDesc::UINT8, pixels.data()))
    return "cannot decode pixels (" + in->geterror() + ")";
  in->close();
  return {};
}

std::string write_png(const std::string& path, int width, int height, int channels, const std::uint8_t* pixels) {
  auto out = OIIO::ImageOutput::create("png");
  if (!out) return "OpenImageIO has no PNG writer (" + OIIO::geterror() + ")";
  OIIO::ImageSpec spec(width, height, channels, OIIO::TypeDesc::UINT8);
  if (!out->open(path, spec)) return "cannot create '" + path + "' (" + out->geterror() + ")";
  if (!out->write_image(OIIO::TypeDesc::UINT8, pixels)) return "cannot write pixels (" + out->geterror() + ")";
  if (!out->close()) return "cannot finish the file (" + out->geterror() + ")";
  return {};
}

OIIO::ImageBuf& buf(void* canvas) {
  return *static_cast<OIIO::ImageBuf*>(canvas);
}

void* canvas_create(int width, int height) {
  auto* b = new OIIO::ImageBuf(OIIO::ImageSpec(width, height, 3, OIIO::TypeDesc::UINT8));
  OIIO::ImageBufAlgo::fill(*b, {1.0f, 1.0f, 1.0f});
  return b;
}

void canvas_destroy(void* canvas) {
  delete static_cast<OIIO::ImageBuf*>(canvas);
}

void canvas_line(void* canvas, int x0, int y0, int x1, int y1, const float rgb[3]) {
  OIIO::ImageBufAlgo::render_line(buf(canvas), x0, y0, x1, y1, {rgb[0], rgb[1], rgb[2]});
}

void canvas_box(void* canvas, int x0, int y0, int x1, int y1, const float rgb[3], bool fill) {
  OIIO::ImageBufAlgo::render_box(buf(canvas), x0, y0, x1, y1, {rgb[0], rgb[1], rgb[2]}, fill);
}

bool canvas_text_size(const std::string& text, int size, const std::string& font, int& width, int& top) {
  const OIIO::ROI r = OIIO::ImageBufAlgo::text_size(text, size, font);
  if (!r.defined()) return false;
  width = r.width();
  top = r.ybegin;
  return true;
}

bool canvas_text(void* canvas, int x, int baseline, const std::string& text, int size, const std::string& font,
                 const float rgb[3]) {
  return OIIO::ImageBufAlgo::render_text(buf(canvas), x, baseline, text, size, font, {rgb[0], rgb[1], rgb[2]});
}

std::string canvas_write_png(void* canvas, const std::string& path) {
  if (!buf(canvas).write(path, OIIO::TypeUnknown, "png")) return buf(canvas).geterror();
  return {};
}

void canvas_paste(void* canvas, int x, int y, int w, int h, const std::uint8_t* rgb) {
  buf(canvas).set_pixels(OIIO::ROI(x, x + w, y, y + h, 0, 1, 0, 3), OIIO::TypeDesc::UINT8, rgb);
}

constexpr Abi kAbi = {kAbiVersion, read_image8,      write_png,   canvas_create,    canvas_destroy, canvas_line,
                      canvas_box,  canvas_text_size, canvas_text, canvas_write_png, canvas_paste};

}  // namespace
}  // namespace horizon::imageio::plugin

extern "C" __attribute__((visibility("default"))) const horizon::imageio::plugin::Abi* horizon_imageio_abi() {
  return &horizon::imageio::plugin::kAbi;
}
