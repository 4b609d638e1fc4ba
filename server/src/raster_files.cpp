#include "raster_files.hpp"

#include <unistd.h>

#include <atomic>
#include <fstream>
#include <sstream>

#include "horizon/terrain/geotiff_writer.hpp"

namespace horizon::server {
namespace {

namespace fs = std::filesystem;

fs::path unique_name(const fs::path& dir, const char* extension) {
  static std::atomic<std::uint64_t> counter{0};
  return dir / ("horizond-" + std::to_string(::getpid()) + "-" + std::to_string(counter.fetch_add(1)) + extension);
}

// Runs `write(path)`, returns the file's bytes and removes it whatever happens.
template <class Write>
Result<std::string> encode(const fs::path& dir, const char* extension, Write&& write) {
  const fs::path path = unique_name(dir, extension);
  struct Remove {
    const fs::path& p;
    ~Remove() {
      std::error_code ec;
      fs::remove(p, ec);
    }
  } remove{path};
  const Status written = write(path.string());
  if (!written.ok()) return written.error();
  std::ifstream in(path, std::ios::binary);
  if (!in)
    return make_error(ErrorCode::kIoError, "an encoded raster could not be read back from the scratch directory");
  std::ostringstream bytes;
  bytes << in.rdbuf();
  return std::move(bytes).str();
}

}  // namespace

Result<std::string> geotiff_bytes(const fs::path& scratch_dir, const terrain::Grid<float>& grid,
                                  const terrain::Georeference& georef, std::optional<double> nodata,
                                  const terrain::GeoTiffOptions& options) {
  return encode(scratch_dir, ".tif",
                [&](const std::string& p) { return terrain::write_geotiff(p, grid, georef, nodata, options); });
}

Result<std::string> geotiff_bytes(const fs::path& scratch_dir, const terrain::Grid<std::uint8_t>& grid,
                                  const terrain::Georeference& georef, std::optional<double> nodata,
                                  const terrain::ColourTable* colours, const terrain::GeoTiffOptions& options) {
  return encode(scratch_dir, ".tif", [&](const std::string& p) {
    return colours ? terrain::write_geotiff(p, grid, georef, nodata, *colours, options)
                   : terrain::write_geotiff(p, grid, georef, nodata, options);
  });
}

Result<std::string> geotiff_bytes(const fs::path& scratch_dir, const terrain::Grid<std::uint32_t>& grid,
                                  const terrain::Georeference& georef, std::optional<double> nodata,
                                  const terrain::GeoTiffOptions& options) {
  return encode(scratch_dir, ".tif",
                [&](const std::string& p) { return terrain::write_geotiff(p, grid, georef, nodata, options); });
}

Result<std::string> png_bytes(const fs::path& scratch_dir, const std::function<Status(const std::string& path)>& draw) {
  return encode(scratch_dir, ".png", draw);
}

}  // namespace horizon::server
