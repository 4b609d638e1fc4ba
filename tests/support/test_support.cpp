#include "test_support.hpp"

#include "horizon/terrain/geotiff_writer.hpp"

#include <sys/wait.h>

#include <unistd.h>
#include <array>
#include <atomic>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <random>
#include <vector>

namespace horizon::testing {

terrain::Dem make_dem(int width, int height, const std::function<double(int, int)>& height_fn, double cell_size,
                      int epsg) {
  terrain::Dem dem;
  dem.elevation = terrain::Grid<float>(width, height);
  for (int r = 0; r < height; ++r)
    for (int c = 0; c < width; ++c) dem.elevation.at(c, r) = static_cast<float>(height_fn(c, r));
  dem.georef.transform = {500000.0, cell_size, 5000000.0, -cell_size};
  dem.georef.epsg = epsg;
  dem.source = "synthetic";
  dem.format = "synthetic";
  return dem;
}

terrain::Dem make_random_terrain(int width, int height, unsigned seed, double relief, double cell_size) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> ux(0, width), uy(0, height), amp(-0.5, 1.0), radius(2.0, 0.25 * width);
  struct Hill {
    double x, y, a, r;
  };
  std::vector<Hill> hills(40);
  for (Hill& h : hills) h = {ux(rng), uy(rng), amp(rng) * relief, radius(rng)};
  std::uniform_real_distribution<double> noise(0.0, 0.02 * relief);
  return make_dem(
      width, height,
      [&](int c, int r) {
        double z = 0.5 * relief;
        for (const Hill& h : hills) {
          const double d2 = (c - h.x) * (c - h.x) + (r - h.y) * (r - h.y);
          z += h.a * std::exp(-d2 / (h.r * h.r));
        }
        return z + noise(rng);
      },
      cell_size, /*epsg=*/0);
}

TempDir::TempDir() {
  static std::atomic<int> counter{0};
  std::random_device rd;
  path_ = std::filesystem::temp_directory_path() /
          ("horizon-test-" + std::to_string(::getpid()) + "-" + std::to_string(counter++) + "-" + std::to_string(rd()));
  std::filesystem::create_directories(path_);
}

TempDir::~TempDir() {
  std::error_code ec;
  std::filesystem::remove_all(path_, ec);
}

std::string bundled_dem(const std::string& name) {
  // $HORIZON_TEST_DATA_DIR: the test binaries run from a copied bundle
  // (tests/bench/gpu_device_bundle.sh) on a machine without this checkout.
  const char* dir = std::getenv("HORIZON_TEST_DATA_DIR");
  return std::string(dir && *dir ? dir : HORIZON_DATA_DIR) + "/" + name;
}

std::string shared_dem_dir() {
  std::error_code ec;
  const std::filesystem::path dir = HORIZON_SHARED_DEM_DIR;
  if (std::filesystem::is_directory(dir, ec)) return std::filesystem::canonical(dir, ec).string();
  return {};
}

CommandResult run_command(const std::string& command) {
  CommandResult result;
  const std::string full = command + " 2>&1";
  FILE* pipe = ::popen(full.c_str(), "r");
  if (!pipe) return result;
  std::array<char, 4096> buffer{};
  std::size_t n = 0;
  while ((n = std::fread(buffer.data(), 1, buffer.size(), pipe)) > 0) result.output.append(buffer.data(), n);
  const int status = ::pclose(pipe);
  result.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return result;
}

std::vector<std::string> write_tiles(const terrain::Dem& dem, int nx, int ny, const std::string& dir) {
  std::vector<std::string> paths;
  const int tw = dem.width() / nx, th = dem.height() / ny;
  for (int ty = 0; ty < ny; ++ty)
    for (int tx = 0; tx < nx; ++tx) {
      const int c0 = tx * tw, r0 = ty * th;
      const int c1 = tx == nx - 1 ? dem.width() : c0 + tw, r1 = ty == ny - 1 ? dem.height() : r0 + th;
      terrain::Grid<float> cells(c1 - c0, r1 - r0);
      for (int r = r0; r < r1; ++r)
        for (int c = c0; c < c1; ++c) cells.at(c - c0, r - r0) = dem.elevation.at(c, r);
      terrain::Georeference georef = dem.georef;
      georef.transform = dem.georef.transform.shifted(c0, r0);
      const std::string path = dir + "/tile_" + std::to_string(ty) + "_" + std::to_string(tx) + ".tif";
      if (!terrain::write_geotiff(path, cells, georef, dem.nodata).ok()) return {};
      paths.push_back(path);
    }
  return paths;
}

std::string readable_name(const std::string& text) {
  std::string name;
  for (const char ch : text) {
    if (std::isalnum(static_cast<unsigned char>(ch)))
      name += ch;
    else if (!name.empty() && name.back() != '_')
      name += '_';
  }
  if (!name.empty() && name.back() == '_') name.pop_back();
  return name;
}

std::string dem_name(const std::string& file) {
  return readable_name(std::filesystem::path(file).stem().string());
}

std::string read_bytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

void overwrite_middle(const std::string& path) {
  const auto size = std::filesystem::file_size(path);
  std::fstream f(path, std::ios::in | std::ios::out | std::ios::binary);
  f.seekp(static_cast<std::streamoff>(size / 2));
  const std::string junk(512, '\xA5');
  f.write(junk.data(), static_cast<std::streamsize>(junk.size()));
}

void write_hgt(const std::string& dir, int lat, int lon, int n) {
  char name[32];
  std::snprintf(name, sizeof name, "%c%02d%c%03d.hgt", lat >= 0 ? 'N' : 'S', std::abs(lat), lon >= 0 ? 'E' : 'W',
                std::abs(lon));
  std::ofstream out(dir + "/" + name, std::ios::binary);
  for (int r = 0; r < n; ++r)
    for (int c = 0; c < n; ++c) {
      const long gc = static_cast<long>(lon) * (n - 1) + c, gr = static_cast<long>(-lat) * (n - 1) + r;
      // Ridges and valleys across tiles, so that a viewshed has something to hide.
      const double z = 1500 + 600 * std::sin(gc * 0.011) * std::cos(gr * 0.013) + 80 * std::sin(gc * 0.13 + gr * 0.07);
      auto v = static_cast<std::int16_t>(std::lround(z));
      if ((gc * 7 + gr * 13) % 9973 == 0) v = -32768;
      const unsigned char bytes[2] = {static_cast<unsigned char>(static_cast<std::uint16_t>(v) >> 8),
                                      static_cast<unsigned char>(v & 0xff)};
      out.write(reinterpret_cast<const char*>(bytes), 2);
    }
}

std::string shell_quote(const std::string& text) {
  std::string out(1, '\'');
  for (char c : text) {
    if (c == '\'')
      out.append("'\\''");
    else
      out.push_back(c);
  }
  out.push_back('\'');
  return out;
}

}  // namespace horizon::testing
