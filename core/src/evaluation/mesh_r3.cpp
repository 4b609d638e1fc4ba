// evaluation/mesh_r3.cpp — the cull against R3 on the source DEM
// (mesh_r3.hpp).
#include "horizon/evaluation/mesh_r3.hpp"

#include <cassert>

#include "horizon/geodesy/observer.hpp"
#include "horizon/mesh/tin_raster.hpp"
#include "horizon/visibility/viewshed.hpp"

namespace horizon::evaluation {

Result<terrain::Grid<std::uint8_t>> r3_ground_viewshed(const terrain::Dem& dem, const mesh::TinVertex& eye,
                                                       unsigned threads, const RunControl* control) {
  geodesy::PointSpec spec;
  spec.frame = geodesy::PointFrame::kDatasetCrs;
  spec.x = eye.x, spec.y = eye.y;
  spec.height = eye.z, spec.height_mode = geodesy::HeightMode::kAbsolute;
  auto point = geodesy::resolve_point(dem, spec, "camera");
  if (!point.ok()) return point.error();
  visibility::ViewshedOptions options;
  options.algorithm = visibility::Algorithm::kExact;
  options.visibility_only = true;  // R3's visible/hidden at the ground is all that is read
  options.target_height = 0.0;
  options.curvature_coefficient = 0.0;  // a flat earth, as the TIN's frame
  options.backend = visibility::Backend::kCpu;
  options.threads = threads;
  auto result = visibility::compute_viewshed(dem, *point, options, control);
  if (!result.ok()) return result.error();
  // No max distance: the window is the whole DEM, cell (0, 0) its corner.
  assert(result->frame.window.col0 == 0 && result->frame.window.row0 == 0 &&
         result->frame.window.width() == dem.width() && result->frame.window.height() == dem.height());
  return visibility::visibility_mask(*result, 0.0);
}

R3CellCounts count_cells(const terrain::Grid<std::uint32_t>& cell_triangle, const terrain::Grid<std::uint8_t>& r3,
                         const std::vector<std::uint8_t>& culled) {
  assert(cell_triangle.width() == r3.width() && cell_triangle.height() == r3.height());
  R3CellCounts n;
  for (int row = 0; row < r3.height(); ++row)
    for (int col = 0; col < r3.width(); ++col) {
      const std::uint32_t t = cell_triangle.at(col, row);
      const std::uint8_t seen = r3.at(col, row);
      if (t == mesh::kNoTriangle || seen == visibility::kNoAnswer) continue;
      assert(t < culled.size());
      const bool hidden = seen == visibility::kHidden;
      const bool dropped = culled[t] != 0;
      ++n.cells;
      n.r3_hidden += hidden ? 1 : 0;
      n.culled += dropped ? 1 : 0;
      n.culled_r3_visible += dropped && !hidden ? 1 : 0;
    }
  return n;
}

}  // namespace horizon::evaluation
