// plugin_abi.hpp — the table of functions libhorizon_imageio.so exports, and
// nothing else: the module is built from this project with the same compiler
// and standard library, so std::string and std::vector cross the boundary.
// Every function that can fail returns an empty string on success and the
// reason otherwise. Bump kAbiVersion whenever the table changes.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace horizon::imageio::plugin {

constexpr int kAbiVersion = 2;

struct ImageFacts {
  int width = 0, height = 0, channels = 0;
  std::string format;
};

struct Abi {
  int version;
  std::string (*read_image8)(const std::string& path, ImageFacts& facts, std::vector<std::uint8_t>& pixels);
  std::string (*write_png)(const std::string& path, int width, int height, int channels, const std::uint8_t* pixels);
  void* (*canvas_create)(int width, int height);  // white RGB
  void (*canvas_destroy)(void* canvas);
  void (*canvas_line)(void* canvas, int x0, int y0, int x1, int y1, const float rgb[3]);
  void (*canvas_box)(void* canvas, int x0, int y0, int x1, int y1, const float rgb[3], bool fill);
  // The text's width and its top's offset from the baseline (negative); false without the font.
  bool (*canvas_text_size)(const std::string& text, int size, const std::string& font, int& width, int& top);
  bool (*canvas_text)(void* canvas, int x, int baseline, const std::string& text, int size, const std::string& font,
                      const float rgb[3]);
  std::string (*canvas_write_png)(void* canvas, const std::string& path);
  // Copies w x h RGB pixels (row-major, 3 bytes each) to the canvas at (x, y); the rectangle lies on it.
  void (*canvas_paste)(void* canvas, int x, int y, int w, int h, const std::uint8_t* rgb);
};

}  // namespace horizon::imageio::plugin

// The module's one exported symbol.
extern "C" const horizon::imageio::plugin::Abi* horizon_imageio_abi();
