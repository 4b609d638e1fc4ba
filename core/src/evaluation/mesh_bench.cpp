#include "horizon/evaluation/mesh_bench.hpp"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <random>
#include <sstream>

#include "horizon/evaluation/mesh_r3.hpp"
#include "horizon/mesh/cull.hpp"
#include "horizon/mesh/local_frame.hpp"
#include "horizon/mesh/prepared_mesh.hpp"
#include "horizon/mesh/tin_from_dem.hpp"
#include "horizon/mesh/tin_raster.hpp"
#include "horizon/mesh/tin_visibility.hpp"
#include "horizon/terrain/dem_reader.hpp"

namespace horizon::evaluation {
namespace {

using Clock = std::chrono::steady_clock;

double seconds_since(Clock::time_point start) { return std::chrono::duration<double>(Clock::now() - start).count(); }

Status check(const MeshBenchConfig& c) {
  auto bad = [](const std::string& why) { return make_error(ErrorCode::kInvalidArgument, why, "mesh bench"); };
  if (c.dems.empty()) return bad("no DEM to run on");
  if (c.vertices < 4) return bad("vertices must be 4 or more");
  if (c.shapes.empty()) return bad("no sectors/subsectors shape");
  if (c.cameras < 1 || c.cull_repeats < 1 || c.exact_cameras < 0 || c.exact_cameras > c.cameras)
    return bad("cameras and cull repeats must be >= 1, exact cameras 0 to cameras");
  if (!(c.height >= 0)) return bad("the camera height must be >= 0");
  if (!(c.high_eye >= 0)) return bad("the high cameras' extra height must be >= 0");
  return Status::Ok();
}

bool any_sample_seen(const mesh::TinVisibility& vis, const mesh::Tin& tin, const mesh::TinTriangle& t,
                     const mesh::TinVertex& eye) {
  const mesh::TinVertex& a = tin.vertices[t[0]];
  const mesh::TinVertex& b = tin.vertices[t[1]];
  const mesh::TinVertex& c = tin.vertices[t[2]];
  const mesh::TinVertex centroid{(a.x + b.x + c.x) / 3, (a.y + b.y + c.y) / 3, (a.z + b.z + c.z) / 3};
  return vis.visible(eye, a) || vis.visible(eye, b) || vis.visible(eye, c) || vis.visible(eye, centroid);
}

}  // namespace

const char* camera_kind_name(CameraKind kind) {
  switch (kind) {
    case CameraKind::kValley:
      return "valley";
    case CameraKind::kSlope:
      return "slope";
    case CameraKind::kRidge:
      return "ridge";
    case CameraKind::kHigh:
      return "high";
  }
  return "?";
}

std::vector<MeshBenchCamera> mesh_bench_cameras(const std::vector<double>& z, int count, double height,
                                                double high_eye) {
  // The vertices by height (ties by index, so the draw is the same everywhere).
  std::vector<std::uint32_t> by_height(z.size());
  for (std::uint32_t v = 0; v < by_height.size(); ++v) by_height[v] = v;
  std::sort(by_height.begin(), by_height.end(),
            [&](std::uint32_t a, std::uint32_t b) { return z[a] < z[b] || (z[a] == z[b] && a < b); });
  const std::size_t n = by_height.size();
  // Each kind's band [lo, hi) of by_height, never empty.
  auto band = [n](double from, double to) {
    const std::size_t lo = std::min(n - 1, static_cast<std::size_t>(from * static_cast<double>(n)));
    return std::pair{lo, std::max(lo + 1, static_cast<std::size_t>(to * static_cast<double>(n)))};
  };
  const std::pair<std::size_t, std::size_t> bands[4] = {band(0.0, 0.1), band(0.3, 0.7), band(0.9, 1.0),
                                                        band(0.0, 1.0)};
  std::mt19937_64 rng(1);
  std::vector<MeshBenchCamera> out;
  for (int c = 0; c < count; ++c) {
    const auto kind = static_cast<CameraKind>(c % 4);
    const auto [lo, hi] = bands[c % 4];
    std::uniform_int_distribution<std::size_t> pick(lo, hi - 1);
    out.push_back({by_height[pick(rng)], height + (kind == CameraKind::kHigh ? high_eye : 0.0), kind});
  }
  return out;
}

Result<MeshBenchReport> run_mesh_bench(const MeshBenchConfig& config, const RunControl* control) {
  HORIZON_RETURN_IF_ERROR(check(config));
  MeshBenchReport report;
  for (const std::string& path : config.dems) {
    auto dem = terrain::read_dem(path);
    if (!dem.ok()) return dem.error();
    auto built = mesh::tin_from_dem(*dem, {config.vertices, 0.0});
    if (!built.ok()) return built.error();
    auto frame = mesh::LocalFrame::for_dem(*dem);
    if (!frame.ok()) return frame.error();
    mesh::Tin tin = std::move(built->tin);
    const std::vector<mesh::TinVertex> crs_vertices = tin.vertices;  // R3 reads the DEM in its own CRS
    frame->to_local(tin);
    const mesh::TinVisibility vis(tin);
    // The cameras, in the TIN's frame and in the DEM's CRS: the same vertex,
    // the same height above it.
    std::vector<mesh::TinVertex> cameras, crs_cameras;
    std::vector<double> z;
    for (const mesh::TinVertex& v : tin.vertices) z.push_back(v.z);
    for (const MeshBenchCamera& cam : mesh_bench_cameras(z, config.cameras, config.height, config.high_eye)) {
      const std::uint32_t v = cam.vertex;
      cameras.push_back({tin.vertices[v].x, tin.vertices[v].y, tin.vertices[v].z + cam.height});
      crs_cameras.push_back({crs_vertices[v].x, crs_vertices[v].y, crs_vertices[v].z + cam.height});
    }
    // R3 on the source DEM from each checked camera, once for every shape
    // and mode, read through the triangle over each cell (the input's
    // numbering; a prepared mesh maps back by source_triangle).
    const terrain::Grid<std::uint32_t> cell_triangle =
        mesh::cell_triangles(dem->georef.transform, dem->width(), dem->height(), crs_vertices, tin.triangles);
    std::vector<terrain::Grid<std::uint8_t>> r3(static_cast<std::size_t>(config.exact_cameras));
    for (std::size_t c = 0; c < r3.size(); ++c) {
      auto seen = r3_ground_viewshed(*dem, crs_cameras[c], config.threads, control);
      if (!seen.ok()) return seen.error();
      r3[c] = std::move(*seen);
    }
    for (auto [s, k] : config.shapes) {
      HORIZON_RETURN_IF_ERROR(check_control(control));
      mesh::PrepareOptions options;
      options.horizons = {s, k, config.threads};
      options.crystals.seeds = config.seeds;
      options.crystals.max_groups = config.max_groups;
      const auto start = Clock::now();
      auto prepared = mesh::prepare_mesh(tin, options, control);
      if (!prepared.ok()) return prepared.error();
      const double prepare_seconds = seconds_since(start);
      // Visibility of every triangle from each checked camera, once for both modes.
      std::vector<std::vector<bool>> seen(static_cast<std::size_t>(config.exact_cameras));
      for (std::size_t c = 0; c < seen.size(); ++c) {
        seen[c].resize(prepared->tin.triangles.size());
        for (std::size_t t = 0; t < seen[c].size(); ++t)
          seen[c][t] = any_sample_seen(vis, prepared->tin, prepared->tin.triangles[t], cameras[c]);
      }
      for (mesh::CullMode mode : {mesh::CullMode::kApproximate, mesh::CullMode::kConservative}) {
        MeshBenchRow row;
        row.dem = std::filesystem::path(path).filename().string();
        row.vertices = static_cast<std::uint32_t>(tin.vertices.size());
        row.triangles = static_cast<std::uint32_t>(tin.triangles.size());
        row.sectors = s, row.subsectors = k;
        row.mode = mode == mesh::CullMode::kApproximate ? "approximate" : "conservative";
        const mesh::PrepareStats& st = prepared->stats;
        row.prepare_seconds = prepare_seconds;
        row.horizon_seconds = st.horizon_seconds, row.grouping_seconds = st.grouping_seconds;
        row.hierarchy_seconds = st.hierarchy_seconds, row.wall_seconds = st.wall_seconds;
        row.groups = st.leaf_groups, row.nodes = static_cast<std::uint32_t>(prepared->groups.size());
        row.always_visible = prepared->always_visible_count;
        std::vector<double> micros;
        std::uint64_t tested = 0, culled = 0;
        std::vector<std::uint8_t> culled_source(tin.triangles.size());
        R3CellCounts cells;
        for (std::size_t c = 0; c < cameras.size(); ++c) {
          mesh::CullAnswer answer;
          const auto at = Clock::now();
          for (int r = 0; r < config.cull_repeats; ++r) answer = std::move(*mesh::cull(*prepared, {cameras[c], {}, {}, mode}));
          micros.push_back(seconds_since(at) / config.cull_repeats * 1e6);
          tested += answer.groups_tested;
          culled += answer.triangles_culled;
          if (c >= seen.size()) continue;
          const std::vector<std::uint8_t> drawn = mesh::triangle_states(*prepared, answer);
          for (std::size_t t = 0; t < drawn.size(); ++t) {
            culled_source[prepared->source_triangle[t]] = drawn[t] == mesh::kCulled ? 1 : 0;
            ++row.checked_views;
            row.exactly_hidden += seen[c][t] ? 0 : 1;
            if (drawn[t]) continue;
            ++row.culled_checked;
            row.false_hidden += seen[c][t] ? 1 : 0;
          }
          cells += count_cells(cell_triangle, r3[c], culled_source);
        }
        row.r3_cells = cells.cells, row.r3_hidden = cells.r3_hidden;
        row.r3_culled = cells.culled, row.r3_culled_visible = cells.culled_r3_visible;
        std::sort(micros.begin(), micros.end());
        row.cull_us_median = micros[micros.size() / 2];
        row.groups_tested = static_cast<double>(tested) / static_cast<double>(cameras.size());
        row.culled_share = static_cast<double>(culled) /
                           (static_cast<double>(cameras.size()) * static_cast<double>(prepared->tin.triangles.size()));
        report.rows.push_back(row);
      }
    }
  }
  return report;
}

namespace {

double percent(std::uint64_t part, std::uint64_t whole) {
  return whole ? 100.0 * static_cast<double>(part) / static_cast<double>(whole) : 0.0;
}

}  // namespace

std::string MeshBenchReport::markdown() const {
  std::ostringstream out;
  out << "| DEM | vertices | s/k | mode | prepare s (horizons, groups, hierarchy, walls) | groups | cull us | "
         "groups tested | culled | exactly hidden | false hidden | R3 hidden | culled cells | culled but R3-visible |\n"
         "|---|---:|---|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n";
  char line[512];
  for (const MeshBenchRow& r : rows) {
    const double hidden = percent(r.exactly_hidden, r.checked_views);
    std::snprintf(
        line, sizeof line,
        "| %s | %u | %d/%d | %s | %.3f (%.3f, %.3f, %.3f, %.3f) | %u | %.2f | %.0f | %.2f %% | %.2f %% | %llu of %llu "
        "| %.2f %% | %.2f %% | %.3f %% |\n",
        r.dem.c_str(), r.vertices, r.sectors, r.subsectors, r.mode.c_str(), r.prepare_seconds, r.horizon_seconds,
        r.grouping_seconds, r.hierarchy_seconds, r.wall_seconds, r.groups, r.cull_us_median, r.groups_tested,
        100.0 * r.culled_share, hidden, static_cast<unsigned long long>(r.false_hidden),
        static_cast<unsigned long long>(r.culled_checked), percent(r.r3_hidden, r.r3_cells),
        percent(r.r3_culled, r.r3_cells), percent(r.r3_culled_visible, r.r3_cells));
    out << line;
  }
  return out.str();
}

std::string MeshBenchReport::csv() const {
  std::ostringstream out;
  out << "dem,vertices,triangles,sectors,subsectors,mode,prepare_seconds,horizon_seconds,grouping_seconds,"
         "hierarchy_seconds,wall_seconds,groups,nodes,always_visible,cull_us_median,groups_tested,culled_share,"
         "checked_views,exactly_hidden,culled_checked,false_hidden,r3_cells,r3_hidden,r3_culled,r3_culled_visible\n";
  for (const MeshBenchRow& r : rows)
    out << r.dem << ',' << r.vertices << ',' << r.triangles << ',' << r.sectors << ',' << r.subsectors << ',' << r.mode
        << ',' << r.prepare_seconds << ',' << r.horizon_seconds << ',' << r.grouping_seconds << ','
        << r.hierarchy_seconds << ',' << r.wall_seconds << ',' << r.groups << ',' << r.nodes << ',' << r.always_visible
        << ',' << r.cull_us_median << ',' << r.groups_tested << ',' << r.culled_share << ',' << r.checked_views << ','
        << r.exactly_hidden << ',' << r.culled_checked << ',' << r.false_hidden << ',' << r.r3_cells << ','
        << r.r3_hidden << ',' << r.r3_culled << ',' << r.r3_culled_visible << '\n';
  return out.str();
}

}  // namespace horizon::evaluation
