// horizon/visibility/field_of_view.hpp — the part of its surroundings an
// observer looks at: a wedge of azimuths, a ring of distances and a band of
// vertical angles, as gdal_viewshed (3.10 and later) and GRASS r.viewshed
// (direction_range) offer.
//
// A cell outside the field of view gets no answer, as one beyond max_distance
// does: it is "out of range" in every raster (the visible raster's
// out-of-range code, NaN in the float rasters). The field of view masks the
// answers only; it changes no sight line: terrain nearer than min_distance,
// or outside the wedge, still hides what lies behind it. So the masks are
// applied once, after any algorithm and on either backend (CPU or GL), to the
// OHF every raster derives from (viewshed.hpp), and the rasters still never
// disagree.
//
// Geometry, for a cell centre at ground offset (east, north) metres from the
// eye (ViewFrame's metric cell sizes):
//   azimuth  atan2(east, north), degrees clockwise from grid north (the
//            raster's up; true north on a geographic DEM)
//   distance hypot(east, north)
//   pitch    atan2(z - curvature * distance^2 - eye, distance), degrees above
//            the horizontal, z the cell's ground (voids filled as the options
//            say): the cell's ground as the eye sees it, as GDAL's pitch
//            limits take it. Not the target height: the band is a property
//            of the terrain, and the OHF (which has no target height) can
//            carry it.
// A cell whose centre is the eye's own position has no azimuth (it is in
// every wedge) and a pitch of -90, 0 or +90 as its ground is below, at or
// above the eye.
#pragma once

#include "horizon/common/error.hpp"
#include "horizon/terrain/grid.hpp"

namespace horizon::visibility {

struct ViewFrame;

struct FieldOfView {
  // The view spans clockwise from azimuth_start to azimuth_end, degrees in
  // [0, 360], both ends included: 300, 60 is a 120-degree view centred on
  // north. Equal ends (modulo 360: 0, 0 by default, or 0, 360) leave every
  // direction in view, as GDAL does.
  double azimuth_start = 0.0;
  double azimuth_end = 0.0;
  // Ground metres, >= 0: cells whose centre is nearer are out of range.
  double min_distance = 0.0;
  // Degrees, -90 <= pitch_min <= pitch_max <= 90: cells whose pitch lies
  // outside [pitch_min, pitch_max] are out of range.
  double pitch_min = -90.0;
  double pitch_max = 90.0;

  bool limits_azimuth() const;
  bool limits_pitch() const;
  // Any limit at all (false: the mask is skipped).
  bool limits() const;
};

// Every field finite and in range; the error's field names it
// ("azimuth_start", "min_distance", "pitch_max").
Status validate_field_of_view(const FieldOfView& view);

// Sets to NaN (no answer) every cell of `ohf` outside `view`; `terrain` is
// the same window's ground (ViewshedResult::terrain), `frame` places both.
// On `threads` threads (0: one per core).
void mask_field_of_view(const FieldOfView& view, const ViewFrame& frame, const terrain::Grid<float>& terrain,
                        terrain::Grid<float>& ohf, unsigned threads = 0);

}  // namespace horizon::visibility
