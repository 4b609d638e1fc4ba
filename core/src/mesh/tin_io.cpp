#include "horizon/mesh/tin_io.hpp"

#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/IO/polygon_soup_io.h>

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

// A PLY header checked before CGAL's reader sees it, which trusts it: a
// property before any element indexes an empty list (found by fuzz_mesh),
// and an element's count sizes what is read. Each line must be one CGAL
// reads as intended; counts are bounded by the file's size (a vertex or
// face takes a byte at least).
Status check_ply_header(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  const auto bytes = std::filesystem::file_size(path);
  auto refuse = [&](std::size_t line, const std::string& why) {
    return make_error(ErrorCode::kDataError, path + ": PLY header line " + std::to_string(line) + ": " + why, "mesh");
  };
  std::string line;
  bool element = false;
  for (std::size_t number = 1; std::getline(in, line); ++number) {
    if (number > 10'000) return refuse(number, "no end_header in the first 10 000 lines");
    std::istringstream words(line);
    std::string keyword;
    words >> keyword;
    if (number == 1) {
      if (keyword != "ply") return refuse(1, "a PLY file starts with 'ply'");
    } else if (number == 2) {
      std::string format;
      words >> format;
      if (keyword != "format" || (format != "ascii" && format != "binary_little_endian" && format != "binary_big_endian"))
        return refuse(2, "expected 'format ascii|binary_little_endian|binary_big_endian 1.0'");
    } else if (keyword == "element") {
      std::string name;
      std::uint64_t count = 0;
      if (!(words >> name >> count)) return refuse(number, "an element needs a name and a count");
      if (count > bytes) return refuse(number, "element " + name + " claims " + std::to_string(count) +
                                                   " items, more than the file's " + std::to_string(bytes) + " bytes");
      element = true;
    } else if (keyword == "property") {
      if (!element) return refuse(number, "a property before any element");
      // CGAL reads coordinates as float or double only (another type is a
      // null dereference there).
      std::string type, name;
      words >> type >> name;
      if ((name == "x" || name == "y" || name == "z") && type != "float" && type != "float32" && type != "double" &&
          type != "float64")
        return refuse(number, "coordinate " + name + " is " + type + "; it must be float or double");
    } else if (keyword == "end_header") {
      return Status::Ok();
    }
  }
  return make_error(ErrorCode::kDataError, path + ": a PLY header without end_header", "mesh");
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
  if (ext == ".ply") HORIZON_RETURN_IF_ERROR(check_ply_header(path));
  std::vector<Point> points;
  std::vector<std::vector<std::size_t>> faces;
  bool read = false;
  try {  // CGAL's readers throw on some corrupt files (a list's length past a vector's limit)
    read = CGAL::IO::read_polygon_soup(path, points, faces);
  } catch (const std::exception&) {
    read = false;
  }
  if (!read || points.empty())
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
