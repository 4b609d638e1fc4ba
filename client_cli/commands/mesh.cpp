// `horizon mesh prepare INPUT` and `horizon mesh cull INPUT --observer ...`:
// a TIN prepared for per-frame culling (horizons, crystal groups,
// hierarchy: core's mesh/mesh_model.hpp), and culled from one viewpoint,
// embedded or by a daemon's MeshService (--server, remote/mesh.cpp).
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iostream>

#include "commands/command.hpp"
#include "horizon/mesh/cull.hpp"
#include "horizon/mesh/mesh_model.hpp"
#include "horizon/mesh/tin_raster.hpp"
#include "horizon/terrain/geotiff_writer.hpp"
#include "inputs.hpp"
#include "interrupt.hpp"
#include "output.hpp"
#include "progress.hpp"
#include "remote/remote.hpp"

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
    {"--merge-cutoff", "", "F",
     "A merged group whose circle covers more than F of the mesh is top-level (default 0.25)"},
    {"--random-seed", "", "N", "Seed of the crystal seeding (default 1; the same seed gives the same groups)"},
    {"--azimuth", "", "FROM,TO",
     "The view: degrees clockwise from north, FROM turning clockwise to TO (default all round)"},
    {"--conservative", "", "",
     "Never cull a triangle the viewpoint can see (walls; default: the thesis's approximate test)"},
    {"--out", "-o", "OUT.tif",
     "DEM input: a raster on the DEM's grid: 1 drawn, 0 culled, 2 always visible, 255 no triangle"},
    {"--mesh-out", "", "OUT.obj", "Write the TIN with its triangles in group order (the ranges the answer names)"},
    {"--boxes", "", "FILE.csv",
     "Also cull object boxes: [id,]x_min,y_min,x_max,y_max,z_min,z_max a line (the input's CRS, absolute metres); "
     "hidden means no point of the box can be seen"},
    {"--lonlat", "", "", "--boxes are in WGS84 degrees (x = longitude, y = latitude; DEM input only)"},
    {"--cache", "", "DIR",
     "Keep the prepared mesh in DIR, keyed by the TIN and the knobs, and load it from there next time"},
    {"--threads", "", "N", "Worker threads for preparing (default 0 = all cores)"},
    {"--band", "", "N", "DEM band to read, 1-based (required when the file has several)"},
    {"--registered-boxes", "", "", "With --server: also cull the boxes registered with the daemon's mesh"},
    {"--json", "", "", "Print a JSON document (cull: with every drawn group's triangle range)"},
    remote::kServerFlag,
    remote::kDeadlineFlag,
    remote::kCaFlag,
    remote::kClientCertFlag,
    remote::kTokenFileFlag,
};

// The flags only `horizon mesh cull` takes, and those only a local input takes.
constexpr std::string_view kCullOnly[] = {"--observer", "--lat",          "--lon", "--height", "--altitude",
                                          "--azimuth",  "--conservative", "--out", "--boxes",  "--registered-boxes"};
constexpr std::string_view kLocalOnly[] = {"--vertices",    "--max-error",  "--sectors",       "--seeds",
                                           "--min-group",   "--max-groups", "--orphan-passes", "--merge-cutoff",
                                           "--random-seed", "--out",        "--mesh-out",      "--boxes",
                                           "--cache",       "--threads",    "--band"};

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

