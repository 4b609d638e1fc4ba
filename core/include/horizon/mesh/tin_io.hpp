// horizon/mesh/tin_io.hpp — TINs read from mesh files.
//
// Formats: Wavefront OBJ (.obj), read by CGAL's OBJ reader, and Stanford
// PLY (.ply: ascii, binary little- or big-endian), read by our own reader
// (CGAL's trusts the file's counts; see src/mesh/ply_reader.hpp). Both
// read in double precision (a float reader would round a UTM easting to
// centimetres). Not OFF: CGAL's OFF reader has undefined behaviour on a
// corrupt face line. Coordinates are taken as they are: x, y in the CRS
// the caller says the file is in, z in metres. A face of more than three
// corners is cut into a fan of triangles from its first corner; points at
// exactly the same (x, y, z) are merged into one vertex (exporters that
// write each face's corners anew). The result has passed
// check_height_field (tin.hpp).
//
// A PLY file's memory is bounded by its size: no element or list is sized
// from a count the bytes left in the file cannot hold. PLY errors name the
// header line, or the element, item and property. Triangle numbers in
// height-field errors are the file's face numbers when every face is a
// triangle.
//
// Errors: kNotFound (no such file), kUnsupported (another extension),
// kDataError (a bad PLY header or body, CGAL refused the OBJ file, no
// vertices or no faces, a face of fewer than three corners or naming a
// vertex the file lacks), kIoError (the file cannot be read),
// kInvalidArgument (not a height field; the element named).
#pragma once

#include <string>

#include "horizon/common/error.hpp"
#include "horizon/mesh/tin.hpp"

namespace horizon::mesh {

Result<Tin> read_tin(const std::string& path);

}  // namespace horizon::mesh
