#include "horizon/mesh/tin_io.hpp"

#include "mesh/ply_reader.hpp"

#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/IO/OBJ.h>

#include <algorithm>
#include <cctype>
#include <exception>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <tuple>
#include <vector>

namespace horizon::mesh {
namespace {

using Point = CGAL::Exact_predicates_inexact_constructions_kernel::Point_3;

std::string lower_extension(const std::string& path) {
  std::string ext = std::filesystem::path(path).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return std::tolower(c); });
  return ext;
}

// The whole file, for the PLY reader (it bounds every count by the bytes
// left, so it wants them all).
Result<std::string> slurp(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream bytes;
  bytes << in.rdbuf();
  if (!in.good() && !in.eof()) return make_error(ErrorCode::kIoError, path + ": cannot read the file", "mesh");
  return bytes.str();
}

// An OBJ file through CGAL's reader, which sizes nothing from a count in
// the file (a face's corners are the numbers on its line).
Result<detail::PolygonSoup> read_obj(const std::string& path) {
  std::vector<Point> points;
  std::vector<std::vector<std::size_t>> faces;
  bool read = false;
  try {
    read = CGAL::IO::read_OBJ(path, points, faces);
  } catch (const std::exception&) {
    read = false;
  }
  if (!read) return make_error(ErrorCode::kDataError, path + ": not a readable OBJ mesh (CGAL's reader stopped)", "mesh");
  detail::PolygonSoup soup;
  soup.points.reserve(points.size());
  for (const Point& p : points) soup.points.push_back({p.x(), p.y(), p.z()});
  soup.faces.reserve(faces.size());
  for (const auto& face : faces) soup.faces.emplace_back(face.begin(), face.end());
  return soup;
}

}  // namespace

Result<Tin> read_tin(const std::string& path) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec))
    return make_error(ErrorCode::kNotFound, path + ": no such mesh file", "mesh");
  const std::string ext = lower_extension(path);
  // Not OFF, though CGAL reads it: its reader converts a face's corner
  // count from a double unchecked (undefined behaviour on 1e20; fuzz_mesh).
  if (ext != ".obj" && ext != ".ply")
    return make_error(ErrorCode::kUnsupported, path + ": a mesh file must be OBJ (.obj) or PLY (.ply), not '" + ext + "'",
                      "mesh");
  Result<detail::PolygonSoup> soup = make_error(ErrorCode::kInternal, "", "mesh");
  if (ext == ".ply") {
    auto bytes = slurp(path);
    if (!bytes.ok()) return bytes.error();
    soup = detail::read_ply(*bytes, path);
  } else {
    soup = read_obj(path);
  }
  if (!soup.ok()) return soup.error();
  const auto& points = soup->points;
  const auto& faces = soup->faces;
  if (points.empty() || faces.empty())
    return make_error(ErrorCode::kDataError,
                      path + ": the file has " + std::to_string(points.size()) + " vertices and " +
                          std::to_string(faces.size()) + " faces; a TIN needs both",
                      "mesh");
  // Merge points at exactly the same place; map the file's indices to ours.
  Tin tin;
  std::vector<std::uint32_t> index(points.size());
  std::map<std::tuple<double, double, double>, std::uint32_t> at;
  for (std::size_t i = 0; i < points.size(); ++i) {
    const auto key = std::tuple(points[i][0], points[i][1], points[i][2]);
    auto [it, fresh] = at.emplace(key, static_cast<std::uint32_t>(tin.vertices.size()));
    if (fresh) tin.vertices.push_back({points[i][0], points[i][1], points[i][2]});
    index[i] = it->second;
  }
  for (std::size_t f = 0; f < faces.size(); ++f) {
    const auto& face = faces[f];
    if (face.size() < 3)
      return make_error(ErrorCode::kDataError,
                        path + ": face " + std::to_string(f) + " has " + std::to_string(face.size()) +
                            " corners; a TIN's faces need three or more",
                        "mesh");
    for (std::uint64_t c : face)
      if (c >= points.size())
        return make_error(ErrorCode::kDataError,
                          path + ": face " + std::to_string(f) + " names vertex " + std::to_string(c) +
                              ", but the file has " + std::to_string(points.size()),
                          "mesh");
    for (std::size_t c = 1; c + 1 < face.size(); ++c)
      tin.triangles.push_back({index[face[0]], index[face[c]], index[face[c + 1]]});
  }
  HORIZON_RETURN_IF_ERROR(check_height_field(tin, path));
  return tin;
}

}  // namespace horizon::mesh