// The model of a local input: a DEM made a TIN, or a mesh file; prepared
// (through --cache) with the progress bar up and Ctrl-C cancelling.
Result<mesh::MeshModel> load_model(const Args& args, const std::string& path) {
  mesh::MeshModelOptions options;
  options.prepare = options_from_flags(args);
  options.greedy.max_vertices = static_cast<std::uint32_t>(args.positive_integer("--vertices").value_or(100'000));
  options.greedy.max_error = args.non_negative("--max-error").value_or(0.0);
  if (auto cache = args.text("--cache")) options.cache_dir = *cache;
  InterruptScope interrupt;  // Ctrl-C cancels the preparation cleanly
  ProgressBar bar("preparing");
  RunControl control;
  control.cancel = &interrupt.token();
  control.progress = bar.callback();
  Result<mesh::MeshModel> model = make_error(ErrorCode::kInternal, "not loaded", "");
  if (is_mesh_file(path)) {
    model = mesh::MeshModel::from_file(path, options, &control);
  } else {
    auto dem = load_dem(path, args);
    if (!dem.ok()) return dem.error();
    model = mesh::MeshModel::from_dem(std::move(*dem), options, &control);
  }
  bar.finish();
  if (model.ok() && !model->cache_use().note.empty())
    std::cerr << "horizon: warning: " << model->cache_use().note << '\n';
  return model;
}

// What a prepared model is, for the JSON report of both verbs.
Json describe(const mesh::MeshModel& model, const mesh::PrepareOptions& options, const Args& args) {
  const mesh::PreparedMesh& p = model.prepared();
  const mesh::PrepareStats& st = p.stats;
  Json report;
  report["vertices"] = p.tin.vertices.size();
  report["triangles"] = p.tin.triangles.size();
  if (model.fit())
    report["fit"] = {
        {"max_error_m", model.fit()->max_error}, {"rmse_m", model.fit()->rmse}, {"cells_measured", model.fit()->cells}};
  report["local_frame"] = model.frame().geographic() ? "tangent plane at the DEM's centre" : "the CRS";
  report["options"] = {{"sectors", p.sectors},
                       {"subsectors", options.horizons.subsectors},
                       {"seeds", options.crystals.seeds},
                       {"min_group", options.crystals.min_group_size},
                       {"max_groups", options.crystals.max_groups},
                       {"orphan_passes", options.crystals.max_orphan_passes},
                       {"merge_cutoff", options.merge_cutoff},
                       {"random_seed", options.crystals.random_seed}};
  report["prepare"] = {{"seconds", model.prepare_seconds()},
                       {"horizon_seconds", st.horizon_seconds},
                       {"grouping_seconds", st.grouping_seconds},
                       {"hierarchy_seconds", st.hierarchy_seconds},
                       {"wall_seconds", st.wall_seconds},
                       {"groups", st.leaf_groups},
                       {"nodes", p.groups.size()},
                       {"levels", st.levels},
                       {"top_level", p.top_level.size()},
                       {"orphan_passes", st.orphan_passes},
                       {"always_visible_triangles", p.always_visible_count},
                       {"resident_bytes", model.memory_bytes()}};
  if (args.has("--cache"))
    report["cache"] = {
        {"hit", model.cache_use().hit}, {"path", model.cache_use().path}, {"note", model.cache_use().note}};
  return report;
}

void print_prepared(const std::string& path, const mesh::MeshModel& model, const mesh::PrepareOptions& options) {
  const mesh::PreparedMesh& p = model.prepared();
  std::cout << "TIN of " << path << ": " << p.tin.vertices.size() << " vertices, " << p.tin.triangles.size()
            << " triangles\n";
  if (model.fit())
    std::cout << "  fit:       max " << fixed(model.fit()->max_error, 2) << " m, RMSE " << fixed(model.fit()->rmse, 2)
              << " m against the DEM\n";
  std::cout << "  prepared:  " << fixed(model.prepare_seconds(), 3) << " s"
            << (model.cache_use().hit ? " (from the cache)" : "") << " (" << p.sectors << '/'
            << options.horizons.subsectors << "; " << p.stats.leaf_groups << " groups, " << p.groups.size()
            << " nodes, " << p.always_visible_count << " always-visible triangles)\n";
}

// Writes --mesh-out when given.
Status write_mesh_out(const Args& args, const mesh::MeshModel& model) {
  const auto mesh_out = args.text("--mesh-out");
  if (!mesh_out) return Status::Ok();
  HORIZON_RETURN_IF_ERROR(write_obj(*mesh_out, model.crs_vertices(), model.prepared().tin.triangles));
  std::cout << (args.has("--json") ? "" : "  wrote:     " + *mesh_out + "\n");
  return Status::Ok();
}

int run_prepare(const Args& args, const std::string& path) {
  for (std::string_view flag : kCullOnly)
    if (args.has(flag)) throw UsageError(args.typed(flag) + ": a flag of `horizon mesh cull`, not of prepare");
  if (args.has("--server"))
    throw UsageError("--server: a daemon prepares its meshes from its config (\"meshes\"); prepare runs locally");
  if (is_mesh_file(path) && (args.has("--vertices") || args.has("--max-error")))
    throw UsageError("--vertices and --max-error need a DEM as input, not a mesh file");
  if (auto mesh_out = args.text("--mesh-out"))
    if (auto s = check_output_path(*mesh_out, "--mesh-out", path, {".obj"}); !s.ok()) return report_error(s.error());
  (void)args.positive_integer("--band");
  const mesh::PrepareOptions options = options_from_flags(args);
  auto model = load_model(args, path);
  if (!model.ok()) return report_error(model.error());
  const bool json = args.has("--json");
  if (json) {
    Json report{{"input", path}};
    report.update(describe(*model, options, args));
    if (auto s = write_mesh_out(args, *model); !s.ok()) return report_error(s.error());
    if (auto mesh_out = args.text("--mesh-out")) report["mesh_out"] = *mesh_out;
    std::cout << report.dump(2) << '\n';
    return kExitOk;
  }
  print_prepared(path, *model, options);
  if (auto s = write_mesh_out(args, *model); !s.ok()) return report_error(s.error());
  return kExitOk;
}

int run_cull(const Args& args, const std::string& path) {
  const bool json = args.has("--json");
  if (args.has("--height") && args.has("--altitude"))
    throw UsageError("--height and --altitude both set the eye; give one of them");
  geodesy::PointSpec spec = point_from_flags(args, {"--observer", "--lat", "--lon"});
  if (args.has("--altitude"))
    spec.height = *args.number("--altitude"), spec.height_mode = geodesy::HeightMode::kAbsolute;
  else
    spec.height = args.non_negative("--height").value_or(2.0);
  mesh::CullQuery query;
  query.mode = args.has("--conservative") ? mesh::CullMode::kConservative : mesh::CullMode::kApproximate;
  if (auto view = args.pair("--azimuth")) query.azimuth_from = view->first, query.azimuth_to = view->second;

  if (args.has("--server")) {
    for (std::string_view flag : kLocalOnly)
      if (args.has(flag))
        throw UsageError(args.typed(flag) +
                         ": applies to a local input; a daemon's mesh is prepared with the knobs of its config"
                         " (--boxes: use --registered-boxes for the boxes registered there)");
    remote::MeshCullInputs inputs{path,
                                  spec,
                                  query.azimuth_from,
                                  query.azimuth_to,
                                  query.mode == mesh::CullMode::kConservative,
                                  args.has("--registered-boxes"),
                                  json};
    return remote::run_mesh_cull(args, inputs);
  }
  if (args.has("--registered-boxes"))
    throw UsageError("--registered-boxes: a flag of --server; locally, give --boxes FILE");
  const bool from_file = is_mesh_file(path);
  if (from_file && (args.has("--lat") || args.has("--lon")))
    throw UsageError("a mesh file has no CRS Horizon can read: place the viewpoint with --observer X,Y");
  if (from_file && (args.has("--vertices") || args.has("--max-error") || args.has("--out")))
    throw UsageError("--vertices, --max-error and --out need a DEM as input, not a mesh file");
  const auto out = args.text("--out");
  if (out)
    if (auto s = check_output_path(*out, "--out", path, {".tif", ".tiff"}); !s.ok()) return report_error(s.error());
  if (auto mesh_out = args.text("--mesh-out"))
    if (auto s = check_output_path(*mesh_out, "--mesh-out", path, {".obj"}); !s.ok()) return report_error(s.error());
  const auto boxes_path = args.text("--boxes");
  std::vector<std::uint64_t> box_ids;
  std::vector<visibility::BoxSpec> box_specs;
  if (args.has("--lonlat") && !boxes_path) throw UsageError("--lonlat: says how --boxes are given; add --boxes");
  if (args.has("--lonlat") && from_file)
    throw UsageError("--lonlat: a mesh file has no CRS Horizon can read; give the boxes in its frame");
  if (boxes_path) box_specs = read_boxes_file(*boxes_path, args.has("--lonlat"), &box_ids);
  (void)args.positive_integer("--band");
  const mesh::PrepareOptions options = options_from_flags(args);

  const auto started = std::chrono::steady_clock::now();
  auto model = load_model(args, path);
  if (!model.ok()) return report_error(model.error());
  auto eye = model->eye(spec, "observer");
  if (!eye.ok()) return report_error(eye.error());
  query.camera = eye->local;
  if (boxes_path)
    if (auto s = model->register_boxes(box_specs, options.horizons.threads); !s.ok()) return report_error(s.error());

  const auto culling = std::chrono::steady_clock::now();
  auto answer = mesh::cull(model->prepared(), query);
  if (!answer.ok()) return report_error(answer.error());
  const double cull_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - culling).count();
  const mesh::PreparedMesh& prepared = model->prepared();

  Json report;
  report["input"] = path;
  report.update(describe(*model, options, args));
  if (const terrain::Dem* dem = model->dem()) {
    geodesy::GridPoint point;
    point.x = eye->crs.x, point.y = eye->crs.y, point.elevation = eye->crs.z, point.ground = eye->ground;
    const terrain::GeoTransform& t = dem->georef.transform;
    point.col = t.col_at(point.x), point.row = t.row_at(point.y);
    report["observer"] = to_json(point, lonlat_of(*dem, point.x, point.y));
  } else {
    report["observer"] = {{"x", eye->crs.x}, {"y", eye->crs.y}, {"z", eye->crs.z}};
  }
  if (boxes_path) {
    const mesh::RegisteredBoxes& boxes = *model->boxes();
    Json list = Json::array();
    std::size_t hidden = 0;
    for (std::size_t k = 0; k < boxes.size(); ++k) {
      const bool h = boxes.hidden(prepared, k, eye->local);
      hidden += h ? 1 : 0;
      Json item{{"index", k}, {"hidden", h}};
      if (!box_ids.empty()) item["id"] = box_ids[k];
      list.push_back(item);
    }
    report["boxes"] = {{"file", *boxes_path}, {"count", boxes.size()}, {"hidden_count", hidden}, {"boxes", list}};
  }
  const std::vector<std::uint8_t> state = mesh::triangle_states(prepared, *answer);
  if (out) {
    const terrain::Dem& dem = *model->dem();
    if (auto s =
            terrain::write_geotiff(*out, rasterise(dem, model->crs_vertices(), prepared, state), dem.georef, 255.0);
        !s.ok())
      return report_error(s.error());
  }
  if (auto mesh_out = args.text("--mesh-out"))
    if (auto s = write_obj(*mesh_out, model->crs_vertices(), prepared.tin.triangles); !s.ok())
      return report_error(s.error());

  report["mode"] = query.mode == mesh::CullMode::kConservative ? "conservative" : "approximate";
  report["cull"] = {{"microseconds", cull_seconds * 1e6},           {"groups_tested", answer->groups_tested},
                    {"groups_culled", answer->groups_culled},       {"frustum_culled", answer->frustum_culled},
                    {"triangles_culled", answer->triangles_culled}, {"triangles_drawn", answer->triangles_visible}};
  Json drawn = Json::array();
  for (std::uint32_t g : answer->visible_groups)
    drawn.push_back({{"group", g},
                     {"first_triangle", prepared.groups[g].first_triangle},
                     {"triangle_count", prepared.groups[g].triangle_count}});
  report["drawn_groups"] = drawn;
  report["always_visible"] = {{"first_triangle", prepared.always_visible_first},
                              {"triangle_count", prepared.always_visible_count}};
  report["total_seconds"] = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
  if (json) {
    std::cout << report.dump(2) << '\n';
    return kExitOk;
  }
  print_prepared(path, *model, options);
  std::cout << "  culled:    " << answer->triangles_culled << " triangles in " << answer->groups_culled << " of "
            << answer->groups_tested << " groups tested (" << report["mode"].get<std::string>() << ", "
            << fixed(cull_seconds * 1e6, 1) << " us)\n"
            << "  drawn:     " << answer->triangles_visible << " triangles in " << answer->visible_groups.size()
            << " groups and the always-visible set\n";
  if (boxes_path)
    std::cout << "  boxes:     " << report["boxes"]["hidden_count"].get<std::size_t>() << " of " << box_specs.size()
              << " hidden (walls; sound)\n";
  if (out) std::cout << "  wrote:     " << *out << '\n';
  if (auto mesh_out = args.text("--mesh-out")) std::cout << "  wrote:     " << *mesh_out << '\n';
  return kExitOk;
}

int run_mesh(const Args& args) {
  const auto& operands = args.positionals();
  if (operands.empty()) throw UsageError("missing the verb: `horizon mesh prepare INPUT` or `horizon mesh cull INPUT`");
  const std::string& verb = operands.front();
  if (verb != "prepare" && verb != "cull")
    throw UsageError("unknown verb '" + verb + "': expected prepare or cull (horizon mesh prepare|cull INPUT ...)");
  if (operands.size() < 2)
    throw UsageError("missing the " +
                     std::string(verb == "cull" && args.has("--server") ? "mesh name" : "DEM or mesh file") +
                     " operand");
  if (operands.size() > 2) throw UsageError("unexpected extra operand '" + operands[2] + "'");
  return verb == "prepare" ? run_prepare(args, operands[1]) : run_cull(args, operands[1]);
}

}  // namespace

