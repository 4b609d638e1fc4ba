// A daemon serving DEMs in CRSs without an EPSG code or with a vertical part
// (made by GDAL at test time, gdal_crs_cases.hpp): `horizon info --server`
// says what embedded mode says, a viewshed's GeoTIFF is byte-identical to
// embedded mode's, and an observer the CRS cannot place is refused in the
// user's words with no server path in the message.
#include <gtest/gtest.h>

#include <algorithm>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "daemon_process.hpp"
#include "gdal_crs_cases.hpp"

namespace horizon::testing {
namespace {

using Json = nlohmann::json;

CommandResult horizon(const std::string& args) {
  return run_command(shell_quote(HORIZON_CLI_PATH) + " " + args);
}

Json json_of(const CommandResult& r) {
  const auto start = r.output.find('{');
  return start == std::string::npos ? Json() : Json::parse(r.output.substr(start), nullptr, false);
}

// The cases served: one per kind of CRS a code alone cannot give.
const std::vector<std::string> kServed = {"CustomLambertFeetTowgs84", "CustomAzimuthalEquidistant",
                                          "CompoundBritishGridOdnHeight", "CaliforniaUsFeet"};

class ServerCrs : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    if (!have_gdal()) return;
    data_ = new TempDir();
    DaemonOptions options;
    options.datasets.clear();
    for (const GdalCrsCase& c : gdal_crs_cases())
      if (std::find(kServed.begin(), kServed.end(), c.name) != kServed.end()) {
        std::string error;
        if (make_gdal_crs_file(c, data_->path(), &error).empty()) {
          setup_error_ = error;
          return;
        }
        options.datasets.emplace_back(c.name, c.name + ".tif");
      }
    options.data_root = data_->path();
    daemon_ = new DaemonProcess(options);
  }
  static void TearDownTestSuite() {
    delete daemon_;
    delete data_;
    daemon_ = nullptr;
    data_ = nullptr;
  }
  void SetUp() override {
    if (!have_gdal()) GTEST_SKIP() << "gdal-bin is not installed (scripts/setup.sh installs it)";
    ASSERT_TRUE(setup_error_.empty()) << setup_error_;
    ASSERT_TRUE(daemon_ && daemon_->ready()) << (daemon_ ? daemon_->error() : "no daemon");
  }
  std::string server() const { return " --server " + daemon_->address(); }
  static std::string file(const std::string& name) { return data_->file(name + ".tif"); }

  static TempDir* data_;
  static DaemonProcess* daemon_;
  static std::string setup_error_;
  TempDir dir_;
};

TempDir* ServerCrs::data_ = nullptr;
DaemonProcess* ServerCrs::daemon_ = nullptr;
std::string ServerCrs::setup_error_;

TEST_F(ServerCrs, InfoSaysWhatEmbeddedModeSays) {
  for (const std::string& name : kServed) {
    const auto local = horizon("info " + shell_quote(file(name)) + " --json");
    const auto remote = horizon("info " + name + server() + " --json");
    ASSERT_EQ(local.exit_code, 0) << local.output;
    ASSERT_EQ(remote.exit_code, 0) << remote.output;
    Json a = json_of(local), b = json_of(remote);
    a.erase("path");
    b.erase("path");
    b.erase("server");
    EXPECT_EQ(a, b) << name;
    ASSERT_TRUE(b["crs"].is_object()) << remote.output;

    // The text's CRS and heights lines too.
    const auto local_text = horizon("info " + shell_quote(file(name)));
    const auto remote_text = horizon("info " + name + server());
    const auto line = [](const std::string& text, const std::string& label) {
      const auto at = text.find(label);
      return at == std::string::npos ? std::string() : text.substr(at, text.find('\n', at) - at);
    };
    EXPECT_FALSE(line(remote_text.output, "CRS:").empty()) << remote_text.output;
    EXPECT_EQ(line(local_text.output, "CRS:"), line(remote_text.output, "CRS:"));
    EXPECT_EQ(line(local_text.output, "Heights:"), line(remote_text.output, "Heights:"));
  }
  const auto lambert = horizon("info CustomLambertFeetTowgs84" + server());
  EXPECT_NE(lambert.output.find("CRS:         user-defined, projected (Lambert Conic Conformal (2SP)), units: US "
                                "survey foot"),
            std::string::npos)
      << lambert.output;
  const auto compound = horizon("info CompoundBritishGridOdnHeight" + server());
  EXPECT_NE(compound.output.find("Heights:     EPSG:5701 (ODN height)"), std::string::npos) << compound.output;

  const auto list = horizon("datasets" + server() + " --json");
  ASSERT_EQ(list.exit_code, 0) << list.output;
  for (const Json& d : json_of(list)["datasets"])
    if (d["name"] == "CustomAzimuthalEquidistant") {
      EXPECT_TRUE(d["epsg"].is_null()) << d;
      EXPECT_EQ(d["crs_name"], "unknown") << d;
    }
}

TEST_F(ServerCrs, ViewshedGeoTiffIsByteIdenticalToEmbedded) {
  // An observer on Rainier's western flank, given in WGS 84 where
  // gdaltransform places the centre of the crop's cell (20, 20), whose
  // neighbours all hold data (the summit's voids are in the middle).
  for (const std::string& name : kServed) {
    const auto placed =
        run_command("echo 20.5 20.5 | gdaltransform -output_xy -t_srs EPSG:4326 " + shell_quote(file(name)));
    ASSERT_EQ(placed.exit_code, 0) << placed.output;
    std::string lon, lat;
    std::istringstream(placed.output) >> lon >> lat;
    const std::string eye = " --lat " + lat + " --lon " + lon + " --max-distance 1500";
    const std::string local = dir_.file(name + "_local.tif"), remote = dir_.file(name + "_remote.tif");
    const auto a = horizon("viewshed " + shell_quote(file(name)) + eye + " --full-read -o " + local + " --json");
    const auto b = horizon("viewshed " + name + server() + eye + " -o " + remote + " --json");
    ASSERT_EQ(a.exit_code, 0) << a.output;
    ASSERT_EQ(b.exit_code, 0) << b.output;
    EXPECT_TRUE(read_bytes(local) == read_bytes(remote)) << name;
    EXPECT_EQ(json_of(a)["visible_cells"], json_of(b)["visible_cells"]) << name;
    EXPECT_GT(json_of(b)["visible_cells"].get<long>(), 0) << b.output;
    EXPECT_EQ(json_of(b)["observer"]["col"], 20.0) << b.output;
    EXPECT_EQ(json_of(b)["observer"]["row"], 20.0) << b.output;
  }
}

TEST_F(ServerCrs, AnObserverTheCrsCannotPlaceIsRefusedWithoutServerPaths) {
  // The antipode of the azimuthal equidistant projection's centre (46.85 N,
  // 121.76 W) has no single image in it.
  const auto r =
      horizon("viewshed CustomAzimuthalEquidistant" + server() + " --lat -46.85 --lon 58.24 -o " + dir_.file("v.tif"));
  EXPECT_EQ(r.exit_code, 1) << r.output;
  EXPECT_NE(r.output.find("lon 58.24, lat -46.85"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("CustomAzimuthalEquidistant"), std::string::npos) << r.output;
  EXPECT_EQ(r.output.find(data_->path().string()), std::string::npos) << r.output;
}

}  // namespace
}  // namespace horizon::testing
