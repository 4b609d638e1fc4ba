// libFuzzer target: every request's validation, planning and (on a small
// DEM) execution, from the wire bytes of a v1 request. The first byte picks
// the message (viewshed, culling, sight lines, region, camera trace); the rest
// is parsed as it. The steps are the daemon's: the translations of
// server/src/translate.hpp and trace_translate.hpp, then visibility::plan_* /
// region::plan_region / trace::plan_trace and run_* against the bundled Olinda DEM
// (111 x 111 cells), under a 2 s deadline. Any outcome but a crash, a hang
// or undefined behaviour is fine: an Error names what was wrong.
#include <chrono>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include <google/protobuf/stubs/logging.h>

#include "horizon/region/region_plan.hpp"
#include "horizon/terrain/block_cache.hpp"
#include "horizon/terrain/source.hpp"
#include "horizon/trace/trace_plan.hpp"
#include "horizon/v1/visibility.pb.h"
#include "horizon/visibility/many_observers.hpp"
#include "horizon/visibility/plan.hpp"
#include "trace_translate.hpp"
#include "translate.hpp"

namespace {

namespace v1 = horizon::v1;
namespace vis = horizon::visibility;
using horizon::RunControl;

struct Fixture {
  std::shared_ptr<const horizon::terrain::ElevationSource> source;
  horizon::terrain::BlockCache cache{{.budget_bytes = 8 << 20, .io_threads = 1}};
  Fixture() {
    google::protobuf::SetLogHandler(nullptr);  // invalid UTF-8 in a string field is an expected input, not news
    auto opened = horizon::terrain::ElevationSource::open(HORIZON_DATA_DIR "/olinda_coast_utm25s_111x111.tif");
    if (opened.ok()) source = *opened;
  }
};

Fixture& fixture() {
  static Fixture f;
  return f;
}

RunControl bounded() {
  RunControl control;
  control.deadline = std::chrono::steady_clock::now() + std::chrono::seconds(2);
  return control;
}

// Many observers: the sites as the daemon reads them, planned and run on
// the whole (small) DEM.
void many_observers(const v1::ViewshedRequest& req) {
  Fixture& f = fixture();
  if (req.observers_size() > 16) return;  // limits.max_observers, shrunk
  auto options = horizon::server::to_viewshed_options(req.options(), 1);
  if (!options.ok()) return;
  std::vector<vis::ObserverSite> sites;
  for (const v1::ObserverSite& in : req.observers()) {
    auto spec = horizon::server::to_point_spec(in.point(), "observers[].point");
    if (!spec.ok()) return;
    sites.push_back({.point = *spec, .max_distance = in.max_distance()});
  }
  const RunControl control = bounded();
  const auto& h = f.source->header();
  auto dem = f.source->read({0, 0, h.width, h.height}, &f.cache, &control);
  if (!dem.ok()) return;
  auto plan = vis::plan_many_observers(*dem, sites, {.viewshed = *options, .threads = 1});
  if (!plan.ok()) return;
  (void)vis::compute_many_observers(*dem, *plan, &control);
}

void viewshed(const v1::ViewshedRequest& req) {
  Fixture& f = fixture();
  if (req.observers_size() > 0) return many_observers(req);
  if (!req.has_observer()) return;
  auto spec = horizon::server::to_point_spec(req.observer(), "observer");
  if (!spec.ok()) return;
  auto options = horizon::server::to_viewshed_options(req.options(), 1);
  if (!options.ok()) return;
  options->backend = vis::Backend::kCpu;  // no GL context in a fuzzer
  auto plan = vis::plan_viewshed(*f.source, {*spec, *options});
  if (!plan.ok()) return;
  const RunControl control = bounded();
  (void)vis::run_viewshed(*plan, *f.source, &f.cache, &control, nullptr, nullptr, nullptr);
}

void cull(const v1::CullBoxesRequest& req) {
  Fixture& f = fixture();
  if (!req.has_observer() || req.boxes_size() > 1000) return;  // the daemon's limits.max_boxes, shrunk
  auto spec = horizon::server::to_point_spec(req.observer(), "observer");
  if (!spec.ok()) return;
  auto options = horizon::server::to_cull_options(req, 1);
  if (!options.ok()) return;
  auto boxes = horizon::server::to_boxes(req);
  if (!boxes.ok()) return;
  auto plan = vis::plan_cull_boxes(*f.source, {*spec, std::move(*boxes), *options});
  if (!plan.ok()) return;
  const RunControl control = bounded();
  (void)vis::run_cull_boxes(*plan, *f.source, &f.cache, &control, nullptr, nullptr, nullptr);
}

void lines(const v1::LineOfSightRequest& req) {
  Fixture& f = fixture();
  if (req.lines_size() > 50) return;  // limits.max_lines, shrunk
  auto curvature = horizon::server::to_curvature(req.has_curvature(), req.curvature());
  if (!curvature.ok()) return;
  vis::LosOptions options;
  options.curvature_coefficient = *curvature;
  const RunControl control = bounded();
  for (const v1::SightLine& line : req.lines()) {
    auto ends = horizon::server::to_line_ends(line, "lines[].");
    if (!ends.ok()) return;
    auto plan = vis::plan_line(*f.source, {ends->first, ends->second, options});
    if (!plan.ok()) continue;
    (void)vis::run_line(*plan, *f.source, &f.cache, &control);
  }
}

void region(const v1::RegionVisibilityRequest& req) {
  Fixture& f = fixture();
  if (req.boxes_size() > 1000) return;  // limits.max_boxes, shrunk
  auto query = horizon::server::to_region_query(req, 1);
  if (!query.ok()) return;
  auto plan = horizon::region::plan_region(*f.source, std::move(*query));
  if (!plan.ok()) return;
  const RunControl control = bounded();
  (void)horizon::region::run_region(*plan, *f.source, &f.cache, &control);
}

void camera_trace(const v1::TraceRequest& req) {
  Fixture& f = fixture();
  if (req.boxes_size() > 1000) return;  // limits.max_boxes, shrunk
  auto ask = horizon::server::to_trace_ask(req, f.source->header(), 1);
  if (!ask.ok()) return;
  const horizon::trace::CameraSpec& c = ask->query.camera;
  if (static_cast<std::uint64_t>(c.width) * static_cast<std::uint64_t>(c.height) > 256 * 256)
    return;  // limits.max_trace_pixels, shrunk
  auto plan = horizon::trace::plan_trace(*f.source, ask->query, 1);
  if (!plan.ok()) return;
  const RunControl control = bounded();
  (void)horizon::trace::run_trace(*plan, *f.source, &f.cache, &control, nullptr);
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size < 1 || !fixture().source) return 0;
  const void* body = data + 1;
  const int n = static_cast<int>(size - 1);
  switch (data[0] % 5) {
    case 0: {
      v1::ViewshedRequest r;
      if (r.ParseFromArray(body, n)) viewshed(r);
      break;
    }
    case 1: {
      v1::CullBoxesRequest r;
      if (r.ParseFromArray(body, n)) cull(r);
      break;
    }
    case 2: {
      v1::LineOfSightRequest r;
      if (r.ParseFromArray(body, n)) lines(r);
      break;
    }
    case 3: {
      v1::RegionVisibilityRequest r;
      if (r.ParseFromArray(body, n)) region(r);
      break;
    }
    default: {
      v1::TraceRequest r;
      if (r.ParseFromArray(body, n)) camera_trace(r);
      break;
    }
  }
  return 0;
}
