// `horizon mesh INPUT --observer ...`: a TIN prepared for per-frame culling
// (horizons, crystal groups, hierarchy) and culled from one viewpoint.
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iostream>

#include "commands/command.hpp"
#include "horizon/mesh/cull.hpp"
#include "horizon/mesh/local_frame.hpp"
#include "horizon/mesh/mesh_boxes.hpp"
#include "horizon/mesh/prepared_cache.hpp"
#include "horizon/mesh/prepared_mesh.hpp"
#include "horizon/mesh/tin_from_dem.hpp"
#include "horizon/mesh/tin_io.hpp"
#include "horizon/mesh/tin_raster.hpp"
#include "horizon/mesh/tin_visibility.hpp"
#include "horizon/terrain/geotiff_writer.hpp"
#include "inputs.hpp"
#include "interrupt.hpp"
#include "output.hpp"
#include "progress.hpp"

namespace horizon::cli {
namespace {

constexpr FlagSpec kFlags[] = {
    {"--observer", "", "X,Y", "Viewpoint in the input's CRS"},
    {"--lat", "", "LAT", "Viewpoint latitude, WGS84 degrees (with --lon; DEM input only)"},
    {"--lon", "", "LON", "Viewpoint longitude, WGS84 degrees (with --lat; DEM input only)"},
    {"--height", "", "M", "Eye height above the surface, metres (default 2)"},
    {"--altitude", "", "M", "Eye altitude, absolute metres (instead of --height)"},
    {"--vertices", "", "N", "DEM input: the TIN's vertex budget for greedy insertion (default 100000)"},
    {"--max-error", "", "M", "DEM input: stop inserting once every cell is within M metres (default 0: the budget)"},
    {"--sectors", "", "S/K", "Sectors and subsectors of each vertex's horizon (default 16/4)"},
    {"--seeds", "", "N", "Crystal seeds of the first pass (default 500)"},
    {"--min-group", "", "N", "Smallest group, triangles (default 30)"},
    {"--max-groups", "", "N", "Most groups (default 1000)"},
    {"--orphan-passes", "", "N", "Reseeding passes over unclaimed triangles (default 10)"},
    {"--merge-cutoff", "", "F", "A merged group whose circle covers more than F of the mesh is top-level (default 0.25)"},
    {"--random-seed", "", "N", "Seed of the crystal seeding (default 1; the same seed gives the same groups)"},
    {"--azimuth", "", "FROM,TO", "The view: degrees clockwise from north, FROM turning clockwise to TO (default all round)"},
    {"--conservative", "", "", "Never cull a triangle the viewpoint can see (walls; default: the thesis's approximate test)"},
    {"--out", "-o", "OUT.tif",
     "DEM input: a raster on the DEM's grid: 1 drawn, 0 culled, 2 always visible, 255 no triangle"},
    {"--mesh-out", "", "OUT.obj", "Write the TIN with its triangles in group order (the ranges the answer names)"},
    {"--boxes", "", "FILE.csv",
     "Also cull object boxes: [id,]x_min,y_min,x_max,y_max,z_min,z_max a line (the input's CRS, absolute metres); "
     "hidden means no point of the box can be seen"},
    {"--cache", "", "DIR",
     "Keep the prepared mesh in DIR, keyed by the TIN and the knobs, and load it from there next time"},
    {"--threads", "", "N", "Worker threads for preparing (default 0 = all cores)"},
    {"--band", "", "N", "DEM band to read, 1-based (required when the file has several)"},
    {"--json", "", "", "Print a JSON document with every drawn group's triangle range"},
};

bool is_mesh_file(const std::string& path) {
  std::string ext = std::filesystem::path(path).extension().string();
  for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return ext == ".obj" || ext == ".ply";
}

mesh::PrepareOptions options_from_flags(const Args& args) {
  mesh::PrepareOptions o;
  if (auto text = args.text("--sectors")) {
    int s = 0, k = 0;
    char tail = 0;
    if (std::sscanf(text->c_str(), "%d/%d%c", &s, &k, &tail) != 2)
      throw UsageError("--sectors: expected S/K (sectors/subsectors, e.g. 16/4), got '" + *text + "'");
    o.horizons.sectors = s;
    o.horizons.subsectors = k;
  }
  o.horizons.threads = args.non_negative_integer("--threads").value_or(0);
  if (auto n = args.positive_integer("--seeds")) o.crystals.seeds = *n;
  if (auto n = args.positive_integer("--min-group")) o.crystals.min_group_size = *n;
  if (auto n = args.positive_integer("--max-groups")) o.crystals.max_groups = *n;
  if (auto n = args.non_negative_integer("--orphan-passes")) o.crystals.max_orphan_passes = static_cast<int>(*n);
  if (auto n = args.non_negative_integer("--random-seed")) o.crystals.random_seed = *n;
  if (auto f = args.number("--merge-cutoff")) o.merge_cutoff = *f;
  return o;
}

// Writes the TIN (CRS coordinates) as OBJ, its triangles in group order.
Status write_obj(const std::string& path, const std::vector<mesh::TinVertex>& vertices,
                 const std::vector<mesh::TinTriangle>& triangles) {
  const std::string partial = path + ".partial";
  {
    std::ofstream out(partial);
    out.precision(17);
    out << "# horizon mesh: triangles in group order\n";
    for (const mesh::TinVertex& v : vertices) out << "v " << v.x << ' ' << v.y << ' ' << v.z << '\n';
    for (const mesh::TinTriangle& t : triangles) out << "f " << t[0] + 1 << ' ' << t[1] + 1 << ' ' << t[2] + 1 << '\n';
    if (!out) return make_error(ErrorCode::kIoError, path + ": cannot write the mesh", "--mesh-out");
  }
  std::error_code ec;
  std::filesystem::rename(partial, path, ec);
  if (ec) return make_error(ErrorCode::kIoError, path + ": " + ec.message(), "--mesh-out");
  return Status::Ok();
}

// 1 drawn, 0 culled, 2 always visible, 255 no triangle, at each cell centre.
terrain::Grid<std::uint8_t> rasterise(const terrain::Dem& dem, const std::vector<mesh::TinVertex>& crs_vertices,
                                      const mesh::PreparedMesh& prepared, const std::vector<std::uint8_t>& state) {
  const terrain::Grid<std::uint32_t> triangle =
      mesh::cell_triangles(dem.georef.transform, dem.width(), dem.height(), crs_vertices, prepared.tin.triangles);
  terrain::Grid<std::uint8_t> grid(dem.width(), dem.height(), 255);
  for (int r = 0; r < dem.height(); ++r)
    for (int c = 0; c < dem.width(); ++c)
      if (const std::uint32_t t = triangle.at(c, r); t != mesh::kNoTriangle) grid.at(c, r) = state[t];
  return grid;
}

int run_mesh(const Args& args) {
  const std::string& path = single_operand(args, "DEM or mesh file");
  const bool json = args.has("--json");
  const bool from_file = is_mesh_file(path);
  if (args.has("--height") && args.has("--altitude"))
    throw UsageError("--height and --altitude both set the eye; give one of them");
  if (from_file && (args.has("--lat") || args.has("--lon")))
    throw UsageError("a mesh file has no CRS Horizon can read: place the viewpoint with --observer X,Y");
  if (from_file && (args.has("--vertices") || args.has("--max-error") || args.has("--out")))
    throw UsageError("--vertices, --max-error and --out need a DEM as input, not a mesh file");
  geodesy::PointSpec spec = point_from_flags(args, {"--observer", "--lat", "--lon"});
  const mesh::PrepareOptions options = options_from_flags(args);
  mesh::CullQuery query;
  query.mode = args.has("--conservative") ? mesh::CullMode::kConservative : mesh::CullMode::kApproximate;
  if (auto view = args.pair("--azimuth")) query.azimuth_from = view->first, query.azimuth_to = view->second;
  const auto out = args.text("--out");
  if (out)
    if (auto s = check_output_path(*out, "--out", path, {".tif", ".tiff"}); !s.ok()) return report_error(s.error());
  const auto mesh_out = args.text("--mesh-out");
  if (mesh_out)
    if (auto s = check_output_path(*mesh_out, "--mesh-out", path, {".obj"}); !s.ok()) return report_error(s.error());
  const auto boxes_path = args.text("--boxes");
  std::vector<std::uint64_t> box_ids;
  std::vector<visibility::BoxSpec> box_specs;
  if (boxes_path) box_specs = read_boxes_file(*boxes_path, false, &box_ids);
  const auto vertices = args.positive_integer("--vertices").value_or(100'000);
  const double max_error = args.non_negative("--max-error").value_or(0.0);
  (void)args.positive_integer("--band");

  const auto started = std::chrono::steady_clock::now();
  Json report;
  report["input"] = path;
  mesh::Tin tin;
  std::optional<terrain::Dem> dem;
  mesh::LocalFrame frame;
  if (from_file) {
    auto read = mesh::read_tin(path);
    if (!read.ok()) return report_error(read.error());
    tin = std::move(*read);
  } else {
    auto loaded = load_dem(path, args);
    if (!loaded.ok()) return report_error(loaded.error());
    dem = std::move(*loaded);
    auto built = mesh::tin_from_dem(*dem, {static_cast<std::uint32_t>(vertices), max_error});
    if (!built.ok()) return report_error(built.error());
    tin = std::move(built->tin);
    report["fit"] = {{"max_error_m", built->fit.max_error}, {"rmse_m", built->fit.rmse},
                     {"cells_measured", built->fit.cells}};
    auto local = mesh::LocalFrame::for_dem(*dem);
    if (!local.ok()) return report_error(local.error());
    frame = std::move(*local);
  }
  const std::vector<mesh::TinVertex> crs_vertices = tin.vertices;
  frame.to_local(tin);

  // The eye: a DEM's point rules (its CRS or WGS84, above its ground); a
  // mesh file's, the surface of the mesh itself.
  mesh::TinVertex eye;
  if (dem) {
    if (args.has("--altitude")) spec.height = *args.number("--altitude"), spec.height_mode = geodesy::HeightMode::kAbsolute;
    else spec.height = args.non_negative("--height").value_or(2.0);
    auto point = geodesy::resolve_point(*dem, spec, "observer");
    if (!point.ok()) return report_error(point.error());
    eye = frame.to_local({point->x, point->y, point->elevation});
    report["observer"] = to_json(*point, lonlat_of(*dem, point->x, point->y));
  } else {
    const mesh::TinVisibility surface(tin);
    const auto ground = surface.height_at(spec.x, spec.y);
    if (args.has("--altitude")) {
      eye = {spec.x, spec.y, *args.number("--altitude")};
    } else {
      if (!ground)
        return report_error(make_error(ErrorCode::kOutOfRange,
                                       "observer (" + fixed(spec.x, 3) + ", " + fixed(spec.y, 3) + ") is off the mesh",
                                       "observer"));
      eye = {spec.x, spec.y, *ground + args.non_negative("--height").value_or(2.0)};
    }
    report["observer"] = {{"x", eye.x}, {"y", eye.y}, {"z", eye.z}};
  }

  const auto preparing = std::chrono::steady_clock::now();
  const auto cache = args.text("--cache");
  mesh::CacheUse cache_use;
  InterruptScope interrupt;  // Ctrl-C cancels the preparation cleanly
  ProgressBar bar("preparing");
  RunControl control;
  control.cancel = &interrupt.token();
  control.progress = bar.callback();
  auto prepared = cache ? mesh::prepare_cached(tin, options, *cache, &cache_use, &control)
                        : mesh::prepare_mesh(std::move(tin), options, &control);
  bar.finish();
  if (!prepared.ok()) return report_error(prepared.error());
  if (!cache_use.note.empty()) std::cerr << "horizon: warning: " << cache_use.note << '\n';
  if (cache) report["cache"] = {{"hit", cache_use.hit}, {"path", cache_use.path}, {"note", cache_use.note}};
  const double prepare_seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - preparing).count();
  const auto culling = std::chrono::steady_clock::now();
  auto answer = mesh::cull(*prepared, query);
  if (!answer.ok()) return report_error(answer.error());
  const double cull_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - culling).count();

