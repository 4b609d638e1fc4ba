// imageio.cpp — finds and opens libhorizon_imageio.so once, and turns the
// plugin's string errors into Horizon's (see imageio.hpp).
#include "horizon/imageio/imageio.hpp"

#include <dlfcn.h>
#include <unistd.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <mutex>

#include "horizon/common/plugin_paths.hpp"
#include "plugin_abi.hpp"

namespace horizon::imageio {
namespace {

constexpr const char* kModule = "libhorizon_imageio.so";

struct Loaded {
  const plugin::Abi* abi = nullptr;
  std::string path;   // where it was loaded from
  std::string error;  // why it was not
};

Loaded load() {
#ifdef HORIZON_IMAGEIO_BUILD_PATH
  const char* build_path = HORIZON_IMAGEIO_BUILD_PATH;
#else
  const char* build_path = nullptr;
#endif
  const std::vector<std::string> candidates = plugin_candidates("HORIZON_IMAGEIO_PLUGIN", kModule, build_path);
  Loaded loaded;
  std::string tried;
  for (const std::string& path : candidates) {
    if (!std::filesystem::exists(path)) {
      tried += (tried.empty() ? "" : ", ") + path + " (absent)";
      continue;
    }
    void* handle = ::dlopen(path.c_str(), RTLD_NOW | RTLD_LOCAL);
    if (!handle) {
      const char* why = ::dlerror();
      tried += (tried.empty() ? "" : ", ") + path + " (" + (why ? why : "dlopen failed") + ")";
      continue;
    }
    using Entry = const plugin::Abi* (*)();
    auto entry = reinterpret_cast<Entry>(::dlsym(handle, "horizon_imageio_abi"));
    const plugin::Abi* abi = entry ? entry() : nullptr;
    if (!abi || abi->version != plugin::kAbiVersion) {
      tried += (tried.empty() ? "" : ", ") + path + " (not a compatible " + kModule + ")";
      ::dlclose(handle);
      continue;
    }
    // Kept open for the life of the process.
    loaded.abi = abi;
    loaded.path = path;
    return loaded;
  }
  loaded.error = std::string("the OpenImageIO plugin ") + kModule +
                 " could not be loaded (tried: " + (tried.empty() ? "nothing" : tried) +
                 "); set HORIZON_IMAGEIO_PLUGIN to its path";
  return loaded;
}

const Loaded& module() {
  static std::once_flag once;
  static Loaded loaded;
  std::call_once(once, [] { loaded = load(); });
  return loaded;
}

Result<const plugin::Abi*> abi() {
  const Loaded& m = module();
  if (!m.abi) return make_error(ErrorCode::kInternal, m.error, "imageio");
  return m.abi;
}

void rgb_of(Colour c, float out[3]) {
  out[0] = c.r;
  out[1] = c.g;
  out[2] = c.b;
}

class PluginCanvas final : public Canvas {
 public:
  PluginCanvas(const plugin::Abi* abi, void* handle, int width, int height)
      : abi_(abi), handle_(handle), width_(width), height_(height) {}
  ~PluginCanvas() override { abi_->canvas_destroy(handle_); }
  PluginCanvas(const PluginCanvas&) = delete;
  PluginCanvas& operator=(const PluginCanvas&) = delete;

