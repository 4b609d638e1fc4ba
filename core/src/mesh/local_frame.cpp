#include "horizon/mesh/local_frame.hpp"

#include <GeographicLib/LocalCartesian.hpp>

#include "horizon/geodesy/crs.hpp"

namespace horizon::mesh {

LocalFrame::LocalFrame() = default;
LocalFrame::~LocalFrame() = default;
LocalFrame::LocalFrame(LocalFrame&&) noexcept = default;
LocalFrame& LocalFrame::operator=(LocalFrame&&) noexcept = default;

Result<LocalFrame> LocalFrame::for_dem(const terrain::Dem& dem) {
  LocalFrame frame;
  if (!dem.georef.has_crs()) return frame;
  auto crs = geodesy::Crs::of(dem.georef);
  if (!crs.ok()) return crs.error();
  if (!crs->is_geographic()) return frame;
  const terrain::GeoTransform& t = dem.georef.transform;
  const double lon = t.x_at((dem.width() - 1) / 2.0), lat = t.y_at((dem.height() - 1) / 2.0);
  frame.tangent_ = std::make_unique<GeographicLib::LocalCartesian>(lat, lon, 0.0);
  return frame;
}

TinVertex LocalFrame::to_local(const TinVertex& p) const {
  if (!tangent_) return p;
  double x = 0, y = 0, up = 0;
  tangent_->Forward(p.y, p.x, 0.0, x, y, up);
  return {x, y, p.z};
}

TinVertex LocalFrame::to_crs(const TinVertex& p) const {
  if (!tangent_) return p;
  // (x, y) was made by Forward at height 0, which put the point a little
  // below the tangent plane (up < 0). Find that up: start from the
  // sphere's drop and correct by the height Reverse reports; three rounds
  // reach a nanometre.
  double up = -(p.x * p.x + p.y * p.y) / (2 * 6371008.8);
  double lat = 0, lon = 0, h = 0;
  for (int round = 0; round < 3; ++round) {
    tangent_->Reverse(p.x, p.y, up, lat, lon, h);
    up -= h;
  }
  return {lon, lat, p.z};
}

void LocalFrame::to_local(Tin& tin) const {
  if (!tangent_) return;
  for (TinVertex& v : tin.vertices) v = to_local(v);
}

}  // namespace horizon::mesh
