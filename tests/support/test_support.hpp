// Shared helpers for Horizon's tests: synthetic DEMs, temporary directories,
// locating bundled and shared data.
#pragma once

#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include "horizon/terrain/dem.hpp"

namespace horizon::testing {

// A DEM of width x height cells whose elevation at cell (col, row) is
// height(col, row). Projected metres (EPSG:32633, UTM 33N) with square cells
// of `cell_size` metres, origin at (500000, 5000000) so it is georeferenced.
terrain::Dem make_dem(int width, int height, const std::function<double(int, int)>& height_fn, double cell_size = 10.0,
                      int epsg = 32633);

// Rough synthetic terrain for property tests: a fixed-seed sum of Gaussian
// hills and pits (heights in [0, ~relief] metres) over value noise. No CRS
// (epsg 0): grid units are plain metres, so distances are exactly cells x size.
terrain::Dem make_random_terrain(int width, int height, unsigned seed, double relief = 200.0, double cell_size = 30.0);

// A fresh empty directory under the system temp dir, removed on destruction.
class TempDir {
 public:
  TempDir();
  ~TempDir();
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;
  const std::filesystem::path& path() const { return path_; }
  std::string file(const std::string& name) const { return (path_ / name).string(); }

 private:
  std::filesystem::path path_;
};

// Cuts `dem` into nx x ny tiles of near-equal size (the last row and column
// take the remainder) and writes each as a GeoTIFF "<dir>/tile_<r>_<c>.tif"
// with its own georeference (the DEM's, shifted to the tile's corner), as
// gdal_translate -srcwin would. Returns the paths, row by row.
std::vector<std::string> write_tiles(const terrain::Dem& dem, int nx, int ny, const std::string& dir);

// The bytes of the file at `path` ("" when it cannot be read).
std::string read_bytes(const std::string& path);

// Overwrites 512 bytes in the middle of the file at `path` with 0xA5: a
// corrupt block in a compressed GeoTIFF's pixels.
void overwrite_middle(const std::string& path);

// Writes an SRTM tile "<dir>/N46W122.hgt" (named by its south-west corner,
// big-endian int16, n x n samples on whole-degree edges) whose heights are a
// function of the global sample position, so neighbours' shared edges agree;
// a void (-32768) now and then.
void write_hgt(const std::string& dir, int lat, int lon, int n);

// Path of a DEM bundled in data/dem (always present), or in
// $HORIZON_TEST_DATA_DIR when that is set.
std::string bundled_dem(const std::string& name);
// Directory of ../shared/data/dem, or empty when it does not exist (tests then GTEST_SKIP()).
std::string shared_dem_dir();

// Runs a shell command, returns its exit status and captures stdout+stderr.
struct CommandResult {
  int exit_code = -1;
  std::string output;
};
CommandResult run_command(const std::string& command);
// `text` single-quoted for /bin/sh.
std::string shell_quote(const std::string& text);

// A parameterised test's name from free text: letters and digits kept, every
// run of anything else one '_' (none at the ends), as gtest requires.
std::string readable_name(const std::string& text);
// The name of a test run on the DEM `file`: its stem ("rainier_summit_srtm3_400x400").
std::string dem_name(const std::string& file);

}  // namespace horizon::testing
