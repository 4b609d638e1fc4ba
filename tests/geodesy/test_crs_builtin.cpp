// The CRSs of most DEMs are described without PROJ
// (core/src/geodesy/builtin_crs.hpp). These tests hold that description to
// PROJ's own: "EPSG:n" takes the built-in path, "epsg:n" (the same CRS
// spelled so the built-in path does not match it) goes through PROJ, and
// both must say and compute the same, for every built-in code. NAD83's go
// to WGS 84 through PROJ on both paths; their description and ground scale
// are the built-in path's own.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <optional>
#include <string>
#include <vector>

#include "horizon/geodesy/crs.hpp"

namespace horizon::geodesy {
namespace {

// The built-in transverse Mercator CRSs and their central meridians, from
// the EPSG dataset's names (zone z: 6 z - 183 degrees).
std::vector<std::pair<int, double>> transverse_mercator_codes() {
  std::vector<std::pair<int, double>> codes;
  const auto zones = [&](int first_code, int first_zone, int last_zone) {
    for (int zone = first_zone; zone <= last_zone; ++zone)
      codes.emplace_back(first_code + zone - first_zone, 6.0 * zone - 183.0);
  };
  zones(32601, 1, 60);              // WGS 84 / UTM zone 1N..60N
  zones(32701, 1, 60);              // WGS 84 / UTM zone 1S..60S
  zones(31965, 11, 22);             // SIRGAS 2000 / UTM zone 11N..22N
  zones(6210, 23, 24);              // SIRGAS 2000 / UTM zone 23N, 24N
  zones(31977, 17, 25);             // SIRGAS 2000 / UTM zone 17S..25S
  zones(5396, 26, 26);              // SIRGAS 2000 / UTM zone 26S
  zones(25828, 28, 37);             // ETRS89 / UTM zone 28N..37N
  zones(2133, 58, 60);              // NZGD2000 / UTM zone 58S..60S
  zones(5700, 1, 1);                // NZGD2000 / UTM zone 1S
  codes.emplace_back(2193, 173.0);  // NZGD2000 / New Zealand Transverse Mercator 2000
  zones(26901, 1, 23);              // NAD83 / UTM zone 1N..23N
  zones(9712, 24, 24);              // NAD83 / UTM zone 24N
  zones(3372, 59, 60);              // NAD83 / UTM zone 59N, 60N
  return codes;
}

// Geographic: WGS 84, SIRGAS 2000, ETRS89, NZGD2000, NAD83.
constexpr int kGeographicCodes[] = {4326, 4674, 4258, 4167, 4269};

std::vector<int> builtin_codes() {
  std::vector<int> codes(std::begin(kGeographicCodes), std::end(kGeographicCodes));
  codes.push_back(3857);
  for (const auto& [epsg, lon0] : transverse_mercator_codes()) codes.push_back(epsg);
  return codes;
}

struct Pair {
  Crs builtin, proj;
};

Pair pair_of(int epsg) {
  auto builtin = Crs::from_definition("EPSG:" + std::to_string(epsg));
  auto proj = Crs::from_definition("epsg:" + std::to_string(epsg));
  EXPECT_TRUE(builtin.ok()) << epsg;
  EXPECT_TRUE(proj.ok()) << epsg << ": " << (proj.ok() ? "" : proj.error().message);
  return Pair{builtin.value(), proj.value()};
}

// Both conversions of one position and the ground scale there agree (to
// 1e-6 m, 1e-11 degrees and `scale_tolerance` relative); false when PROJ
// refuses the position, as the built-in path must then too.
bool expect_same_at(const Pair& p, LonLat ll, double scale_tolerance) {
  const auto a = p.builtin.from_lonlat(ll);
  const auto b = p.proj.from_lonlat(ll);
  EXPECT_EQ(a.ok(), b.ok());
  if (!a.ok() || !b.ok()) return false;
  EXPECT_NEAR(a->x, b->x, 1e-6);
  EXPECT_NEAR(a->y, b->y, 1e-6);
  const auto la = p.builtin.to_lonlat(*a);
  const auto lb = p.proj.to_lonlat(*b);
  EXPECT_TRUE(la.ok());
  EXPECT_TRUE(lb.ok());
  if (!la.ok() || !lb.ok()) return false;
  EXPECT_NEAR(std::remainder(la->lon - lb->lon, 360.0), 0.0, 1e-11);
  EXPECT_NEAR(la->lat, lb->lat, 1e-11);
  const GroundScale sa = p.builtin.ground_scale(*a), sb = p.proj.ground_scale(*b);
  EXPECT_NEAR(sa.metres_per_x / sb.metres_per_x, 1.0, scale_tolerance);
  EXPECT_NEAR(sa.metres_per_y / sb.metres_per_y, 1.0, scale_tolerance);
  return true;
}

TEST(CrsBuiltin, DescribesEveryCodeAsProjDoes) {
  for (int epsg : builtin_codes()) {
    const Pair p = pair_of(epsg);
    SCOPED_TRACE(epsg);
    EXPECT_EQ(p.builtin.name(), p.proj.name());
    EXPECT_EQ(p.builtin.horizontal_name(), p.proj.horizontal_name());
    EXPECT_EQ(p.builtin.vertical_name(), p.proj.vertical_name());
    EXPECT_EQ(p.builtin.epsg(), p.proj.epsg());
    EXPECT_EQ(p.builtin.horizontal_epsg(), p.proj.horizontal_epsg());
    EXPECT_EQ(p.builtin.vertical_epsg(), p.proj.vertical_epsg());
    EXPECT_EQ(p.builtin.is_geographic(), p.proj.is_geographic());
    EXPECT_EQ(p.builtin.projection(), p.proj.projection());
    EXPECT_EQ(p.builtin.unit_name(), p.proj.unit_name());
    EXPECT_EQ(p.builtin.unit_size(), p.proj.unit_size());
    EXPECT_EQ(p.builtin.wkt(), p.proj.wkt());  // made through PROJ on first use
    EXPECT_FALSE(p.builtin.wkt().empty());
    EXPECT_TRUE(p.builtin.equivalent_to(p.proj));
  }
}

TEST(CrsBuiltin, TransverseMercatorConvertsAndScalesAsProjDoes) {
  // Positions across each zone and beyond it: up to 29 degrees of longitude
  // from the central meridian the built-in series answers, further PROJ.
  // On the GRS 1980 datums a series on WGS 84's ellipsoid would be ~0.1 mm
  // off, a hundred times the tolerance.
  const double lats[] = {-83.0, -60.0, -33.3, -1.0, 0.0, 0.5, 27.9, 47.0, 71.0, 84.0};
  const double offsets[] = {-29.0, -3.0, -0.4, 0.0, 1.7, 3.0, 8.0, 29.0, 31.0, 45.0};
  const auto codes = transverse_mercator_codes();
  ASSERT_EQ(codes.size(), 120u + 24u + 10u + 5u + 26u);
  int compared = 0;
  for (const auto& [epsg, lon0] : codes) {
    const Pair p = pair_of(epsg);
    for (double lat : lats)
      for (double offset : offsets) {
        double lon = lon0 + offset;
        lon -= 360.0 * std::floor((lon + 180.0) / 360.0);
        SCOPED_TRACE(std::to_string(epsg) + " lon " + std::to_string(lon) + " lat " + std::to_string(lat));
        // PROJ's scale comes from numerical derivatives (good to ~1e-10 near
        // the poles), the built-in one from the series' own k.
        compared += expect_same_at(p, {lon, lat}, 1e-9);
      }
  }
  EXPECT_GT(compared, static_cast<int>(codes.size()) * 80);  // nearly every position converts
}

// from_lonlat on both paths: both answer, with the same bits; the answer.
std::optional<XY> expect_same_from_lonlat(const Pair& p, LonLat ll) {
  const auto a = p.builtin.from_lonlat(ll);
  const auto b = p.proj.from_lonlat(ll);
  EXPECT_TRUE(a.ok()) << a.error().message;
  EXPECT_TRUE(b.ok()) << b.error().message;
  if (!a.ok() || !b.ok()) return std::nullopt;
  EXPECT_EQ(a->x, b->x);
  EXPECT_EQ(a->y, b->y);
  return *a;
}

void expect_geographic_as_proj(const Pair& p) {
  for (const LonLat ll : {LonLat{-121.76, 46.853}, LonLat{179.999, -89.0}, LonLat{-180.0, 0.0}})
    expect_same_from_lonlat(p, ll);
  for (const XY xy : {XY{-121.76, 46.853}, XY{190.0, 10.0}, XY{-540.0, -90.0}}) {
    const auto a = p.builtin.to_lonlat(xy);
    const auto b = p.proj.to_lonlat(xy);
    ASSERT_TRUE(a.ok());
    ASSERT_TRUE(b.ok());
    EXPECT_EQ(a->lon, b->lon);
    EXPECT_EQ(a->lat, b->lat);
    const GroundScale sa = p.builtin.ground_scale(xy), sb = p.proj.ground_scale(xy);
    EXPECT_EQ(sa.metres_per_x, sb.metres_per_x);
    EXPECT_EQ(sa.metres_per_y, sb.metres_per_y);
  }
  EXPECT_FALSE(p.builtin.to_lonlat({0.0, 91.0}).ok());
}

TEST(CrsBuiltin, GeographicConvertsAndScalesAsProjDoes) {
  // On each datum: PROJ takes SIRGAS 2000, ETRS89 and NZGD2000 to WGS 84 by
  // a null transformation (the identity), NAD83 by one it picks by place;
  // the ground scale of those four is GRS 1980's.
  for (const int epsg : kGeographicCodes) {
    SCOPED_TRACE(epsg);
    expect_geographic_as_proj(pair_of(epsg));
  }
}

TEST(CrsBuiltin, Nad83GoesToWgs84AsProjPicksByPlace) {
  // In Hawaii PROJ picks "NAD83 to WGS 84 (3)", a Helmert shift of ~0.5 m
  // (Indiana's "(1)" is null): the built-in description must not take the
  // numbers over unchanged.
  const LonLat honolulu{-157.8, 21.3};
  const auto xy = expect_same_from_lonlat(pair_of(4269), honolulu);
  ASSERT_TRUE(xy);
  EXPECT_GT(std::abs(xy->x - honolulu.lon) + std::abs(xy->y - honolulu.lat), 1e-6);
}

TEST(CrsBuiltin, RefusesWhatProjRefuses) {
  // 89 degrees from the central meridian, a pole, a NaN; far beyond the false easting.
  for (const auto& [epsg, lon0] : {std::pair{32633, 15.0}, std::pair{26915, -93.0}, std::pair{31985, -33.0},
                                   std::pair{25832, 9.0}, std::pair{2193, 173.0}}) {
    SCOPED_TRACE(epsg);
    const Pair p = pair_of(epsg);
    for (const LonLat bad : {LonLat{lon0 + 89.0, 10.0}, LonLat{0.0, 90.5}, LonLat{std::nan(""), 0.0}}) {
      const auto a = p.builtin.from_lonlat(bad);
      ASSERT_FALSE(a.ok());
      EXPECT_EQ(a.error().code, p.proj.from_lonlat(bad).error().code);
      EXPECT_NE(a.error().message.find(p.proj.name()), std::string::npos) << a.error().message;
    }
    const auto far = p.builtin.to_lonlat({5.0e7, 0.0});
    ASSERT_FALSE(far.ok());
    EXPECT_EQ(far.error().code, ErrorCode::kOutOfRange);
  }
}

TEST(CrsBuiltin, WebMercatorConvertsAndScalesAsProjDoes) {
  // Across the map's square and beyond its latitude limit (85.0511), where PROJ answers.
  const Pair p = pair_of(3857);
  int compared = 0;
  for (double lat : {-89.0, -85.0, -60.0, -12.5, 0.0, 0.001, 33.3, 46.853, 71.0, 85.05, 85.2, 89.5})
    for (double lon : {-180.0, -179.9, -121.76, -3.0, 0.0, 17.25, 138.73, 179.99}) {
      SCOPED_TRACE("lon " + std::to_string(lon) + " lat " + std::to_string(lat));
      // PROJ's numerical derivatives drift near the map's edge (4e-9 at 85 degrees).
      compared += expect_same_at(p, {lon, lat}, 1e-8);
    }
  EXPECT_GE(compared, 12 * 8 - 8);
  // The square's corner and beyond it.
  EXPECT_TRUE(p.builtin.to_lonlat({std::numbers::pi * 6378137.0, std::numbers::pi * 6378137.0}).ok());
  const auto beyond = p.builtin.to_lonlat({4.0e7, 0.0});
  const auto beyond_proj = p.proj.to_lonlat({4.0e7, 0.0});
  ASSERT_EQ(beyond.ok(), beyond_proj.ok());
  if (beyond.ok()) {
    EXPECT_EQ(beyond->lon, beyond_proj->lon);
  }
}

TEST(CrsBuiltin, OnlyTheExactSpellingIsBuiltIn) {
  // Codes next to the built-in ranges go to PROJ and are what PROJ says.
  auto zone61 = Crs::from_epsg(32661);  // UPS North, in PROJ's database
  ASSERT_TRUE(zone61.ok());
  EXPECT_EQ(zone61->projection(), "Polar Stereographic (variant A)");
  auto compound = Crs::from_definition("EPSG:32633+5773");
  ASSERT_TRUE(compound.ok());
  EXPECT_EQ(compound->horizontal_epsg(), 32633);
  EXPECT_EQ(compound->vertical_epsg(), 5773);
}

}  // namespace
}  // namespace horizon::geodesy
