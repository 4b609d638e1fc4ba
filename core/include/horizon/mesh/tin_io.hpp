// horizon/mesh/tin_io.hpp — TINs read from mesh files.
//
// Formats: Wavefront OBJ (.obj) and Stanford PLY (.ply, text or binary),
// read by CGAL's polygon-soup readers in double precision (a float reader
// would round a UTM easting to centimetres). Not OFF: CGAL's OFF reader
// has undefined behaviour on a corrupt face line. Coordinates are
// taken as they are: x, y in the CRS the caller says the file is in, z in
// metres. A face of more than three corners is cut into a fan of
// triangles from its first corner; points at exactly the same (x, y, z)
// are merged into one vertex (exporters that write each face's corners
// anew). The result has passed check_height_field (tin.hpp).
//
// A PLY header is checked first (CGAL's reader trusts it): its first two
// lines, every property after an element, coordinates float or double, no
// element counting more items than the file has bytes. Exceptions from the
// reader become kDataError. Triangle numbers in errors are the file's face
// numbers when every face is a triangle.
//
// Errors: kNotFound (no such file), kUnsupported (another extension),
// kDataError (a bad PLY header, the reader refused the file, or a face has
// fewer than three corners), kInvalidArgument (not a height field; the
// element named).
#pragma once

#include <string>

#include "horizon/common/error.hpp"
#include "horizon/mesh/tin.hpp"

namespace horizon::mesh {

Result<Tin> read_tin(const std::string& path);

}  // namespace horizon::mesh
