// The trace's brute-force reference (trace_reference in trace.hpp): every
// pixel's ray walked through every crossing, no map, no tree. The hit is
// the nearest crossing whose slope reaches the ray's, the crossing before
// it the farthest one nearer than the hit (ties to the row family the
// sub-frustum partitions, as the trace breaks them), and the point between
// them chord_hit's, all with the trace's own per-crossing arithmetic
// (frustum.hpp): the tree must find the same crossing, to the bit.
#include <cmath>
#include <limits>

#include "frustum.hpp"
#include "horizon/trace/trace.hpp"

namespace horizon::trace {

TraceImage trace_reference(const terrain::HeightView& view, const Camera& camera, const TraceOptions& options) {
  const detail::FrameGeometry g = detail::make_frame_geometry(camera, view, options);
  TraceImage image;
  image.width = camera.spec.width;
  image.height = camera.spec.height;
  const auto pixels = static_cast<std::size_t>(image.width) * static_cast<std::size_t>(image.height);
  image.distance.assign(pixels, std::numeric_limits<float>::infinity());
  image.line.assign(pixels, -1);
  image.axis.assign(pixels, LineAxis::kRows);
  const float* data = view.data();

  for (const detail::Run& run : g.runs) {
    for (int x = run.x0; x < run.x1; ++x) {
      const auto xi = static_cast<std::size_t>(x);
      struct Family {
        const detail::LineFamily* lines;
        float pos_per_t, dist_per_t;
        int count;
      };
      Family families[2] = {{&run.primary, g.pos_per_t[xi], g.dist_per_t[xi], run.primary.count},
                            {&run.secondary[g.side[xi]], g.pos_per_t2[xi], g.dist_per_t2[xi], 0}};
      if (options.column_crossings && std::isfinite(g.dist_per_t2[xi])) families[1].count = families[1].lines->count;
      for (int j = 0; j < image.height; ++j) {
        const float s = detail::pixel_slope(g, x, j);
        // The nearest crossing reaching the ray, over both families.
        int hit_family = -1, hit_k = -1;
        float hit_d = std::numeric_limits<float>::infinity(), hit_s = detail::kNoCrossing;
        for (int f = 0; f < 2; ++f) {
          const Family& fam = families[f];
          for (int k = 0; k < fam.count; ++k) {
            const float sk = detail::family_slope(data, *fam.lines, k, fam.pos_per_t, fam.dist_per_t, g.near[xi], g.far,
                                                  g.eye_z, g.curvature, g.fill);
            if (s <= sk) {
              const float d = detail::crossing_distance(*fam.lines, k, fam.dist_per_t);
              if (d < hit_d || hit_family < 0) {
                hit_family = f;
                hit_k = k;
                hit_d = d;
                hit_s = sk;
              }
              break;  // later crossings of this family are farther
            }
          }
        }
        if (hit_family < 0) continue;
        // The farthest crossing nearer than the hit.
        float before_d = std::numeric_limits<float>::infinity(), before_s = detail::kNoCrossing;
        bool have_before = false;
        for (int f = 0; f < 2; ++f) {
          const Family& fam = families[f];
          for (int k = fam.count - 1; k >= 0; --k) {
            const float d = detail::crossing_distance(*fam.lines, k, fam.dist_per_t);
            if (!(d < hit_d)) continue;
            if (!have_before || d > before_d) {
              before_d = d;
              before_s = detail::family_slope(data, *fam.lines, k, fam.pos_per_t, fam.dist_per_t, g.near[xi], g.far,
                                              g.eye_z, g.curvature, g.fill);
              have_before = true;
            }
            break;
          }
        }
        const std::size_t at = static_cast<std::size_t>(j) * static_cast<std::size_t>(image.width) + xi;
        image.distance[at] = detail::chord_hit(s, before_d, before_s, hit_d, hit_s);
        image.line[at] = families[hit_family].lines->first + families[hit_family].lines->step * hit_k;
        image.axis[at] = families[hit_family].lines->axis;
      }
    }
  }
  return image;
}

}  // namespace horizon::trace