  if (boxes_path) {
    // Each box's footprint corners into the frame, and their bounding box.
    std::vector<mesh::MeshBox> boxes;
    for (const visibility::BoxSpec& b : box_specs) {
      mesh::MeshBox m{INFINITY, INFINITY, -INFINITY, -INFINITY, b.z_min, b.z_max};
      for (double x : {b.x_min, b.x_max})
        for (double y : {b.y_min, b.y_max}) {
          const mesh::TinVertex p = frame.to_local({x, y, 0.0});
          m.x_min = std::min(m.x_min, p.x), m.x_max = std::max(m.x_max, p.x);
          m.y_min = std::min(m.y_min, p.y), m.y_max = std::max(m.y_max, p.y);
        }
      boxes.push_back(m);
    }
    auto registered = mesh::RegisteredBoxes::make(*prepared, boxes, options.horizons.threads);
    if (!registered.ok()) return report_error(registered.error());
    Json list = Json::array();
    std::size_t hidden = 0;
    for (std::size_t k = 0; k < boxes.size(); ++k) {
      const bool h = registered->hidden(*prepared, k, eye);
      hidden += h ? 1 : 0;
      Json item{{"index", k}, {"hidden", h}};
      if (!box_ids.empty()) item["id"] = box_ids[k];
      list.push_back(item);
    }
    report["boxes"] = {{"file", *boxes_path}, {"count", boxes.size()}, {"hidden_count", hidden}, {"boxes", list}};
  }

