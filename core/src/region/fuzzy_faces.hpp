// region/fuzzy_faces.hpp — the always-hidden half of from-region visibility:
// the fuzzy array of one cube face and the sweep of its walls (the rule is
// in horizon/region/region.hpp).
//
// Face frame. A face looks along one grid axis, towards growing or shrinking
// columns (east, west) or rows (south, north). In its frame, u is the grid
// index along the face axis counted outward (u = col, W - 1 - col, row or
// H - 1 - row), v the lateral grid index (row or col); walls sit at integer
// u, their nodes at integer v. Metres: p = u * axial_metres, l = v * lateral_metres.
#pragma once

#include <cstdint>
#include <functional>
#include <vector>

#include "horizon/region/region.hpp"
#include "horizon/terrain/height_view.hpp"

namespace horizon::region {

enum class Face : std::uint8_t { kEast = 0, kWest = 1, kSouth = 2, kNorth = 3 };
inline constexpr int kFaceCount = 4;

// A rectangle of points at one height, in continuous grid coordinates: a
// cell's target (a degenerate rectangle) or the top of a box over the cell
// centres it covers.
struct FaceItem {
  double col_min = 0.0, col_max = 0.0, row_min = 0.0, row_max = 0.0;
  double z = 0.0;
};

// Where an item falls on a face.
struct FaceFit {
  int column_lo = 0, column_hi = 0;  // fuzzy-array columns its directions from the region span
  double slope_max = 0.0;            // the steepest b = dz/dp of those directions
  int wall_limit = 0;                // walls 0 .. wall_limit - 1 lie before it
  double spread = 0.0;               // max |a| of its directions (smaller fits the face better)
  double slope_slack = 0.0;          // how far a cover must exceed slope_max (rounding of R3's answer)
};

class FaceGeometry {
 public:
  FaceGeometry(Face face, const RegionFrame& frame, int dem_width, int dem_height, int resolution);

  Face face() const { return face_; }
  int wall_count() const { return walls_; }
  int lateral_count() const { return lateral_; }
  int resolution() const { return resolution_; }
  // The first wall strictly beyond the region along the face axis.
  int first_wall() const { return first_wall_; }
  // DEM (col, row) of node v of wall w.
  int node_col(int w, int v) const;
  int node_row(int w, int v) const;
  // The wall on which DEM cell (col, row) lies.
  int wall_of(int col, int row) const;

  // The item's columns, slopes and walls on this face; false when some of its
  // directions from the region leave the face's span (or run along p <= 0).
  bool fit(const FaceItem& item, FaceFit& out) const;

  // cover(c, w) for every column c of wall w, max-ed into `cover`
  // (resolution values); `nodes` holds the wall's lateral_count() heights
  // (-inf: covers nothing); `deque` is scratch of lateral_count() entries.
  // Returns the nodes the sliding minimum took in.
  std::uint64_t add_wall(int w, const std::vector<float>& nodes, std::vector<int>& deque,
                         std::vector<double>& cover) const;

 private:
  double u_of(double col, double row) const;
  double v_of(double col, double row) const;

  Face face_;
  int walls_ = 0, lateral_ = 0, resolution_ = 0;
  double axial_m_ = 1.0, lateral_m_ = 1.0;
  double u0_ = 0.0, u1_ = 0.0, v0_ = 0.0, v1_ = 0.0;  // region, face grid units (u1 >= u0)
  double z0_ = 0.0, z1_ = 0.0;
  double column_width_ = 0.0;
  int first_wall_ = 0;
  int dem_w_ = 0, dem_h_ = 0;
};

// True when every point of the item is hidden from every viewpoint by the
// cover of the walls before it: min of cover over the fit's columns > slope_max.
// rows > 0: as the seed's fuzzy array of `rows` slope rows over [-1, 1]
// (RegionOptions::fuzzy_rows): the rows up to the one holding slope_max lie
// wholly below that min.
bool covered(const FaceFit& fit, const std::vector<double>& cover, int rows = 0);

// Sweeps one face's walls outward from the region, up to wall_end
// (exclusive, at most wall_count()). Before adding wall w (first_wall() <= w
// < wall_end) and once after the last (w = wall_end), calls test(w, cover):
// cover then holds walls first_wall() .. w - 1, what an item with
// wall_limit == w may use. `terrain` is the DEM under the request's void
// policy. Polls `control` every 64 walls; returns its error.
Status sweep_face(const FaceGeometry& geometry, const terrain::HeightView& terrain, int wall_end,
                  const RunControl* control, const std::function<void(int, const std::vector<double>&)>& test,
                  RegionStats& stats);

}  // namespace horizon::region
