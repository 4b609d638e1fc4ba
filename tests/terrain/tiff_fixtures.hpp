// Test-only helpers that craft TIFF files the production writer never makes:
// rotated transforms, PixelIsPoint, unsupported CRSs, several bands, odd
// pixel types. Raw GeoTIFF tags go through libtiff directly; plain multi-band
// images through OpenImageIO.
#pragma once

#include <OpenImageIO/imageio.h>
#include <tiffio.h>

#include <cstdint>
#include <optional>
#include <string>
#include <utility>
#include <vector>

namespace horizon::testing {

struct RawTiff {
  int width = 0, height = 0;
  bool int16 = false;                                            // else float32
  std::vector<double> values;                                    // row-major, width * height
  std::vector<double> pixel_scale;                               // ModelPixelScaleTag (33550)
  std::vector<double> tiepoints;                                 // ModelTiepointTag (33922)
  std::vector<double> matrix;                                    // ModelTransformationTag (34264)
  std::vector<std::pair<std::uint16_t, std::uint16_t>> geokeys;  // (key id, SHORT value), ascending ids
  std::optional<std::string> nodata;                             // GDAL_NODATA (42113)
  std::uint32_t rows_per_strip = 1;                              // the height for one strip
  bool deflate = false;                                          // else uncompressed
};

// Writes `spec` as a striped TIFF. Returns false on failure.
inline bool write_raw_tiff(const std::string& path, const RawTiff& spec) {
  static const TIFFFieldInfo kFields[] = {
      {33550, -1, -1, TIFF_DOUBLE, FIELD_CUSTOM, 1, 1, const_cast<char*>("ModelPixelScale")},
      {33922, -1, -1, TIFF_DOUBLE, FIELD_CUSTOM, 1, 1, const_cast<char*>("ModelTiepoint")},
      {34264, -1, -1, TIFF_DOUBLE, FIELD_CUSTOM, 1, 1, const_cast<char*>("ModelTransformation")},
      {34735, -1, -1, TIFF_SHORT, FIELD_CUSTOM, 1, 1, const_cast<char*>("GeoKeyDirectory")},
      {42113, -1, -1, TIFF_ASCII, FIELD_CUSTOM, 1, 0, const_cast<char*>("GDAL_NODATA")},
  };
  TIFF* tif = TIFFOpen(path.c_str(), "w");
  if (!tif) return false;
  TIFFMergeFieldInfo(tif, kFields, sizeof kFields / sizeof kFields[0]);
  TIFFSetField(tif, TIFFTAG_IMAGEWIDTH, static_cast<std::uint32_t>(spec.width));
  TIFFSetField(tif, TIFFTAG_IMAGELENGTH, static_cast<std::uint32_t>(spec.height));
  TIFFSetField(tif, TIFFTAG_SAMPLESPERPIXEL, 1);
  TIFFSetField(tif, TIFFTAG_BITSPERSAMPLE, spec.int16 ? 16 : 32);
  TIFFSetField(tif, TIFFTAG_SAMPLEFORMAT, spec.int16 ? SAMPLEFORMAT_INT : SAMPLEFORMAT_IEEEFP);
  TIFFSetField(tif, TIFFTAG_PHOTOMETRIC, PHOTOMETRIC_MINISBLACK);
  TIFFSetField(tif, TIFFTAG_PLANARCONFIG, PLANARCONFIG_CONTIG);
  TIFFSetField(tif, TIFFTAG_ROWSPERSTRIP, spec.rows_per_strip);
  if (spec.deflate) TIFFSetField(tif, TIFFTAG_COMPRESSION, COMPRESSION_ADOBE_DEFLATE);
  if (!spec.pixel_scale.empty())
    TIFFSetField(tif, 33550, static_cast<int>(spec.pixel_scale.size()), spec.pixel_scale.data());
  if (!spec.tiepoints.empty()) TIFFSetField(tif, 33922, static_cast<int>(spec.tiepoints.size()), spec.tiepoints.data());
  if (!spec.matrix.empty()) TIFFSetField(tif, 34264, static_cast<int>(spec.matrix.size()), spec.matrix.data());
  if (!spec.geokeys.empty()) {
    std::vector<std::uint16_t> dir = {1, 1, 0, static_cast<std::uint16_t>(spec.geokeys.size())};
    for (const auto& [key, value] : spec.geokeys) dir.insert(dir.end(), {key, 0, 1, value});
    TIFFSetField(tif, 34735, static_cast<int>(dir.size()), dir.data());
  }
  if (spec.nodata) TIFFSetField(tif, 42113, spec.nodata->c_str());
  bool ok = true;
  for (int r = 0; r < spec.height && ok; ++r) {
    if (spec.int16) {
      std::vector<std::int16_t> row(spec.width);
      for (int c = 0; c < spec.width; ++c) row[c] = static_cast<std::int16_t>(spec.values[r * spec.width + c]);
      ok = TIFFWriteScanline(tif, row.data(), static_cast<std::uint32_t>(r), 0) == 1;
    } else {
      std::vector<float> row(spec.width);
      for (int c = 0; c < spec.width; ++c) row[c] = static_cast<float>(spec.values[r * spec.width + c]);
      ok = TIFFWriteScanline(tif, row.data(), static_cast<std::uint32_t>(r), 0) == 1;
    }
  }
  TIFFClose(tif);
  return ok;
}

// A georeferenced width x height Float32 RawTiff: UTM 33N, 10 m cells,
// corner at (500000, 5000000), value = 100 * row + col.
inline RawTiff utm_raw_tiff(int width, int height) {
  RawTiff t;
  t.width = width;
  t.height = height;
  for (int r = 0; r < height; ++r)
    for (int c = 0; c < width; ++c) t.values.push_back(100.0 * r + c);
  t.pixel_scale = {10.0, 10.0, 0.0};
  t.tiepoints = {0, 0, 0, 500000.0, 5000000.0, 0};
  t.geokeys = {{1024, 1}, {1025, 1}, {3072, 32633}};  // projected, PixelIsArea, EPSG:32633
  return t;
}

// Writes an image of `channels` bands with OpenImageIO (no georeferencing);
// band b of cell (c, r) holds 1000 * (b + 1) + 10 * r + c.
inline bool write_oiio_image(const std::string& path, int width, int height, int channels, OIIO::TypeDesc type,
                             const std::string& compression = "zip", bool tiled = false, bool bigtiff = false) {
  auto out = OIIO::ImageOutput::create(path);
  if (!out) return false;
  OIIO::ImageSpec spec(width, height, channels, type);
  spec.attribute("compression", compression);
  if (tiled) {
    spec.tile_width = 16;
    spec.tile_height = 16;
  }
  if (bigtiff) spec.attribute("tiff:bigtiff", 1);
  std::vector<float> pixels(static_cast<std::size_t>(width) * height * channels);
  for (int r = 0; r < height; ++r)
    for (int c = 0; c < width; ++c)
      for (int b = 0; b < channels; ++b)
        pixels[(static_cast<std::size_t>(r) * width + c) * channels + b] = 1000.0f * (b + 1) + 10.0f * r + c;
  // Hand OIIO values of the target type so integers are not normalised.
  if (!out->open(path, spec)) return false;
  bool ok = false;
  if (type == OIIO::TypeDesc::FLOAT || type == OIIO::TypeDesc::DOUBLE) {
    ok = out->write_image(OIIO::TypeDesc::FLOAT, pixels.data());
  } else {
    std::vector<std::int32_t> ints(pixels.begin(), pixels.end());
    std::vector<unsigned char> raw(ints.size() * type.size());
    for (std::size_t i = 0; i < ints.size(); ++i) {
      if (type == OIIO::TypeDesc::INT16)
        reinterpret_cast<std::int16_t*>(raw.data())[i] = static_cast<std::int16_t>(ints[i]);
      else if (type == OIIO::TypeDesc::UINT16)
        reinterpret_cast<std::uint16_t*>(raw.data())[i] = static_cast<std::uint16_t>(ints[i]);
      else if (type == OIIO::TypeDesc::INT32)
        reinterpret_cast<std::int32_t*>(raw.data())[i] = ints[i];
      else if (type == OIIO::TypeDesc::INT8)
        reinterpret_cast<std::int8_t*>(raw.data())[i] = static_cast<std::int8_t>(ints[i] % 100);
      else if (type == OIIO::TypeDesc::UINT8)
        raw[i] = static_cast<unsigned char>(ints[i] % 200);
      else
        return false;
    }
    ok = out->write_image(type, raw.data());
  }
  return out->close() && ok;
}

}  // namespace horizon::testing
