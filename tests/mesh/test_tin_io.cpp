// Tests for mesh/tin_io.cpp (read_tin): small OBJ and PLY files written
// here, read back at full double precision; each refusal names the file and
// what is wrong.
#include <gtest/gtest.h>

#include <fstream>

#include "horizon/mesh/tin_io.hpp"
#include "test_support.hpp"

namespace horizon::mesh {
namespace {

std::string write(const testing::TempDir& dir, const std::string& name, const std::string& text) {
  const std::string path = dir.file(name);
  std::ofstream(path) << text;
  return path;
}

TEST(ReadTin, ReadsObjAtFullPrecision) {
  testing::TempDir dir;
  const std::string path = write(dir, "utm.obj",
                                 "# two triangles on UTM 45N\n"
                                 "v 450375.123456 3042016.654321 8848.25\n"
                                 "v 450385.123456 3042016.654321 8840.5\n"
                                 "v 450385.123456 3042026.654321 8830.75\n"
                                 "v 450375.123456 3042026.654321 8835\n"
                                 "f 1 2 3\n"
                                 "f 1 3 4\n");
  auto tin = read_tin(path);
  ASSERT_TRUE(tin.ok()) << tin.error().message;
  ASSERT_EQ(tin->vertices.size(), 4u);
  EXPECT_EQ(tin->vertices[0], (TinVertex{450375.123456, 3042016.654321, 8848.25}));
  EXPECT_EQ(tin->vertices[2], (TinVertex{450385.123456, 3042026.654321, 8830.75}));
  EXPECT_EQ(tin->triangles.size(), 2u);
}

TEST(ReadTin, ReadsPlyAndCutsAQuadIntoTwoTriangles) {
  testing::TempDir dir;
  const std::string ply = write(dir, "quad.ply",
                                "ply\nformat ascii 1.0\nelement vertex 4\nproperty double x\nproperty double y\n"
                                "property double z\nelement face 1\nproperty list uchar int vertex_indices\n"
                                "end_header\n0 0 1\n10 0 2\n10 10 3\n0 10 4\n4 0 1 2 3\n");
  auto tin = read_tin(ply);
  ASSERT_TRUE(tin.ok()) << tin.error().message;
  EXPECT_EQ(tin->vertices.size(), 4u);
  ASSERT_EQ(tin->triangles.size(), 2u);
  EXPECT_EQ(tin->triangles[0], (TinTriangle{0, 1, 2}));
  EXPECT_EQ(tin->triangles[1], (TinTriangle{0, 2, 3}));
}

TEST(ReadTin, MergesCornersWrittenOncePerFace) {
  testing::TempDir dir;
  // Each face with its own copies of its corners, as some exporters write.
  const std::string path = write(dir, "soup.obj",
                                 "v 0 0 1\nv 10 0 2\nv 10 10 3\n"
                                 "v 0 0 1\nv 10 10 3\nv 0 10 4\n"
                                 "f 1 2 3\nf 4 5 6\n");
  auto tin = read_tin(path);
  ASSERT_TRUE(tin.ok()) << tin.error().message;
  EXPECT_EQ(tin->vertices.size(), 4u);
  EXPECT_EQ(tin->triangles[1], (TinTriangle{0, 2, 3}));
}

TEST(ReadTin, NamesTheFileAndWhatIsWrong) {
  testing::TempDir dir;
  auto missing = read_tin(dir.file("none.obj"));
  ASSERT_FALSE(missing.ok());
  EXPECT_EQ(missing.error().code, ErrorCode::kNotFound);
  EXPECT_NE(missing.error().message.find("none.obj: no such mesh file"), std::string::npos);

  for (const char* name : {"mesh.stl", "mesh.off"}) {
    auto other = read_tin(write(dir, name, "solid x\nendsolid x\n"));
    ASSERT_FALSE(other.ok());
    EXPECT_EQ(other.error().code, ErrorCode::kUnsupported);
    EXPECT_NE(other.error().message.find("must be OBJ (.obj) or PLY (.ply), not '."), std::string::npos);
  }

  auto empty = read_tin(write(dir, "empty.obj", "# nothing here\n"));
  ASSERT_FALSE(empty.ok());
  EXPECT_EQ(empty.error().code, ErrorCode::kDataError);
  EXPECT_NE(empty.error().message.find("empty.obj: not a readable obj mesh"), std::string::npos)
      << empty.error().message;

  auto garbage = read_tin(write(dir, "garbage.ply", "this is not a ply file\n"));
  ASSERT_FALSE(garbage.ok());
  EXPECT_EQ(garbage.error().code, ErrorCode::kDataError);

  // PLY headers CGAL's reader would trust: a property before any element,
  // a count no file of this size can hold.
  auto orphan = read_tin(write(dir, "orphan.ply", "ply\nformat ascii 1.0\nproperty double x\nend_header\n"));
  ASSERT_FALSE(orphan.ok());
  EXPECT_NE(orphan.error().message.find("orphan.ply: PLY header line 3: a property before any element"),
            std::string::npos)
      << orphan.error().message;
  auto huge = read_tin(write(dir, "huge.ply",
                             "ply\nformat binary_little_endian 1.0\nelement vertex 4000000000\nproperty float x\n"
                             "end_header\n"));
  ASSERT_FALSE(huge.ok());
  EXPECT_NE(huge.error().message.find("element vertex claims 4000000000 items, more than the file's"),
            std::string::npos)
      << huge.error().message;

  auto fold = read_tin(write(dir, "fold.obj", "v 0 0 0\nv 2 0 0\nv 1 2 0\nv 1 1 5\nf 1 2 3\nf 1 2 4\n"));
  ASSERT_FALSE(fold.ok());
  EXPECT_EQ(fold.error().code, ErrorCode::kInvalidArgument);
  EXPECT_NE(fold.error().message.find("fold.obj: triangle 0 (vertices 0, 1, 2) and triangle 1"), std::string::npos)
      << fold.error().message;
}

}  // namespace
}  // namespace horizon::mesh
