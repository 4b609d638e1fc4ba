// mesh/ply_reader.hpp (private) — Stanford PLY files as a polygon soup.
//
// Our own reader rather than CGAL's: CGAL 5.5's PLY reader trusts the
// file (a property before any element indexes an empty list, an integer
// coordinate is a null dereference, a list length sizes a vector before a
// byte of it is read: a 4-billion-corner face asks for 16 GB). Here
// nothing is sized from a count the file's remaining bytes cannot hold, and
// every refusal names the header line or the element and item.
//
// Read: format ascii, binary_little_endian, binary_big_endian (version
// 1.0); every scalar type of the standard (char/int8 … double/float64);
// comment and obj_info lines. The "vertex" element must have x, y, z (any
// scalar type, read as double); the "face" element must have a list named
// vertex_indices or vertex_index with an integral count and integral
// items. Other elements and properties are read past. A file may hold no
// face element (then the soup has no faces; the caller refuses it).
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "horizon/common/error.hpp"

namespace horizon::mesh::detail {

struct PolygonSoup {
  std::vector<std::array<double, 3>> points;
  std::vector<std::vector<std::uint64_t>> faces;  // indices into points, as the file wrote them
};

// `bytes` is the whole file; `name` is how errors name it (its path).
Result<PolygonSoup> read_ply(const std::string& bytes, const std::string& name);

}  // namespace horizon::mesh::detail
