// From-region visibility feeding per-frame culling (Google Benchmark): a
// client moving for one second at 60 frames/s culls its boxes every frame,
// either all of them, or only those that one from-region classification of
// its path left undetermined (the always hidden need no test, the always
// visible are drawn).
//
//   build/tests/bench/bench_region_path --benchmark_enable_random_interleaving=true
//       --benchmark_repetitions=5 --benchmark_report_aggregates_only=true
//
// Scene: the bundled Andes crop (383 x 415 cells of 10 m, EPSG:32717), 5 000
// boxes 10 to 40 m wide and 2 to 20 m tall on the ground, uniform over the
// crop; the path of tests/region's path test (71 m north-east in one second),
// the eye 2 m (a vehicle) or 30 m (a drone) above the ground. Per-frame
// culling is cull_boxes with the fast OHF on one thread (what a simulator
// calls); the classification runs once per path, on one thread, and its
// time is in the second form's figure.
//
// BM_RegionPath/<eye>/<form>: eye 0 at 2 m, 1 at 30 m; form 0 every box
// every frame, 1 classification + the undetermined boxes every frame. One
// iteration is the whole second (60 frames). Counters: boxes_per_frame,
// decided (the fraction the classification settled), classify_ms (its time
// per path) and ohf_ms_per_frame (the OHF's part of a frame's culling).
#include <benchmark/benchmark.h>

#include <random>
#include <vector>

#include "horizon/geodesy/observer.hpp"
#include "horizon/region/region.hpp"
#include "horizon/terrain/dem_reader.hpp"
#include "horizon/visibility/cull.hpp"

using namespace horizon;

namespace {

constexpr int kFrames = 60;
constexpr double kX0 = 713850, kY0 = 9558900, kX1 = 713900, kY1 = 9558950;

struct Scene {
  terrain::Dem dem;
  std::vector<visibility::BoxSpec> boxes;
};

const Scene& scene() {
  static const Scene s = [] {
    Scene out;
    auto dem = terrain::read_dem(std::string(HORIZON_DATA_DIR) + "/ecuador_andes_utm17s_10m_383x415.tif");
    if (!dem.ok()) return out;
    out.dem = std::move(*dem);
    const auto& t = out.dem.georef.transform;
    std::mt19937 rng(11);
    std::uniform_real_distribution<double> u(0, 1);
    for (int i = 0; i < 5000; ++i) {
      const double col = 20 + u(rng) * (out.dem.width() - 60), row = 20 + u(rng) * (out.dem.height() - 60);
      const double w = 10 + 30 * u(rng);
      const double ground = out.dem.elevation.at(static_cast<int>(col), static_cast<int>(row));
      visibility::BoxSpec b;
      b.x_min = t.x_at(col);
      b.x_max = b.x_min + w;
      b.y_max = t.y_at(row);
      b.y_min = b.y_max - w;
      b.z_min = ground;
      b.z_max = ground + 2 + 18 * u(rng);
      out.boxes.push_back(b);
    }
    return out;
  }();
  return s;
}

void BM_RegionPath(benchmark::State& state) {
  const Scene& s = scene();
  if (s.boxes.empty()) {
    state.SkipWithError("the bundled Andes crop could not be read");
    return;
  }
  const double height = state.range(0) == 0 ? 2.0 : 30.0;
  const bool classify = state.range(1) == 1;
  std::vector<geodesy::GridPoint> eyes;
  for (int f = 0; f < kFrames; ++f) {
    geodesy::PointSpec at;
    at.x = kX0 + (kX1 - kX0) * f / (kFrames - 1);
    at.y = kY0 + (kY1 - kY0) * f / (kFrames - 1);
    at.height = height;
    auto eye = geodesy::resolve_point(s.dem, at, "observer");
    if (!eye.ok()) {
      state.SkipWithError(eye.error().message.c_str());
      return;
    }
    eyes.push_back(*eye);
  }
  const region::RegionSpec path =
      region::swept_region(kX0, kY0, kX1, kY1, 0.5, 0.5, height, height, geodesy::HeightMode::kAboveGround);
  region::RegionOptions region_options;
  region_options.threads = 1;
  visibility::CullOptions cull_options;
  cull_options.viewshed.threads = 1;

  std::size_t tested = 0, decided = 0;
  double classify_seconds = 0.0, frame_seconds = 0.0;
  for (auto _ : state) {
    std::vector<visibility::BoxSpec> subset;
    const std::vector<visibility::BoxSpec>* per_frame = &s.boxes;
    if (classify) {
      auto verdicts = region::classify_boxes(s.dem, path, s.boxes, region_options);
      if (!verdicts.ok()) {
        state.SkipWithError(verdicts.error().message.c_str());
        return;
      }
      for (std::size_t i = 0; i < s.boxes.size(); ++i)
        if (verdicts->verdicts[i] == region::Verdict::kUndetermined) subset.push_back(s.boxes[i]);
      decided = s.boxes.size() - subset.size();
      classify_seconds += verdicts->stats.seconds;
      per_frame = &subset;
    }
    tested = per_frame->size();
    for (const geodesy::GridPoint& eye : eyes) {
      if (per_frame->empty()) break;
      auto culled = visibility::cull_boxes(s.dem, eye, *per_frame, cull_options);
      if (!culled.ok()) {
        state.SkipWithError(culled.error().message.c_str());
        return;
      }
      benchmark::DoNotOptimize(culled->visible_count);
      frame_seconds += culled->stats.seconds;
    }
  }
  state.counters["boxes_per_frame"] = static_cast<double>(tested);
  state.counters["decided"] = static_cast<double>(decided) / static_cast<double>(s.boxes.size());
  // Per path: the classification's own time, and the OHFs' part of the frames (WorkStats.seconds).
  const double n = static_cast<double>(state.iterations());
  state.counters["classify_ms"] = 1e3 * classify_seconds / n;
  state.counters["ohf_ms_per_frame"] = 1e3 * frame_seconds / n / kFrames;
}
BENCHMARK(BM_RegionPath)->ArgsProduct({{0, 1}, {0, 1}})->Unit(benchmark::kMillisecond)->UseRealTime();

}  // namespace

BENCHMARK_MAIN();
