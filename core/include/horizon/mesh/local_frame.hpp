// horizon/mesh/local_frame.hpp — the metric frame a TIN's horizons are
// computed in.
//
// Horizons compare slopes, so x and y must be metres like z. A projected
// DEM's CRS is used as it is (its units are taken to be metres). A
// geographic DEM's (longitude, latitude) are mapped to a local east-north
// frame in metres, tangent to the WGS 84 ellipsoid at the DEM's centre
// (GeographicLib's LocalCartesian, at height 0); heights stay as they
// are. Over a DEM a few hundred kilometres across the mapping's scale
// error stays under a tenth of a percent; the Earth's curvature is not
// modelled, which makes the cull err towards "visible" (a camera and a
// target both see less over a curved Earth).
#pragma once

#include <memory>

#include "horizon/common/error.hpp"
#include "horizon/mesh/tin.hpp"
#include "horizon/terrain/dem.hpp"

namespace GeographicLib {
class LocalCartesian;
}

namespace horizon::mesh {

class LocalFrame {
 public:
  // The frame for `dem`: the identity for a projected CRS or none, the
  // local tangent frame for a geographic one. kUnsupported when the CRS
  // cannot be read.
  static Result<LocalFrame> for_dem(const terrain::Dem& dem);

  LocalFrame();
  ~LocalFrame();
  LocalFrame(LocalFrame&&) noexcept;
  LocalFrame& operator=(LocalFrame&&) noexcept;

  bool geographic() const { return tangent_ != nullptr; }
  // A point of the DEM's CRS (x = longitude, y = latitude when
  // geographic) in the frame, and back.
  TinVertex to_local(const TinVertex& p) const;
  TinVertex to_crs(const TinVertex& p) const;
  void to_local(Tin& tin) const;

 private:
  std::unique_ptr<GeographicLib::LocalCartesian> tangent_;
};

}  // namespace horizon::mesh
