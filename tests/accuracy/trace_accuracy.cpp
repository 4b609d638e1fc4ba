// trace_accuracy: the camera trace's two modes against each other and
// against R3 on real DEMs, as the Markdown table of docs/accuracy.md
// ("Camera traces").
//
//   build/tests/accuracy/trace_accuracy ../shared/data/dem/*.tif > trace.md
//
// Per DEM, at the four observer picks of the viewshed accuracy report
// (summit, ridge, valley, edge), a 360 degree panorama 10 m above the
// ground, 720 x 180 pixels, pitch -5: every column's plane once, both line
// families in play. The exact mode (rows and columns) meets R3's crossings
// along each pixel's plane (the tests hold it to the brute-force reference
// bit for bit); the table gives how often the paper's rows-only trace hits
// another crossing, and how far off, and checks a sample of exact hits
// with R3's own line of sight (visibility::line_of_sight): a target 1 m
// short of the hit on the ray is visible, one 1.5 cells past it is not.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "horizon/terrain/dem_reader.hpp"
#include "horizon/trace/trace.hpp"
#include "horizon/visibility/line_of_sight.hpp"
#include "observer_picks.hpp"

using namespace horizon;

namespace {

double percentile(std::vector<double> v, double p) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  return v[std::min(v.size() - 1, static_cast<std::size_t>(p * static_cast<double>(v.size())))];
}

std::string name_of(const std::string& path) {
  const auto slash = path.find_last_of('/');
  std::string name = slash == std::string::npos ? path : path.substr(slash + 1);
  if (name.size() > 4 && name.ends_with(".tif")) name.resize(name.size() - 4);
  return name;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) {
    std::fprintf(stderr, "usage: trace_accuracy DEM.tif...\n");
    return 2;
  }
  std::printf(
      "| DEM | camera | hit pixels | rows-only: another crossing | more than a cell farther (or sky) | farther "
      "when off: p99 / max (cells) | R3 check of exact hits (short visible, past hidden) | ms rows / exact |\n");
  std::printf("|---|---|---:|---:|---:|---|---|---|\n");
  std::uint64_t all_pixels = 0, all_differ = 0, all_far = 0, all_checked = 0, all_wrong = 0;
  for (int a = 1; a < argc; ++a) {
    auto dem = terrain::read_dem(argv[a]);
    if (!dem.ok()) {
      std::fprintf(stderr, "trace_accuracy: %s\n", dem.error().message.c_str());
      return 1;
    }
    for (const accuracy::ObserverPick& pick : accuracy::pick_observers(*dem)) {
      trace::CameraSpec spec;
      spec.position.x = dem->georef.transform.x_at(pick.col);
      spec.position.y = dem->georef.transform.y_at(pick.row);
      spec.position.height = 10.0;
      spec.pitch = -5.0;
      spec.hfov = 360.0;
      spec.projection = trace::Projection::kCylindrical;
      spec.width = 720;
      spec.height = 180;
      auto camera = trace::resolve_camera(*dem, spec);
      if (!camera.ok()) {
        std::printf("| %s | %s | %s |||||\n", name_of(argv[a]).c_str(), pick.kind.c_str(),
                    camera.error().message.c_str());
        continue;
      }
      const terrain::HeightView view(dem->elevation);
      trace::TraceOptions options;
      const auto t0 = std::chrono::steady_clock::now();
      auto rows = trace::trace_frame(view, *camera, options);
      const auto t1 = std::chrono::steady_clock::now();
      options.column_crossings = true;
      auto exact = trace::trace_frame(view, *camera, options);
      const auto t2 = std::chrono::steady_clock::now();
      if (!rows.ok() || !exact.ok()) return 1;
      const double cell = std::sqrt(camera->metres_per_col * camera->metres_per_row);
      std::uint64_t hits = 0, differ = 0, far_off = 0, checked = 0, wrong = 0;
      std::vector<double> farther;
      visibility::LosOptions los;
      los.curvature_coefficient = options.curvature_coefficient;
      for (int j = 0; j < spec.height; ++j)
        for (int x = 0; x < spec.width; ++x) {
          const auto i =
              static_cast<std::size_t>(j) * static_cast<std::size_t>(spec.width) + static_cast<std::size_t>(x);
          const trace::Hit e = exact->hit(x, j), r = rows->hit(x, j);
          if (e.sky && r.sky) continue;
          ++hits;
          if (rows->image.line[i] != exact->image.line[i] || rows->image.axis[i] != exact->image.axis[i]) {
            ++differ;
            const double off = r.sky ? INFINITY : (r.distance - e.distance) / cell;
            if (!r.sky) farther.push_back(off);
            far_off += off > 1.0;
          }
          // R3 on a sample of the exact hits: every 37th pixel, beyond two cells.
          if (e.sky || i % 37 != 0 || e.distance < 2 * cell) continue;
          const double s = camera->slope(x, j), az = camera->azimuth[static_cast<std::size_t>(x)];
          auto on_ray = [&](double d) {
            geodesy::GridPoint p;
            p.col = camera->eye.col + d * std::sin(az) / camera->metres_per_col;
            p.row = camera->eye.row - d * std::cos(az) / camera->metres_per_row;
            p.elevation = camera->eye.elevation + s * d + exact->curvature * d * d;
            return p;
          };
          auto short_of = visibility::line_of_sight(*dem, camera->eye, on_ray(e.distance - 1.0), los);
          auto past = visibility::line_of_sight(*dem, camera->eye, on_ray(e.distance + 1.5 * cell), los);
          if (!short_of.ok() || !past.ok()) continue;
          ++checked;
          // Float32 slopes against R3's doubles: a millimetre of slack.
          if (short_of->clearance < -1e-3 || (past->visible && past->clearance > 1e-3)) ++wrong;
        }
      const double ms_rows = std::chrono::duration<double>(t1 - t0).count() * 1e3;
      const double ms_exact = std::chrono::duration<double>(t2 - t1).count() * 1e3;
      auto share = [&](std::uint64_t n) {
        return hits ? 100.0 * static_cast<double>(n) / static_cast<double>(hits) : 0.0;
      };
      std::printf("| %s | %s | %llu | %.2f %% | %.3f %% | %.1f / %.0f | %llu of %llu wrong | %.1f / %.1f |\n",
                  name_of(argv[a]).c_str(), pick.kind.c_str(), static_cast<unsigned long long>(hits), share(differ),
                  share(far_off), percentile(farther, 0.99),
                  farther.empty() ? 0.0 : *std::max_element(farther.begin(), farther.end()),
                  static_cast<unsigned long long>(wrong), static_cast<unsigned long long>(checked), ms_rows, ms_exact);
      std::fflush(stdout);
      all_pixels += hits;
      all_differ += differ;
      all_far += far_off;
      all_checked += checked;
      all_wrong += wrong;
    }
  }
  auto share = [&](std::uint64_t n) {
    return all_pixels ? 100.0 * static_cast<double>(n) / static_cast<double>(all_pixels) : 0.0;
  };
  std::printf(
      "\nIn all: of %llu hit pixels, rows-only hits another crossing than exact in %.2f %%, one more than a "
      "cell farther (or sky) in %.3f %%; R3 finds %llu of %llu sampled exact hits wrong.\n",
      static_cast<unsigned long long>(all_pixels), share(all_differ), share(all_far),
      static_cast<unsigned long long>(all_wrong), static_cast<unsigned long long>(all_checked));
  return 0;
}
