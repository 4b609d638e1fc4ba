// qgis_style.cpp — QGIS layer style documents (qgis_style.hpp).
//
// The format is QGIS's own .qml (an XML document, DOCTYPE "qgis"), as QGIS
// 3.22 writes it from a raster layer's Symbology: <pipe> holds the
// <rasterrenderer> ("paletted" with a <colorPalette> of <paletteEntry>, or
// "singlebandpseudocolor" with a <rastershader><colorrampshader> of <item>s,
// colorRampType INTERPOLATED or DISCRETE), then the brightness/contrast,
// hue/saturation and resampler stages at their defaults. Resampling is
// nearest-neighbour: these are per-cell answers, not a surface.
#include "horizon/terrain/qgis_style.hpp"

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>

#include "atomic_file.hpp"

namespace horizon::terrain {
namespace {

std::string escaped(const std::string& s) {
  std::string out;
  for (char c : s) {
    switch (c) {
      case '&':
        out += "&amp;";
        break;
      case '<':
        out += "&lt;";
        break;
      case '>':
        out += "&gt;";
        break;
      case '"':
        out += "&quot;";
        break;
      default:
        out += c;
    }
  }
  return out;
}

std::string hex(const std::array<std::uint8_t, 3>& c) {
  char buf[8];
  std::snprintf(buf, sizeof buf, "#%02x%02x%02x", c[0], c[1], c[2]);
  return buf;
}

// The shortest plain decimal that reads back as `v` ("1", "0.5", "2000", "4371.25").
std::string number(double v) {
  char buf[64];
  for (int digits = 1; digits <= 17; ++digits) {
    std::snprintf(buf, sizeof buf, "%.*g", digits, v);
    if (std::strtod(buf, nullptr) == v && !std::strchr(buf, 'e')) return buf;
  }
  std::snprintf(buf, sizeof buf, "%.17g", v);
  return buf;
}

const char* kHead =
    "<!DOCTYPE qgis PUBLIC 'http://mrcc.com/qgis.dtd' 'SYSTEM'>\n"
    "<qgis version=\"3.22.16\" styleCategories=\"AllStyleCategories\">\n"
    "  <pipe>\n"
    "    <provider>\n"
    "      <resampling enabled=\"false\" zoomedInResamplingMethod=\"nearestNeighbour\" "
    "zoomedOutResamplingMethod=\"nearestNeighbour\" maxOversampling=\"2\"/>\n"
    "    </provider>\n";

const char* kMinMax =
    "      <rasterTransparency/>\n"
    "      <minMaxOrigin>\n"
    "        <limits>None</limits>\n"
    "        <extent>WholeRaster</extent>\n"
    "        <statAccuracy>Estimated</statAccuracy>\n"
    "        <cumulativeCutLower>0.02</cumulativeCutLower>\n"
    "        <cumulativeCutUpper>0.98</cumulativeCutUpper>\n"
    "        <stdDevFactor>2</stdDevFactor>\n"
    "      </minMaxOrigin>\n";

const char* kTail =
    "    <brightnesscontrast brightness=\"0\" contrast=\"0\" gamma=\"1\"/>\n"
    "    <huesaturation saturation=\"0\" grayscaleMode=\"0\" invertColors=\"0\" colorizeOn=\"0\" "
    "colorizeRed=\"255\" colorizeGreen=\"128\" colorizeBlue=\"128\" colorizeStrength=\"100\"/>\n"
    "    <rasterresampler maxOversampling=\"2\"/>\n"
    "    <resamplingStage>resamplingFilter</resamplingStage>\n"
    "  </pipe>\n"
    "  <blendMode>0</blendMode>\n"
    "</qgis>\n";

}  // namespace

std::string qml_paletted(std::span<const StyleEntry> entries) {
  std::string s = kHead;
  s += "    <rasterrenderer type=\"paletted\" band=\"1\" opacity=\"1\" alphaBand=\"-1\" nodataColor=\"\">\n";
  s += kMinMax;
  s += "      <colorPalette>\n";
  for (const StyleEntry& e : entries)
    s += "        <paletteEntry value=\"" + number(e.value) + "\" color=\"" + hex(e.colour) +
         "\" alpha=\"255\" label=\"" + escaped(e.label) + "\"/>\n";
  s += "      </colorPalette>\n";
  s += "    </rasterrenderer>\n";
  s += kTail;
  return s;
}

std::string qml_pseudocolor(std::span<const StyleEntry> entries, bool discrete, int label_precision) {
  const double lo = entries.empty() ? 0.0 : entries.front().value;
  const double hi = entries.empty() ? 0.0 : entries.back().value;
  std::string s = kHead;
  s += "    <rasterrenderer type=\"singlebandpseudocolor\" band=\"1\" opacity=\"1\" alphaBand=\"-1\" nodataColor=\"\" "
       "classificationMin=\"" +
       number(lo) + "\" classificationMax=\"" + number(hi) + "\">\n";
  s += kMinMax;
  s += "      <rastershader>\n";
  s += "        <colorrampshader colorRampType=\"" + std::string(discrete ? "DISCRETE" : "INTERPOLATED") +
       "\" classificationMode=\"1\" clip=\"0\" minimumValue=\"" + number(lo) + "\" maximumValue=\"" + number(hi) +
       "\" labelPrecision=\"" + std::to_string(label_precision) + "\">\n";
  for (const StyleEntry& e : entries)
    s += "          <item value=\"" + number(e.value) + "\" color=\"" + hex(e.colour) + "\" alpha=\"255\" label=\"" +
         escaped(e.label) + "\"/>\n";
  s += "        </colorrampshader>\n";
  s += "      </rastershader>\n";
  s += "    </rasterrenderer>\n";
  s += kTail;
  return s;
}

std::string qml_path_for(const std::string& raster_path) {
  return std::filesystem::path(raster_path).replace_extension(".qml").string();
}

namespace {

// `text` written into `file`'s temporary (created here).
Status write_temporary(detail::AtomicFile& file, const std::string& path, const std::string& text) {
  HORIZON_RETURN_IF_ERROR(file.create("style"));
  std::ofstream out(file.temp_path(), std::ios::binary | std::ios::trunc);
  out << text;
  out.flush();
  if (!out) return make_error(ErrorCode::kIoError, "style '" + path + "': cannot write the file", path);
  return Status::Ok();
}

}  // namespace

Status write_text_file(const std::string& path, const std::string& text) {
  detail::AtomicFile file(path);
  HORIZON_RETURN_IF_ERROR(write_temporary(file, path, text));
  return file.commit("style");
}

StagedTextFile::StagedTextFile() = default;
StagedTextFile::StagedTextFile(StagedTextFile&&) noexcept = default;
StagedTextFile& StagedTextFile::operator=(StagedTextFile&&) noexcept = default;
StagedTextFile::~StagedTextFile() = default;  // AtomicFile removes an uncommitted temporary

Result<StagedTextFile> StagedTextFile::stage(const std::string& path, const std::string& text) {
  StagedTextFile staged;
  staged.file_ = std::make_unique<detail::AtomicFile>(path);
  HORIZON_RETURN_IF_ERROR(write_temporary(*staged.file_, path, text));
  HORIZON_RETURN_IF_ERROR(staged.file_->flush("style"));
  return staged;
}

Status StagedTextFile::commit() {
  return file_->rename_into_place("style");
}

}  // namespace horizon::terrain