  void line(int x0, int y0, int x1, int y1, Colour c) override {
    float rgb[3];
    rgb_of(c, rgb);
    abi_->canvas_line(handle_, x0, y0, x1, y1, rgb);
  }
  void box(int x0, int y0, int x1, int y1, Colour c, bool fill) override {
    float rgb[3];
    rgb_of(c, rgb);
    abi_->canvas_box(handle_, x0, y0, x1, y1, rgb, fill);
  }
  bool text(int x, int y_top, const std::string& s, int size, const std::string& font, int align, Colour c) override {
    int width = 0, top = 0;
    if (!abi_->canvas_text_size(s, size, font, width, top)) return false;
    const int x0 = align == 0 ? x : align == 1 ? x - width / 2 : x - width;
    float rgb[3];
    rgb_of(c, rgb);
    return abi_->canvas_text(handle_, x0, y_top - top, s, size, font, rgb);  // top < 0: the ascent
  }
  bool text_baseline(int x, int baseline, const std::string& s, int size, const std::string& font, int align,
                     Colour c) override {
    int width = 0, top = 0;
    if (!abi_->canvas_text_size(s, size, font, width, top)) return false;
    const int x0 = align == 0 ? x : align == 1 ? x - width / 2 : x - width;
    float rgb[3];
    rgb_of(c, rgb);
    return abi_->canvas_text(handle_, x0, baseline, s, size, font, rgb);
  }
  void paste(int x, int y, int w, int h, const std::uint8_t* rgb) override {
    if (w <= 0 || h <= 0) return;
    // Clip to the canvas: the plugin copies rectangles that lie on it.
    const int x0 = std::max(x, 0), y0 = std::max(y, 0);
    const int x1 = std::min(x + w, width_), y1 = std::min(y + h, height_);
    if (x0 >= x1 || y0 >= y1) return;
    if (x0 == x && y0 == y && x1 == x + w && y1 == y + h) {
      abi_->canvas_paste(handle_, x, y, w, h, rgb);
      return;
    }
    std::vector<std::uint8_t> part(static_cast<std::size_t>(x1 - x0) * (y1 - y0) * 3);
    for (int r = y0; r < y1; ++r)
      std::copy_n(rgb + (static_cast<std::size_t>(r - y) * w + (x0 - x)) * 3, static_cast<std::size_t>(x1 - x0) * 3,
                  part.data() + static_cast<std::size_t>(r - y0) * (x1 - x0) * 3);
    abi_->canvas_paste(handle_, x0, y0, x1 - x0, y1 - y0, part.data());
  }
  Status write_png(const std::string& path) override {
    const std::string why = abi_->canvas_write_png(handle_, path);
    if (!why.empty()) return make_error(ErrorCode::kIoError, "cannot write PNG '" + path + "': " + why, path);
    return Status::Ok();
  }

 private:
  const plugin::Abi* abi_;
  void* handle_;
  int width_, height_;
};

}  // namespace

Result<Image8> read_image8(const std::string& path) {
  auto a = abi();
  if (!a.ok()) return a.error();
  plugin::ImageFacts facts;
  Image8 image;
  const std::string why = (*a)->read_image8(path, facts, image.pixels);
  if (!why.empty()) return make_error(ErrorCode::kDataError, "image '" + path + "': " + why, path);
  image.width = facts.width;
  image.height = facts.height;
  image.channels = facts.channels;
  image.format = facts.format;
  return image;
}

Status write_png(const std::string& path, int width, int height, int channels, const std::uint8_t* pixels) {
  auto a = abi();
  if (!a.ok()) return a.error();
  const std::string why = (*a)->write_png(path, width, height, channels, pixels);
  if (!why.empty()) return make_error(ErrorCode::kIoError, "cannot write PNG '" + path + "': " + why, path);
  return Status::Ok();
}

Result<std::unique_ptr<Canvas>> make_canvas(int width, int height) {
  auto a = abi();
  if (!a.ok()) return a.error();
  if (width <= 0 || height <= 0)
    return make_error(ErrorCode::kInvalidArgument, "canvas: size must be positive", "canvas");
  return std::unique_ptr<Canvas>(std::make_unique<PluginCanvas>(*a, (*a)->canvas_create(width, height), width, height));
}

std::optional<int> text_width(const std::string& s, int size, const std::string& font) {
  auto a = abi();
  if (!a.ok()) return std::nullopt;
  int width = 0, top = 0;
  if (!(*a)->canvas_text_size(s, size, font, width, top)) return std::nullopt;
  return width;
}

Result<std::string> plugin_path() {
  const Loaded& m = module();
  if (!m.abi) return make_error(ErrorCode::kInternal, m.error, "imageio");
  return m.path;
}

}  // namespace horizon::imageio
