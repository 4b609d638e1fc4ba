// Many observers (many_observers.hpp): each observer's viewshed on one
// thread with reused buffers, accumulated into the shared rasters as it
// finishes.
#include "horizon/visibility/many_observers.hpp"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <memory>
#include <mutex>
#include <optional>
#include <string>

#include "horizon/common/parallel.hpp"
#include "horizon/visibility/plan.hpp"
#include "horizon/visibility/viewshed.hpp"

namespace horizon::visibility {
namespace {

std::string site_name(std::size_t i) {
  return "observers[" + std::to_string(i) + "]";
}

// The options one site's viewshed runs with.
ViewshedOptions site_options(const ManyObserversOptions& options, const ObserverSite& site) {
  ViewshedOptions o = options.viewshed;
  if (site.max_distance > 0.0) o.max_distance = site.max_distance;
  o.threads = 1;
  o.backend = Backend::kCpu;
  o.visibility_only = true;  // only the visible/hidden answer is kept
  o.mask_only = true;        // the fast sweep codes it without an OHF
  return o;
}

terrain::Window merged(const terrain::Window& a, const terrain::Window& b) {
  if (a.empty()) return b;
  if (b.empty()) return a;
  return {std::min(a.col0, b.col0), std::min(a.row0, b.row0), std::max(a.col1, b.col1), std::max(a.row1, b.row1)};
}

// One thread's viewshed buffers, kept from one observer to the next.
struct Buffers {
  terrain::Grid<float> ohf, terrain;
  terrain::Grid<std::uint8_t> mask;
};

}  // namespace

Result<ManyObserversPlan> plan_many_observers(const terrain::Dem& dem, std::span<const ObserverSite> sites,
                                              const ManyObserversOptions& options) {
  if (sites.empty())
    return make_error(ErrorCode::kInvalidArgument, "observers: at least one observer is needed", "observers");
  ManyObserversPlan plan;
  plan.options = options;
  HORIZON_RETURN_IF_ERROR(validate_options(site_options(options, ObserverSite{})));
  std::uint64_t largest = 0;
  for (std::size_t i = 0; i < sites.size(); ++i) {
    const ObserverSite& site = sites[i];
    const std::string name = site_name(i);
    if (!(std::isfinite(site.max_distance) && site.max_distance >= 0.0))
      return make_error(ErrorCode::kInvalidArgument,
                        name + ".max_distance: must be a finite number of metres > 0 (0: the shared max distance)",
                        name + ".max_distance");
    auto point = geodesy::resolve_point(dem, site.point, name.c_str());
    if (!point.ok()) return point.error();
    const ViewshedOptions site_viewshed = site_options(options, site);
    auto frame = make_view_frame(dem, *point, site_viewshed);
    if (!frame.ok()) return frame.error();
    // The sweep's rays bounded as a single viewshed's plan bounds them.
    if (site_viewshed.algorithm != Algorithm::kR3) {
      Cost sweep;
      HORIZON_RETURN_IF_ERROR(add_sweep_cost(site_viewshed, frame->window, sweep));
    }
    plan.window = merged(plan.window, frame->window);
    plan.work_cells += frame->window.cell_count();
    largest = std::max(largest, frame->window.cell_count());
    plan.points.push_back(*point);
    plan.frames.push_back(*frame);
  }
  plan.sites.assign(sites.begin(), sites.end());
  plan.cells = plan.window.cell_count();
  plan.threads = static_cast<unsigned>(std::min<std::size_t>(resolve_thread_count(options.threads), sites.size()));
  // The count (4 bytes) and answered (1) rasters, and per thread one
  // viewshed's OHF, terrain crop and mask (9 bytes a cell of its window).
  plan.bytes = plan.cells * 5 + plan.threads * largest * 9 + sites.size() * sizeof(ObserverSummary);
  return plan;
}

Result<ManyObserversResult> compute_many_observers(const terrain::Dem& dem, const ManyObserversPlan& plan,
                                                   const RunControl* control) {
  const auto start = std::chrono::steady_clock::now();
  ManyObserversResult res;
  res.window = plan.window;
  res.count = terrain::Grid<std::uint32_t>(plan.window.width(), plan.window.height(), 0u);
  res.answered = terrain::Grid<std::uint8_t>(plan.window.width(), plan.window.height(), 0);
  res.observers.resize(plan.sites.size());
  res.observer_count = plan.sites.size();

  std::mutex mutex;  // guards `spare` and `failure`
  std::vector<std::unique_ptr<Buffers>> spare;
  std::optional<Error> failure;
  std::atomic<bool> failed{false};
  const Status status = parallel_for(plan.sites.size(), plan.threads, control, [&](std::size_t i) {
    if (failed.load(std::memory_order_relaxed)) return;
    std::unique_ptr<Buffers> buffers;
    {
      std::lock_guard lock(mutex);
      if (!spare.empty()) {
        buffers = std::move(spare.back());
        spare.pop_back();
      }
    }
    if (!buffers) buffers = std::make_unique<Buffers>();
    const auto t0 = std::chrono::steady_clock::now();
    const ViewshedOptions options = site_options(plan.options, plan.sites[i]);
    auto vs = compute_viewshed(dem, plan.points[i], options, control, nullptr, nullptr,
                               {&buffers->ohf, &buffers->terrain, &buffers->mask});
    if (!vs.ok()) {
      std::lock_guard lock(mutex);
      if (!failure) failure = vs.error();
      failed.store(true, std::memory_order_relaxed);
      return;
    }
    const terrain::Grid<std::uint8_t>& mask = *vs->mask;  // mask_only: always made
    const terrain::Window& w = vs->frame.window;
    ObserverSummary& summary = res.observers[i];
    for (int r = 0; r < w.height(); ++r) {
      const std::uint8_t* m = mask.row(r);
      const int row = w.row0 + r - plan.window.row0;
      std::uint32_t* count = res.count.row(row) + (w.col0 - plan.window.col0);
      std::uint8_t* answered = res.answered.row(row) + (w.col0 - plan.window.col0);
      for (int c = 0; c < w.width(); ++c) {
        if (m[c] == kNoAnswer) continue;
        ++summary.cells_answered;
        std::atomic_ref<std::uint8_t>(answered[c]).store(1, std::memory_order_relaxed);
        if (m[c] == kVisible) {
          ++summary.cells_visible;
          std::atomic_ref<std::uint32_t>(count[c]).fetch_add(1, std::memory_order_relaxed);
        }
      }
    }
    summary.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    // The result took the buffers' storage over: hand it back for the next
    // observer (an OHF the sweep did not need stayed in the buffers).
    if (!vs->ohf.empty()) buffers->ohf = std::move(vs->ohf);
    buffers->terrain = std::move(vs->terrain);
    buffers->mask = std::move(*vs->mask);
    std::lock_guard lock(mutex);
    spare.push_back(std::move(buffers));
  });
  if (!status.ok()) return status.error();
  if (failure) return *failure;
  res.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return res;
}

terrain::Grid<std::uint32_t> observer_count(const ManyObserversResult& result) {
  terrain::Grid<std::uint32_t> out = result.count;
  const auto answered = result.answered.values();
  auto cells = out.values();
  for (std::size_t i = 0; i < cells.size(); ++i)
    if (!answered[i]) cells[i] = kNoCount;
  return out;
}

namespace {

template <class Rule>
terrain::Grid<std::uint8_t> classify(const ManyObserversResult& result, Rule seen) {
  terrain::Grid<std::uint8_t> out(result.count.width(), result.count.height(), terrain::kUninitialized);
  const auto count = result.count.values();
  const auto answered = result.answered.values();
  auto cells = out.values();
  for (std::size_t i = 0; i < cells.size(); ++i)
    cells[i] = !answered[i] ? kNoAnswer : seen(count[i]) ? kVisible : kHidden;
  return out;
}

}  // namespace

terrain::Grid<std::uint8_t> seen_from_any(const ManyObserversResult& result) {
  return classify(result, [](std::uint32_t n) { return n > 0; });
}

terrain::Grid<std::uint8_t> seen_from_all(const ManyObserversResult& result) {
  const std::uint64_t all = result.observer_count;
  return classify(result, [all](std::uint32_t n) { return n == all; });
}

}  // namespace horizon::visibility