const Command& mesh_command() {
  static const Command command{
      "mesh",
      "Prepare a TIN for per-frame culling, and cull it from one viewpoint",
      "horizon mesh prepare (DEM | MESH.obj | MESH.ply) [options]\n"
      "       horizon mesh cull (DEM | MESH.obj | MESH.ply) (--observer X,Y | --lat LAT --lon LON) [options]\n"
      "       horizon mesh cull MESH --server HOST:PORT (--observer X,Y | --lat LAT --lon LON) [options]",
      "A DEM is turned into a TIN by greedy insertion (--vertices, --max-error); an OBJ or PLY mesh is read as "
      "it is (a height field, x and y in metres). Each vertex's horizon is found in S sectors of K subsectors, "
      "the triangles are grown into visibility-aware groups and a merge hierarchy (Edmondson 2004): `prepare` "
      "stops there (with --cache it keeps the result for the next run, with --mesh-out it writes the TIN in "
      "group order); `cull` then culls the groups the viewpoint cannot see. Geographic DEMs are prepared in a "
      "local metric frame. The answer names each drawn group's run of triangles in the prepared order "
      "(--mesh-out writes that order). With --server, MESH names one of the daemon's configured meshes, "
      "prepared when it loaded.",
      kFlags,
      "  horizon mesh prepare data/dem/ecuador_andes_utm17s_10m_383x415.tif --vertices 3000 --cache out/meshes\n"
      "  horizon mesh cull data/dem/ecuador_andes_utm17s_10m_383x415.tif --vertices 3000 --observer 713500,9558500 "
      "--json\n"
      "  horizon mesh cull data/dem/rainier_summit_srtm3_400x400.tif --vertices 5000 --lat 46.85 --lon -121.76 \\\n"
      "      --conservative -o out/drawn.tif\n"
      "  horizon mesh cull rainier_tin --server localhost:50051 --lat 46.85 --lon -121.76 --json\n",
      run_mesh};
  return command;
}

}  // namespace horizon::cli