  const std::vector<std::uint8_t> state = mesh::triangle_states(*prepared, *answer);
  if (out) {
    if (auto s = terrain::write_geotiff(*out, rasterise(*dem, crs_vertices, *prepared, state), dem->georef, 255.0);
        !s.ok())
      return report_error(s.error());
  }
  if (mesh_out) {
    if (auto s = write_obj(*mesh_out, crs_vertices, prepared->tin.triangles); !s.ok()) return report_error(s.error());
  }

  const mesh::PrepareStats& st = prepared->stats;
  report["vertices"] = prepared->tin.vertices.size();
  report["triangles"] = prepared->tin.triangles.size();
  report["local_frame"] = frame.geographic() ? "tangent plane at the DEM's centre" : "the CRS";
  report["options"] = {{"sectors", prepared->sectors}, {"subsectors", options.horizons.subsectors},
                       {"seeds", options.crystals.seeds}, {"min_group", options.crystals.min_group_size},
                       {"max_groups", options.crystals.max_groups}, {"orphan_passes", options.crystals.max_orphan_passes},
                       {"merge_cutoff", options.merge_cutoff}, {"random_seed", options.crystals.random_seed}};
  report["prepare"] = {{"seconds", prepare_seconds}, {"horizon_seconds", st.horizon_seconds},
                       {"grouping_seconds", st.grouping_seconds}, {"hierarchy_seconds", st.hierarchy_seconds},
                       {"wall_seconds", st.wall_seconds}, {"groups", st.leaf_groups},
                       {"nodes", prepared->groups.size()}, {"levels", st.levels},
                       {"top_level", prepared->top_level.size()}, {"orphan_passes", st.orphan_passes},
                       {"always_visible_triangles", prepared->always_visible_count}};
  report["mode"] = query.mode == mesh::CullMode::kConservative ? "conservative" : "approximate";
  report["cull"] = {{"microseconds", cull_seconds * 1e6}, {"groups_tested", answer->groups_tested},
                    {"groups_culled", answer->groups_culled}, {"frustum_culled", answer->frustum_culled},
                    {"triangles_culled", answer->triangles_culled}, {"triangles_drawn", answer->triangles_visible}};
  Json drawn = Json::array();
  for (std::uint32_t g : answer->visible_groups)
    drawn.push_back({{"group", g}, {"first_triangle", prepared->groups[g].first_triangle},
                     {"triangle_count", prepared->groups[g].triangle_count}});
  report["drawn_groups"] = drawn;
  report["always_visible"] = {{"first_triangle", prepared->always_visible_first},
                              {"triangle_count", prepared->always_visible_count}};
  report["total_seconds"] = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
  if (json) {
    std::cout << report.dump(2) << '\n';
    return kExitOk;
  }
  std::cout << "TIN of " << path << ": " << prepared->tin.vertices.size() << " vertices, "
            << prepared->tin.triangles.size() << " triangles\n"
            << "  prepared:  " << fixed(prepare_seconds, 3) << " s" << (cache_use.hit ? " (from the cache)" : "") << " ("
            << prepared->sectors << '/'
            << options.horizons.subsectors << "; " << st.leaf_groups << " groups, " << prepared->groups.size()
            << " nodes, " << prepared->always_visible_count << " always-visible triangles)\n"
            << "  culled:    " << answer->triangles_culled << " triangles in " << answer->groups_culled << " of "
            << answer->groups_tested << " groups tested (" << report["mode"].get<std::string>() << ", "
            << fixed(cull_seconds * 1e6, 1) << " us)\n"
            << "  drawn:     " << answer->triangles_visible << " triangles in " << answer->visible_groups.size()
            << " groups and the always-visible set\n";
  if (boxes_path)
    std::cout << "  boxes:     " << report["boxes"]["hidden_count"].get<std::size_t>() << " of " << box_specs.size()
              << " hidden (walls; sound)\n";
  if (out) std::cout << "  wrote:     " << *out << '\n';
  if (mesh_out) std::cout << "  wrote:     " << *mesh_out << '\n';
  return kExitOk;
}

}  // namespace

const Command& mesh_command() {
  static const Command command{
      "mesh",
      "Prepare a TIN for per-frame culling and cull it from one viewpoint",
      "horizon mesh (DEM | MESH.obj | MESH.ply) (--observer X,Y | --lat LAT --lon LON) [options]",
      "A DEM is turned into a TIN by greedy insertion (--vertices, --max-error); an OBJ or PLY mesh is read as "
      "it is (a height field, x and y in metres). Each vertex's horizon is found in S sectors of K subsectors, "
      "the triangles are grown into visibility-aware groups and a merge hierarchy (Edmondson 2004), and the "
      "groups the viewpoint cannot see are culled. Geographic DEMs are prepared in a local metric frame. The "
      "answer names each drawn group's run of triangles in the prepared order (--mesh-out writes that order).",
      kFlags,
      "  horizon mesh data/dem/ecuador_andes_utm17s_10m_383x415.tif --vertices 3000 --observer 713500,9558500 --json\n"
      "  horizon mesh data/dem/rainier_summit_srtm3_400x400.tif --vertices 5000 --lat 46.85 --lon -121.76 \\\n"
      "      --conservative -o out/drawn.tif\n",
      run_mesh};
  return command;
}

}  // namespace horizon::cli
