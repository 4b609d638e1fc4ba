// raster_files.hpp — a viewshed's GeoTIFF and PNG as bytes, through the
// engine's own writers, so the daemon's GeoTIFF is byte-identical to the one
// `horizon viewshed -o` writes for the same inputs. The writers work on files:
// each encoding goes to a unique name in the daemon's private scratch
// directory (scratch_dir.hpp), is read back and removed.
#pragma once

#include <cstdint>
#include <filesystem>
#include <functional>
#include <optional>
#include <string>

#include "horizon/common/error.hpp"
#include "horizon/terrain/georef.hpp"
#include "horizon/terrain/geotiff_writer.hpp"
#include "horizon/terrain/grid.hpp"

namespace horizon::server {

// `options`: the request's format and creation options (the writer's defaults when absent).
Result<std::string> geotiff_bytes(const std::filesystem::path& scratch_dir, const terrain::Grid<float>& grid,
                                  const terrain::Georeference& georef, std::optional<double> nodata,
                                  const terrain::GeoTiffOptions& options = {});
// With `colours`, the GeoTIFF carries that colour table (the visibility masks).
Result<std::string> geotiff_bytes(const std::filesystem::path& scratch_dir, const terrain::Grid<std::uint8_t>& grid,
                                  const terrain::Georeference& georef, std::optional<double> nodata,
                                  const terrain::ColourTable* colours = nullptr,
                                  const terrain::GeoTiffOptions& options = {});
Result<std::string> geotiff_bytes(const std::filesystem::path& scratch_dir, const terrain::Grid<std::uint32_t>& grid,
                                  const terrain::Georeference& georef, std::optional<double> nodata,
                                  const terrain::GeoTiffOptions& options = {});
// The bytes of the PNG `draw(path)` writes (the CLI's --png preview, drawn by
// visibility/viewshed_preview.hpp's writers).
Result<std::string> png_bytes(const std::filesystem::path& scratch_dir,
                              const std::function<Status(const std::string& path)>& draw);

}  // namespace horizon::server
