// `horizon viewshed` with the options a GIS analyst brings from gdal_viewshed
// and r.viewshed (viewshed_flags.hpp): gdal_viewshed's spellings, no limit as
// -md 0, GRASS's refraction coefficient, the field of view, the observer on
// its cell's value, and the GeoTIFF's format and creation options. Each is
// checked on the raster written, cell by cell, against what it must be.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "cli_run.hpp"
#include "horizon/terrain/dem_reader.hpp"
#include "horizon/visibility/many_observers.hpp"
#include "test_support.hpp"

namespace horizon::testing {
namespace {

namespace fs = std::filesystem;
using Json = nlohmann::json;

constexpr const char* kAndes = "ecuador_andes_utm17s_10m_383x415.tif";  // EPSG:32717, 10 m cells
constexpr double kX = 713900.0, kY = 9558950.0;                         // on a slope, off its cell's centre

std::vector<std::string> concat(std::vector<std::string> a, const std::vector<std::string>& b) {
  a.insert(a.end(), b.begin(), b.end());
  return a;
}

// `horizon viewshed` on the Andes crop with `flags`, writing `out`; the JSON summary.
Json viewshed(const std::vector<std::string>& flags, const std::string& out) {
  const auto r = horizon(concat(concat({"viewshed", bundled_dem(kAndes)}, flags), {"-o", out, "--json"}));
  EXPECT_EQ(r.exit_code, 0) << r.output;
  Json j = Json::parse(r.output, nullptr, false);
  EXPECT_FALSE(j.is_discarded()) << r.output;
  return j;
}

terrain::Dem read(const std::string& path) {
  auto dem = terrain::read_dem(path);
  EXPECT_TRUE(dem.ok()) << path << ": " << dem.error().message;
  return dem.ok() ? std::move(*dem) : terrain::Dem{};
}

// Same size, same georeference, the same value (NaN: no answer) in every cell.
void expect_same_cells(const terrain::Dem& a, const terrain::Dem& b, const std::string& what) {
  ASSERT_EQ(a.width(), b.width()) << what;
  ASSERT_EQ(a.height(), b.height()) << what;
  EXPECT_EQ(a.georef.transform.origin_x, b.georef.transform.origin_x) << what;
  EXPECT_EQ(a.georef.transform.origin_y, b.georef.transform.origin_y) << what;
  for (int r = 0; r < a.height(); ++r)
    for (int c = 0; c < a.width(); ++c) {
      const float va = a.elevation.at(c, r), vb = b.elevation.at(c, r);
      if (std::isnan(va) || std::isnan(vb)) {
        ASSERT_EQ(std::isnan(va), std::isnan(vb)) << what << " at " << c << "," << r;
      } else {
        ASSERT_EQ(va, vb) << what << " at " << c << "," << r;
      }
    }
}

// A cell centre of a written raster, relative to the observer: ground metres east and north.
struct Offset {
  double east, north;
  double distance() const { return std::hypot(east, north); }
  double azimuth() const {  // degrees clockwise from north, [0, 360)
    const double a = std::atan2(east, north) * 180.0 / M_PI;
    return a < 0 ? a + 360.0 : a;
  }
};
Offset offset(const terrain::Dem& raster, int c, int r) {
  const terrain::GeoTransform& t = raster.georef.transform;
  return {t.origin_x + (c + 0.5) * t.pixel_width - kX, t.origin_y + (r + 0.5) * t.pixel_height - kY};
}

std::uint64_t answered(const terrain::Dem& raster) {
  std::uint64_t n = 0;
  for (float v : raster.elevation.values()) n += !std::isnan(v);
  return n;
}

const std::vector<std::string> kEye = {"--observer", "713900,9558950"};

TEST(CliViewshedOptions, GdalViewshedsSpellingsAreTheLongFlags) {
  TempDir dir;
  const Json gdal = viewshed({"-ox", "713900", "-oy", "9558950", "-oz", "30", "-tz", "1.5", "-md", "1500", "-cc", "0.9",
                              "-b", "1", "-f", "GTiff", "-co", "COMPRESS=LZW"},
                             dir.file("gdal.tif"));
  const Json ours =
      viewshed({"--observer", "713900,9558950", "--height", "30", "--target-height", "1.5", "--max-distance", "1500",
                "--curvature", "0.9", "--band", "1", "--format", "GTiff", "--co", "COMPRESS=LZW"},
               dir.file("ours.tif"));
  EXPECT_EQ(gdal["options"], ours["options"]);
  EXPECT_EQ(gdal["options"]["height"], 30.0);
  EXPECT_EQ(gdal["options"]["max_distance"], 1500.0);
  EXPECT_EQ(gdal["visible_cells"], ours["visible_cells"]);
  const std::string bytes = read_bytes(dir.file("gdal.tif"));
  ASSERT_GT(bytes.size(), 1000u);
  EXPECT_TRUE(bytes == read_bytes(dir.file("ours.tif")));
  EXPECT_EQ(read(dir.file("gdal.tif")).format, "GeoTIFF UInt8 (LZW, tiled 256x256)");

  // A mistake is named as it was typed.
  const auto bad = horizon(
      {"viewshed", bundled_dem(kAndes), "-ox", "713900", "-oy", "9558950", "-md", "-5", "-o", dir.file("bad.tif")});
  EXPECT_EQ(bad.exit_code, 2);
  EXPECT_NE(bad.output.find("-md: expected metres >= 0, or 0 or 'none' for no limit, got '-5'"), std::string::npos)
      << bad.output;
  const auto half = horizon({"viewshed", bundled_dem(kAndes), "-ox", "713900", "-o", dir.file("half.tif")});
  EXPECT_EQ(half.exit_code, 2);
  EXPECT_NE(half.output.find("--observer-y: required with -ox"), std::string::npos) << half.output;
  EXPECT_FALSE(fs::exists(dir.file("bad.tif")) || fs::exists(dir.file("half.tif")));
}

// gdal_viewshed's -md 0 is no limit; so is "none"; both equal leaving it out.
TEST(CliViewshedOptions, MaxDistanceZeroOrNoneIsNoLimit) {
  TempDir dir;
  const Json all = viewshed(kEye, dir.file("all.tif"));
  EXPECT_TRUE(all["options"]["max_distance"].is_null());
  EXPECT_EQ(all["window"]["width"], 383);
  for (const char* none : {"0", "none"}) {
    const std::string out = dir.file(std::string(none) + ".tif");
    const Json j = viewshed(concat(kEye, {"--max-distance", none}), out);
    EXPECT_TRUE(j["options"]["max_distance"].is_null()) << none;
    EXPECT_EQ(j["visible_cells"], all["visible_cells"]) << none;
    EXPECT_TRUE(read_bytes(out) == read_bytes(dir.file("all.tif"))) << none;
  }
}

// --isa caps the kernels: each set this CPU has writes the same bytes, and
// the summary names the set that ran (a cap above the CPU's best runs its best).
TEST(CliViewshedOptions, IsaCapChangesTheKernelsNotTheRaster) {
  TempDir dir;
  const Json best = viewshed(kEye, dir.file("best.tif"));
  const std::string cpu = best["kernels"];
  for (const char* isa : {"scalar", "avx2", "avx512"}) {
    const std::string out = dir.file(std::string(isa) + ".tif");
    const Json j = viewshed(concat(kEye, {"--isa", isa}), out);
    const std::string want =
        std::string(isa) == "avx512" || (std::string(isa) == "avx2" && cpu == "scalar") ? cpu : isa;
    EXPECT_EQ(j["kernels"], want) << isa;
    EXPECT_EQ(j["visible_cells"], best["visible_cells"]) << isa;
    EXPECT_TRUE(read_bytes(out) == read_bytes(dir.file("best.tif"))) << isa;
  }
  const auto bad = horizon(
      {"viewshed", bundled_dem(kAndes), "--observer", "713900,9558950", "--isa", "sse2", "-o", dir.file("bad.tif")});
  EXPECT_EQ(bad.exit_code, 2);
  EXPECT_NE(bad.output.find("--isa: expected one of scalar, avx2, avx512, got 'sse2'"), std::string::npos)
      << bad.output;
  const auto remote = horizon({"viewshed", "rainier", "--server", "127.0.0.1:1", "--observer", "1,1", "--isa", "avx2",
                               "-o", dir.file("remote.tif")});
  EXPECT_EQ(remote.exit_code, 2);
  EXPECT_NE(remote.output.find("--isa caps this machine's kernels"), std::string::npos) << remote.output;
  EXPECT_FALSE(fs::exists(dir.file("bad.tif")));
}

// GRASS's refraction coefficient k is GDAL's curvature 1 - k; one of the two.
TEST(CliViewshedOptions, RefractionIsOneMinusCurvature) {
  TempDir dir;
  const Json grass = viewshed(concat(kEye, {"--refraction", "0.25", "--max-distance", "3000"}), dir.file("k.tif"));
  const Json gdal = viewshed(concat(kEye, {"--curvature", "0.75", "--max-distance", "3000"}), dir.file("c.tif"));
  EXPECT_EQ(grass["options"]["curvature"], 0.75);
  EXPECT_TRUE(read_bytes(dir.file("k.tif")) == read_bytes(dir.file("c.tif")));
  // A flat earth (refraction 1) sees at least what a curved one does, and more here.
  const Json flat = viewshed(concat(kEye, {"--refraction", "1", "--max-distance", "3000"}), dir.file("flat.tif"));
  EXPECT_EQ(flat["options"]["curvature"], 0.0);
  EXPECT_GE(flat["visible_cells"].get<int>(), gdal["visible_cells"].get<int>());

  const auto both = horizon(concat(concat({"viewshed", bundled_dem(kAndes)}, kEye),
                                   {"-cc", "0.8", "--refraction", "0.2", "-o", dir.file("both.tif")}));
  EXPECT_EQ(both.exit_code, 2);
  EXPECT_NE(both.output.find("-cc and --refraction both set the bending of sight lines"), std::string::npos)
      << both.output;
  const auto range = horizon(
      concat(concat({"viewshed", bundled_dem(kAndes)}, kEye), {"--refraction", "1.5", "-o", dir.file("r.tif")}));
  EXPECT_EQ(range.exit_code, 2);
  EXPECT_NE(range.output.find("--refraction: expected GRASS's refraction coefficient in [-1, 1]"), std::string::npos)
      << range.output;
}

// Cells outside the wedge, nearer than --min-distance or outside the pitches
// have no answer; every other cell has the answer it has without them (the
// view masks answers, not sight lines).
TEST(CliViewshedOptions, TheFieldOfViewAnswersOnlyItsCellsAndThoseAsWithoutIt) {
  TempDir dir;
  const Json all = viewshed(kEye, dir.file("all.tif"));
  const terrain::Dem full = read(dir.file("all.tif"));
  const Json j = viewshed(concat(kEye, {"--azimuth", "300,60", "--min-distance", "400"}), dir.file("view.tif"));
  EXPECT_EQ(j["options"]["field_of_view"]["azimuth"], Json::array({300.0, 60.0}));
  EXPECT_EQ(j["options"]["field_of_view"]["min_distance"], 400.0);
  const terrain::Dem view = read(dir.file("view.tif"));
  ASSERT_EQ(view.width(), full.width());
  ASSERT_EQ(view.height(), full.height());
  // The ground cell sizes may differ from the grid's by the projection's
  // scale (1e-3 at most in UTM): a margin of 2 m and half a degree.
  std::uint64_t inside = 0;
  for (int r = 0; r < view.height(); ++r)
    for (int c = 0; c < view.width(); ++c) {
      const Offset o = offset(view, c, r);
      const double az = o.azimuth();
      const bool in_wedge = az >= 300.5 || az <= 59.5, out_wedge = az <= 299.5 && az >= 60.5;
      const bool far = o.distance() >= 402.0, near = o.distance() <= 398.0;
      const float got = view.elevation.at(c, r), want = full.elevation.at(c, r);
      if (out_wedge || near) {
        ASSERT_TRUE(std::isnan(got)) << c << "," << r << " az " << az << " d " << o.distance();
      } else if (in_wedge && far) {
        if (std::isnan(want)) {
          ASSERT_TRUE(std::isnan(got)) << c << "," << r;
        } else {
          ASSERT_EQ(got, want) << c << "," << r;
          ++inside;
        }
      }
    }
  EXPECT_GT(inside, 10000u);
  EXPECT_LT(j["visible_cells"].get<int>(), all["visible_cells"].get<int>());
  EXPECT_GT(j["visible_cells"].get<int>(), 0);

  // Pitches: the ground's angle from the eye, curvature included (as GDAL's limits).
  const Json p = viewshed(concat(kEye, {"--pitch", "-10,2"}), dir.file("pitch.tif"));
  EXPECT_EQ(p["options"]["field_of_view"]["pitch"], Json::array({-10.0, 2.0}));
  const terrain::Dem pitch = read(dir.file("pitch.tif"));
  const terrain::Dem dem = read(bundled_dem(kAndes));
  const double eye = p["observer"]["elevation"].get<double>();
  const double col0 = std::round((pitch.georef.transform.origin_x - dem.georef.transform.origin_x) / 10.0);
  const double row0 = std::round((pitch.georef.transform.origin_y - dem.georef.transform.origin_y) / -10.0);
  std::uint64_t kept = 0, cut = 0;
  for (int r = 0; r < pitch.height(); ++r)
    for (int c = 0; c < pitch.width(); ++c) {
      const Offset o = offset(pitch, c, r);
      const double z = dem.elevation.at(c + static_cast<int>(col0), r + static_cast<int>(row0));
      if (std::isnan(z) || o.distance() < 30.0) continue;
      const double d = o.distance();
      const double angle = std::atan2(z - 0.85714 * d * d / (2 * 6371000.0) - eye, d) * 180.0 / M_PI;
      const float got = pitch.elevation.at(c, r), want = full.elevation.at(c, r);
      if (angle < -10.5 || angle > 2.5) {
        ASSERT_TRUE(std::isnan(got)) << c << "," << r << " pitch " << angle;
        ++cut;
      } else if (angle > -9.5 && angle < 1.5) {
        ASSERT_EQ(got, want) << c << "," << r << " pitch " << angle;
        ++kept;
      }
    }
  EXPECT_GT(kept, 1000u);
  EXPECT_GT(cut, 1000u);
  EXPECT_LT(answered(pitch), answered(full));
}

TEST(CliViewshedOptions, FieldOfViewMistakesAreNamed) {
  TempDir dir;
  struct Case {
    std::vector<std::string> flags;
    std::string message;
  };
  for (const Case& k : {Case{{"--azimuth", "10"}, "--azimuth: expected START,END (two numbers separated by a comma)"},
                        Case{{"--azimuth", "10,400"}, "--azimuth: must be degrees in [0, 360]"},
                        Case{{"--pitch", "5,-5"}, "--pitch: expected MIN,MAX with MIN <= MAX, got '5,-5'"},
                        Case{{"--pitch", "-95,0"}, "--pitch: must be degrees in [-90, 90]"},
                        Case{{"--min-distance", "-1"}, "--min-distance: expected a non-negative number"},
                        Case{{"-md", "300", "--min-distance", "300"}, "--min-distance: must be below -md (300 m)"}}) {
    const auto r =
        horizon(concat(concat(concat({"viewshed", bundled_dem(kAndes)}, kEye), k.flags), {"-o", dir.file("out.tif")}));
    EXPECT_EQ(r.exit_code, 2) << r.output;
    EXPECT_NE(r.output.find(k.message), std::string::npos) << r.output;
    EXPECT_FALSE(fs::exists(dir.file("out.tif")));
  }
}

// gdal_viewshed and r.viewshed stand the eye on its cell's value; by default
// Horizon's ground is bilinear between cell centres.
TEST(CliViewshedOptions, ObserverGroundCellIsTheCellsValue) {
  TempDir dir;
  const terrain::Dem dem = read(bundled_dem(kAndes));
  const terrain::GeoTransform& t = dem.georef.transform;
  const int col = static_cast<int>(std::floor((kX - t.origin_x) / t.pixel_width));
  const int row = static_cast<int>(std::floor((kY - t.origin_y) / t.pixel_height));
  const double cell = dem.elevation.at(col, row);
  const Json bilinear = viewshed(concat(kEye, {"-oz", "5", "-md", "2000"}), dir.file("b.tif"));
  const Json own = viewshed(concat(kEye, {"-oz", "5", "-md", "2000", "--observer-ground", "cell"}), dir.file("c.tif"));
  EXPECT_EQ(own["options"]["observer_ground"], "cell");
  EXPECT_EQ(bilinear["options"]["observer_ground"], "bilinear");
  EXPECT_DOUBLE_EQ(own["observer"]["ground"].get<double>(), cell);
  EXPECT_DOUBLE_EQ(own["observer"]["elevation"].get<double>(), cell + 5.0);
  // On this slope the two grounds are metres apart, and so are the answers.
  EXPECT_GT(std::abs(bilinear["observer"]["ground"].get<double>() - cell), 1.0);
  EXPECT_NE(own["visible_cells"], bilinear["visible_cells"]);
}

// --format COG and -co: GDAL's spellings, the same cells in another layout.
TEST(CliViewshedOptions, CogAndCreationOptionsLayOutTheSameCells) {
  TempDir dir;
  viewshed(kEye, dir.file("plain.tif"));
  const terrain::Dem plain = read(dir.file("plain.tif"));
  EXPECT_EQ(plain.format, "GeoTIFF UInt8 (deflate, tiled 256x256)");
  viewshed(concat(kEye, {"--format", "COG", "--co", "COMPRESS=LZW", "--co", "BLOCKSIZE=128"}), dir.file("cog.tif"));
  const terrain::Dem cog = read(dir.file("cog.tif"));
  EXPECT_EQ(cog.format, "GeoTIFF UInt8 (LZW, tiled 128x128)");
  expect_same_cells(plain, cog, "COG");
  viewshed(concat(kEye, {"-co", "TILED=NO", "-co", "COMPRESS=NONE", "--output", "ohf"}), dir.file("strips.tif"));
  viewshed(concat(kEye, {"--output", "ohf"}), dir.file("ohf.tif"));
  const terrain::Dem strips = read(dir.file("strips.tif"));
  EXPECT_EQ(strips.format, "GeoTIFF Float32 (uncompressed, striped)");
  expect_same_cells(read(dir.file("ohf.tif")), strips, "strips");

  if (run_command("command -v gdalinfo").exit_code == 0) {
    const auto info = run_command("gdalinfo " + shell_quote(dir.file("cog.tif")));
    EXPECT_NE(info.output.find("LAYOUT=COG"), std::string::npos) << info.output;
    EXPECT_NE(info.output.find("Overviews: 192x208, 96x104"), std::string::npos) << info.output;
  }

  struct Case {
    std::vector<std::string> flags;
    std::string message;
  };
  for (const Case& k :
       {Case{{"-co", "COMPRESS=JPEG"}, "-co COMPRESS=JPEG: not a lossless codec"},
        Case{{"-f", "COG", "-co", "TILED=NO"}, "-co TILED=NO: an option of the GTiff format, not of COG"},
        Case{{"--co", "ZLEVEL"}, "--co 'ZLEVEL': expected NAME=VALUE"},
        Case{{"-of", "PNG"}, "-of: expected GTiff or COG, got 'PNG'"}}) {
    const auto r =
        horizon(concat(concat(concat({"viewshed", bundled_dem(kAndes)}, kEye), k.flags), {"-o", dir.file("bad.tif")}));
    EXPECT_EQ(r.exit_code, 2) << r.output;
    EXPECT_NE(r.output.find(k.message), std::string::npos) << r.output;
    EXPECT_FALSE(fs::exists(dir.file("bad.tif")));
  }
}

// gdal_viewshed's four codes: -vv visible, -iv hidden, -ov out of range,
// -a_nodata the voids (and the file's nodata); the same cells as the default
// 1 / 0 / 255, voids told apart from out of range.
TEST(CliViewshedOptions, ValueCodesAreGdalViewshedsFour) {
  TempDir dir;
  const std::string everest = bundled_dem("everest_summit_voids_srtm3_300x300.tif");
  const std::vector<std::string> eye = {"viewshed", everest,      "--lat", "27.9881", "--lon",
                                        "86.925",   "--altitude", "8850",  "-md",     "8000"};
  ASSERT_EQ(horizon(concat(eye, {"-o", dir.file("default.tif")})).exit_code, 0);
  const auto r = horizon(
      concat(eye, {"-vv", "255", "-iv", "0", "-ov", "128", "-a_nodata", "64", "-o", dir.file("codes.tif"), "--json"}));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const Json j = Json::parse(r.output);
  EXPECT_EQ(j["codes"], Json({{"visible", 255}, {"hidden", 0}, {"out_of_range", 128}, {"nodata", 64}}));

  const terrain::Dem plain = read(dir.file("default.tif")), coded = read(dir.file("codes.tif"));
  const terrain::Dem dem = read(everest);
  EXPECT_EQ(coded.nodata, 64.0);
  ASSERT_EQ(coded.width(), plain.width());
  ASSERT_EQ(coded.height(), plain.height());
  const terrain::GeoTransform &t = coded.georef.transform, &d = dem.georef.transform;
  const int col0 = static_cast<int>(std::lround((t.origin_x - d.origin_x) / d.pixel_width));
  const int row0 = static_cast<int>(std::lround((t.origin_y - d.origin_y) / d.pixel_height));
  std::uint64_t voids = 0, out_of_range = 0, visible = 0, hidden = 0;
  for (int row = 0; row < coded.height(); ++row)
    for (int c = 0; c < coded.width(); ++c) {
      const float got = coded.elevation.at(c, row), was = plain.elevation.at(c, row);
      if (std::isnan(dem.elevation.at(c + col0, row + row0))) {
        ASSERT_TRUE(std::isnan(got)) << c << "," << row;  // 64, the nodata
        ++voids;
      } else if (std::isnan(was)) {
        ASSERT_EQ(got, 128.0f) << c << "," << row;
        ++out_of_range;
      } else {
        ASSERT_EQ(got, was == 1.0f ? 255.0f : 0.0f) << c << "," << row;
        ++(was == 1.0f ? visible : hidden);
      }
    }
  EXPECT_GT(voids, 1000u);
  EXPECT_GT(out_of_range, 1000u);
  EXPECT_EQ(visible, j["visible_cells"].get<std::uint64_t>());
  EXPECT_EQ(hidden, j["hidden_cells"].get<std::uint64_t>());
  // QGIS draws each code in its class's colour, the voids left transparent.
  const std::string qml = read_bytes(dir.file("codes.qml"));
  EXPECT_NE(qml.find("value=\"255\" color=\"#0072b2\" alpha=\"255\" label=\"visible\""), std::string::npos) << qml;
  EXPECT_NE(qml.find("value=\"0\" color=\"#d55e00\" alpha=\"255\" label=\"hidden\""), std::string::npos) << qml;
  EXPECT_NE(qml.find("value=\"128\""), std::string::npos) << qml;
  EXPECT_EQ(qml.find("value=\"64\""), std::string::npos) << qml;

  // r.viewshed -b: 1 visible, 0 hidden or out of range, voids no data.
  ASSERT_EQ(horizon(concat(eye, {"--output", "boolean", "-o", dir.file("boolean.tif")})).exit_code, 0);
  const terrain::Dem boolean = read(dir.file("boolean.tif"));
  for (int row = 0; row < boolean.height(); ++row)
    for (int c = 0; c < boolean.width(); ++c) {
      const float got = boolean.elevation.at(c, row), was = plain.elevation.at(c, row);
      if (std::isnan(dem.elevation.at(c + col0, row + row0)))
        ASSERT_TRUE(std::isnan(got)) << c << "," << row;
      else
        ASSERT_EQ(got, was == 1.0f ? 1.0f : 0.0f) << c << "," << row;
    }

  struct Case {
    std::vector<std::string> flags;
    std::string message;
  };
  for (const Case& k : {Case{{"-vv", "256"}, "-vv: expected a code, a whole number in [0, 255], got '256'"},
                        Case{{"-iv", "1.5"}, "-iv: expected a code"},
                        Case{{"-vv", "7", "-a_nodata", "7"}, "-vv: 7 is also the nodata value"},
                        Case{{"-vv", "255"},
                             "-vv: 255 is also the nodata code (255 by default); give "
                             "--output-nodata (-a_nodata) another one"},
                        Case{{"-vv", "0"}, "-vv: 0 is also the hidden value"},
                        Case{{"--output", "boolean", "-ov", "3"}, "-ov: codes only the visible raster"},
                        Case{{"-om", "GROUND", "-a_nodata", "low"}, "-a_nodata: expected a float32 value or 'nan'"},
                        Case{{"-om", "FAST"}, "-om: expected one of visible, boolean"}}) {
    const auto bad = horizon(concat(concat(eye, k.flags), {"-o", dir.file("bad.tif")}));
    EXPECT_EQ(bad.exit_code, 2) << bad.output;
    EXPECT_NE(bad.output.find(k.message), std::string::npos) << bad.output;
    EXPECT_FALSE(fs::exists(dir.file("bad.tif")));
  }
}

// r.viewshed's rasters, by their definitions: the elevation difference is
// each visible cell's ground minus the eye, the vertical angle
// 90 + atan2(ground + target - curvature drop - eye, distance); NaN (or
// -a_nodata) elsewhere. gdal_viewshed's -om DEM and GROUND are the OHF and
// the minimum target height.
TEST(CliViewshedOptions, RViewshedsRastersByTheirDefinitions) {
  TempDir dir;
  const std::vector<std::string> flags = concat(kEye, {"-oz", "10", "-tz", "2", "-md", "2000"});
  const Json j = viewshed(concat(flags, {"--output", "elevation-difference"}), dir.file("e.tif"));
  EXPECT_EQ(j["output_kind"], "elevation-difference");
  EXPECT_TRUE(j["codes"].is_null());
  viewshed(concat(flags, {"--output", "vertical-angle", "-a_nodata", "-9999"}), dir.file("a.tif"));
  viewshed(flags, dir.file("v.tif"));
  const terrain::Dem difference = read(dir.file("e.tif")), angle = read(dir.file("a.tif")),
                     seen = read(dir.file("v.tif"));
  const terrain::Dem dem = read(bundled_dem(kAndes));
  EXPECT_EQ(angle.nodata, -9999.0);
  const double eye = j["observer"]["elevation"].get<double>();
  const terrain::GeoTransform &t = seen.georef.transform, &d = dem.georef.transform;
  const int col0 = static_cast<int>(std::lround((t.origin_x - d.origin_x) / d.pixel_width));
  const int row0 = static_cast<int>(std::lround((t.origin_y - d.origin_y) / d.pixel_height));
  std::uint64_t visible = 0;
  for (int row = 0; row < seen.height(); ++row)
    for (int c = 0; c < seen.width(); ++c) {
      const float e = difference.elevation.at(c, row), a = angle.elevation.at(c, row);
      if (seen.elevation.at(c, row) != 1.0f) {
        ASSERT_TRUE(std::isnan(e) && std::isnan(a)) << c << "," << row;
        continue;
      }
      ++visible;
      const double z = dem.elevation.at(c + col0, row + row0);
      ASSERT_NEAR(e, z - eye, 1e-3) << c << "," << row;
      const Offset o = offset(seen, c, row);
      const double dist = o.distance();
      if (dist < 15.0) continue;  // the eye's own cell: 180 by r.viewshed's rule
      const double drop = 0.85714 * dist * dist / (2 * 6371000.0);
      ASSERT_NEAR(a, 90.0 + std::atan2(z + 2.0 - drop - eye, dist) * 180.0 / M_PI, 0.1) << c << "," << row;
    }
  EXPECT_EQ(visible, j["visible_cells"].get<std::uint64_t>());
  EXPECT_GT(visible, 1000u);

  // -om NORMAL, DEM and GROUND: gdal_viewshed's names for three of ours.
  for (const auto& [gdal, ours] : {std::pair{"NORMAL", "visible"}, {"DEM", "ohf"}, {"GROUND", "min-target-height"}}) {
    const Json g = viewshed(concat(flags, {"-om", gdal}), dir.file("g.tif"));
    const Json o = viewshed(concat(flags, {"--output", ours}), dir.file("o.tif"));
    EXPECT_EQ(g["output_kind"], ours);
    EXPECT_TRUE(read_bytes(dir.file("g.tif")) == read_bytes(dir.file("o.tif"))) << gdal;
  }
}

// The peer, given the same command line: gdal_viewshed's codes and cells.
// Both stand the eye on its cell's value; the answers are the same where
// both answer but for a few cells along sight lines that graze the terrain.
TEST(CliViewshedOptions, AgreesWithGdalViewshedOnTheSameCommandLine) {
  if (run_command("command -v gdal_viewshed").exit_code != 0) GTEST_SKIP() << "gdal_viewshed not installed";
  TempDir dir;
  const std::vector<std::string> flags = {"-ox", "713900", "-oy",  "9558950", "-oz",       "10",  "-tz",
                                          "1.5", "-md",    "2000", "-cc",     "0.85714",   "-vv", "255",
                                          "-iv", "0",      "-ov",  "128",     "-a_nodata", "64"};
  std::string command = "gdal_viewshed -q";
  for (const std::string& f : concat(flags, {bundled_dem(kAndes), dir.file("g.tif")})) {
    command += ' ';  // (one += at a time: GCC 12 sees a false overlap in " " + std::string)
    command += shell_quote(f);
  }
  const auto peer = run_command(command);
  ASSERT_EQ(peer.exit_code, 0) << peer.output;
  viewshed(concat(flags, {"--observer-ground", "cell", "--algorithm", "exact"}), dir.file("h.tif"));
  const terrain::Dem g = read(dir.file("g.tif")), h = read(dir.file("h.tif"));
  EXPECT_EQ(g.nodata, 64.0);
  EXPECT_EQ(h.nodata, 64.0);
  const terrain::GeoTransform &tg = g.georef.transform, &th = h.georef.transform;
  const int dc = static_cast<int>(std::lround((th.origin_x - tg.origin_x) / tg.pixel_width));
  const int dr = static_cast<int>(std::lround((th.origin_y - tg.origin_y) / tg.pixel_height));
  std::uint64_t both = 0, agree = 0, compared = 0, range_differs = 0;
  for (int row = 0; row < h.height(); ++row)
    for (int c = 0; c < h.width(); ++c) {
      if (c + dc < 0 || c + dc >= g.width() || row + dr < 0 || row + dr >= g.height()) continue;
      const float a = h.elevation.at(c, row), b = g.elevation.at(c + dc, row + dr);
      ++compared;
      for (float v : {a, b}) ASSERT_TRUE(std::isnan(v) || v == 255.0f || v == 0.0f || v == 128.0f) << v;
      if ((a == 128.0f) != (b == 128.0f) && !std::isnan(a)) ++range_differs;
      if ((a == 255.0f || a == 0.0f) && (b == 255.0f || b == 0.0f)) {
        ++both;
        agree += a == b;
      }
    }
  EXPECT_GT(compared, 150000u);
  EXPECT_GT(both, 100000u);
  EXPECT_GE(static_cast<double>(agree), 0.99 * static_cast<double>(both)) << agree << " of " << both;
  // The reach's edge: GDAL measures it to the cell's centre as we do, in the grid's metres.
  EXPECT_LE(static_cast<double>(range_differs), 0.005 * static_cast<double>(compared)) << range_differs;
}

// The other peer, GRASS r.viewshed, on the same DEM and eye (-c -r: its
// curvature and refraction; observer_elevation on the cell's value), for
// the rasters it has: the boolean form (-b), a field of view, the vertical
// angle and the elevation difference (-e). Its direction_range counts
// degrees counter-clockwise from east, so its 30,150 is --azimuth 300,60.
// Measured 2026-12-05: the booleans agree on 99.75 % (all round) and
// 99.87 % (the wedge) of the cells, the angles within 0.5 degrees on
// 98.5 % of the cells both see; GRASS 8.2's -e is ours less the
// observer's height once more (elevation_difference_raster's note).
TEST(CliViewshedOptions, AgreesWithRViewshedOnItsRasters) {
  if (run_command("command -v grass").exit_code != 0) GTEST_SKIP() << "GRASS not installed";
  TempDir dir;
  const std::string dem = bundled_dem(kAndes);
  std::ofstream(dir.file("grass.sh"))
      << "set -e\n"
      << "r.in.gdal -o input=" << shell_quote(dem) << " output=dem --quiet --overwrite\n"
      << "g.region raster=dem\n"
      << "v() { r.viewshed -c -r refraction_coeff=0.14286 input=dem coordinates=713900,9558950 "
         "observer_elevation=10 target_elevation=2 max_distance=2000 --quiet --overwrite \"$@\"; }\n"
      << "v output=angle\nv -e output=difference\nv -b output=all\nv -b output=wedge direction_range=30,150\n"
      << "for m in angle difference all wedge; do r.out.gdal -f input=$m output=" << shell_quote(dir.file("grass_"))
      << "$m.tif type=Float32 nodata=-9999 --quiet --overwrite; done\n";
  const auto grass = run_command("grass --tmp-location " + shell_quote(dem) + " --exec bash " +
                                 shell_quote(dir.file("grass.sh")) + " 2>&1");
  ASSERT_EQ(grass.exit_code, 0) << grass.output;

  const std::vector<std::string> flags = {
      "-ox",  "713900",       "-oy",     "9558950",           "-oz",  "10",          "-tz",  "2", "-md",
      "2000", "--refraction", "0.14286", "--observer-ground", "cell", "--algorithm", "exact"};
  viewshed(concat(flags, {"--output", "boolean"}), dir.file("all.tif"));
  viewshed(concat(flags, {"--output", "boolean", "--azimuth", "300,60"}), dir.file("wedge.tif"));
  viewshed(concat(flags, {"--output", "vertical-angle"}), dir.file("angle.tif"));
  viewshed(concat(flags, {"--output", "elevation-difference"}), dir.file("difference.tif"));

  // Each of ours against GRASS's over our window (GRASS writes the whole DEM).
  struct Tally {
    std::uint64_t compared = 0, same = 0, both = 0, close = 0, one = 0;
  };
  const auto tally = [&](const std::string& name, double tolerance, double shift) {
    const terrain::Dem ours = read(dir.file(name + ".tif")), theirs = read(dir.file("grass_" + name + ".tif"));
    const terrain::GeoTransform &to = ours.georef.transform, &tt = theirs.georef.transform;
    const int dc = static_cast<int>(std::lround((to.origin_x - tt.origin_x) / tt.pixel_width));
    const int dr = static_cast<int>(std::lround((to.origin_y - tt.origin_y) / tt.pixel_height));
    Tally t;
    for (int row = 0; row < ours.height(); ++row)
      for (int c = 0; c < ours.width(); ++c) {
        if (c + dc < 0 || c + dc >= theirs.width() || row + dr < 0 || row + dr >= theirs.height()) continue;
        const float a = ours.elevation.at(c, row), b = theirs.elevation.at(c + dc, row + dr);
        ++t.compared;
        t.same += a == b || (std::isnan(a) && std::isnan(b));  // voids: nodata in both
        if (std::isnan(a) != std::isnan(b)) ++t.one;
        if (std::isnan(a) || std::isnan(b)) continue;
        ++t.both;
        t.close += std::abs(a - shift - b) <= tolerance;
      }
    return t;
  };
  for (const char* name : {"all", "wedge"}) {
    const Tally t = tally(name, 0.0, 0.0);
    EXPECT_GT(t.compared, 150000u) << name;
    EXPECT_GE(static_cast<double>(t.same), 0.995 * static_cast<double>(t.compared)) << name << ": " << t.same;
  }
  const Tally angle = tally("angle", 0.5, 0.0);
  EXPECT_GT(angle.both, 15000u);
  EXPECT_GE(static_cast<double>(angle.close), 0.97 * static_cast<double>(angle.both)) << angle.close;
  EXPECT_LE(static_cast<double>(angle.one), 0.03 * static_cast<double>(angle.both)) << angle.one;
  const Tally difference = tally("difference", 1e-3, 10.0);
  EXPECT_EQ(difference.both, angle.both);
  EXPECT_EQ(difference.close, difference.both);
}

// Many observers take the same flags: each site on its cell's value, each
// viewshed in the field of view, the count in a COG; the engine's answer.
TEST(CliViewshedOptions, ManyObserversTakeTheSharedFlags) {
  TempDir dir;
  const auto r = horizon({"viewshed",
                          bundled_dem(kAndes),
                          "--observer",
                          "713900,9558950",
                          "--observer",
                          "713200,9559800",
                          "-oz",
                          "10",
                          "-md",
                          "1500",
                          "--azimuth",
                          "90,270",
                          "--observer-ground",
                          "cell",
                          "--refraction",
                          "0.2",
                          "-f",
                          "COG",
                          "-o",
                          dir.file("count.tif"),
                          "--json"});
  ASSERT_EQ(r.exit_code, 0) << r.output;

  const terrain::Dem dem = read(bundled_dem(kAndes));
  visibility::ManyObserversOptions options;
  options.viewshed.max_distance = 1500;
  options.viewshed.curvature_coefficient = 0.8;
  options.viewshed.field_of_view.azimuth_start = 90;
  options.viewshed.field_of_view.azimuth_end = 270;
  std::vector<visibility::ObserverSite> sites(2);
  sites[0].point.x = 713900;
  sites[0].point.y = 9558950;
  sites[1].point.x = 713200;
  sites[1].point.y = 9559800;
  for (visibility::ObserverSite& s : sites) {
    s.point.height = 10;
    s.point.ground = geodesy::GroundSample::kCell;
  }
  auto plan = visibility::plan_many_observers(dem, sites, options);
  ASSERT_TRUE(plan.ok()) << plan.error().message;
  auto want = visibility::compute_many_observers(dem, *plan);
  ASSERT_TRUE(want.ok()) << want.error().message;

  const terrain::Dem count = read(dir.file("count.tif"));
  EXPECT_EQ(count.format, "GeoTIFF UInt32 (deflate, tiled 512x512)");
  ASSERT_EQ(count.width(), want->window.width());
  ASSERT_EQ(count.height(), want->window.height());
  std::uint64_t seen = 0;
  for (int row = 0; row < count.height(); ++row)
    for (int c = 0; c < count.width(); ++c) {
      const float got = count.elevation.at(c, row);
      if (!want->answered.at(c, row)) {
        ASSERT_TRUE(std::isnan(got)) << c << "," << row;
      } else {
        ASSERT_EQ(got, static_cast<float>(want->count.at(c, row))) << c << "," << row;
        seen += want->count.at(c, row) > 0;
      }
    }
  EXPECT_GT(seen, 1000u);
  // Nothing north of both observers is answered: the view looks south.
  EXPECT_TRUE(std::isnan(count.elevation.at(count.width() / 2, 0)));

  const auto one = horizon({"viewshed", bundled_dem(kAndes), "--observer", "713900,9558950", "--observer",
                            "713200,9559800", "-ox", "713900", "-oy", "9558950", "-o", dir.file("x.tif")});
  EXPECT_EQ(one.exit_code, 2);
  EXPECT_NE(one.output.find("-ox: places one observer"), std::string::npos) << one.output;
}

}  // namespace
}  // namespace horizon::testing
