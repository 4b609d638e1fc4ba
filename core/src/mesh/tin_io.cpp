#include "horizon/mesh/tin_io.hpp"

#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/IO/polygon_soup_io.h>

#include <algorithm>
#include <cctype>
#include <filesystem>
#include <map>
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

}  // namespace

Result<Tin> read_tin(const std::string& path) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec))
    return make_error(ErrorCode::kNotFound, path + ": no such mesh file", "mesh");
  const std::string ext = lower_extension(path);
  if (ext != ".obj" && ext != ".ply" && ext != ".off")
    return make_error(ErrorCode::kUnsupported,
                      path + ": a mesh file must be OBJ (.obj), PLY (.ply) or OFF (.off), not '" + ext + "'", "mesh");
  std::vector<Point> points;
  std::vector<std::vector<std::size_t>> faces;
  if (!CGAL::IO::read_polygon_soup(path, points, faces) || points.empty())
    return make_error(ErrorCode::kDataError,
                      path + ": not a readable " + ext.substr(1) + " mesh (CGAL's reader stopped; a TIN needs "
                      "vertices and triangle faces)", "mesh");
  // Merge points at exactly the same place; map the file's indices to ours.
  Tin tin;
  std::vector<std::uint32_t> index(points.size());
  std::map<std::tuple<double, double, double>, std::uint32_t> at;
  for (std::size_t i = 0; i < points.size(); ++i) {
    const auto key = std::tuple(points[i].x(), points[i].y(), points[i].z());
    auto [it, fresh] = at.emplace(key, static_cast<std::uint32_t>(tin.vertices.size()));
    if (fresh) tin.vertices.push_back({points[i].x(), points[i].y(), points[i].z()});
    index[i] = it->second;
  }
  for (std::size_t f = 0; f < faces.size(); ++f) {
    const auto& face = faces[f];
    if (face.size() < 3)
      return make_error(ErrorCode::kDataError,
                        path + ": face " + std::to_string(f) + " has " + std::to_string(face.size()) +
                            " corners; a TIN's faces need three or more",
                        "mesh");
    for (std::size_t c : face)
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
