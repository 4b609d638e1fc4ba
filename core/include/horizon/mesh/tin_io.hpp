// horizon/mesh/tin_io.hpp — TINs read from mesh files.
//
// Formats: Wavefront OBJ (.obj), Stanford PLY (.ply, text or binary) and
// OFF (.off), read by CGAL's polygon-soup readers in double precision (a
// float reader would round a UTM easting to centimetres). Coordinates are
// taken as they are: x, y in the CRS the caller says the file is in, z in
// metres. A face of more than three corners is cut into a fan of
// triangles from its first corner; points at exactly the same (x, y, z)
// are merged into one vertex (exporters that write each face's corners
// anew). The result has passed check_height_field (tin.hpp).
//
// Errors: kNotFound (no such file), kUnsupported (another extension),
// kDataError (the reader refused the file, or a face has fewer than three
// corners), kInvalidArgument (not a height field; the element named).
#pragma once

#include <string>

#include "horizon/common/error.hpp"
#include "horizon/mesh/tin.hpp"

namespace horizon::mesh {

Result<Tin> read_tin(const std::string& path);

}  // namespace horizon::mesh
