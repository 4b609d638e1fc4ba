// Tests for mesh/tin_io.cpp (read_tin): small OBJ and PLY files written
// here, read back at full double precision; each refusal names the file and
// what is wrong.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <cstring>
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

// A binary PLY body, scalar by scalar, in either byte order.
class PlyBytes {
 public:
  explicit PlyBytes(bool big_endian) : big_(big_endian) {}
  template <class T>
  PlyBytes& put(T value) {
    char raw[sizeof(T)];
    std::memcpy(raw, &value, sizeof(T));
    if (big_) std::reverse(raw, raw + sizeof(T));
    bytes_.append(raw, sizeof(T));
    return *this;
  }
  const std::string& bytes() const { return bytes_; }

 private:
  bool big_;
  std::string bytes_;
};

std::string binary_quad(bool big_endian) {
  // x, y as double, z as int, a normal and a colour to read past; a face
  // list with a uchar length and uint indices, a per-face flag; an "edge"
  // element no TIN uses.
  std::string text = std::string("ply\r\nformat ") + (big_endian ? "binary_big_endian" : "binary_little_endian") +
                     " 1.0\ncomment made by hand\nelement vertex 4\nproperty double x\nproperty double y\n"
                     "property float nx\nproperty int z\nproperty uchar red\nelement face 2\n"
                     "property list uchar uint vertex_indices\nproperty short flag\nelement edge 1\n"
                     "property list ushort int pair\nend_header\n";
  PlyBytes body(big_endian);
  const double xy[4][2] = {{450375.123456, 3042016.654321}, {450385.5, 3042016.654321}, {450385.5, 3042026.25},
                           {450375.123456, 3042026.25}};
  for (int v = 0; v < 4; ++v) body.put(xy[v][0]).put(xy[v][1]).put(0.5f).put(std::int32_t{8800 + v}).put(std::uint8_t{7});
  body.put(std::uint8_t{3}).put(std::uint32_t{0}).put(std::uint32_t{1}).put(std::uint32_t{2}).put(std::int16_t{-1});
  body.put(std::uint8_t{3}).put(std::uint32_t{0}).put(std::uint32_t{2}).put(std::uint32_t{3}).put(std::int16_t{1});
  body.put(std::uint16_t{2}).put(std::int32_t{0}).put(std::int32_t{1});
  return text + body.bytes();
}

TEST(ReadTin, ReadsBinaryPlyInEitherByteOrder) {
  testing::TempDir dir;
  for (bool big : {false, true}) {
    auto tin = read_tin(write(dir, big ? "big.ply" : "little.ply", binary_quad(big)));
    ASSERT_TRUE(tin.ok()) << tin.error().message;
    ASSERT_EQ(tin->vertices.size(), 4u);
    EXPECT_EQ(tin->vertices[0], (TinVertex{450375.123456, 3042016.654321, 8800}));
    EXPECT_EQ(tin->vertices[2], (TinVertex{450385.5, 3042026.25, 8802}));
    ASSERT_EQ(tin->triangles.size(), 2u);
    EXPECT_EQ(tin->triangles[1], (TinTriangle{0, 2, 3}));
  }
}

TEST(ReadTin, BoundsAndNamesWhatIsWrongInAPlyBody) {
  testing::TempDir dir;
  const std::string good = binary_quad(false);
  const std::size_t body = good.find("end_header\n") + 11;
  auto refused = [&](const std::string& name, const std::string& bytes, const std::string& message) {
    auto tin = read_tin(write(dir, name, bytes));
    ASSERT_FALSE(tin.ok()) << name;
    EXPECT_EQ(tin.error().code, ErrorCode::kDataError) << name;
    EXPECT_NE(tin.error().message.find(name + ": PLY " + message), std::string::npos) << tin.error().message;
  };
  // A face claiming 255 corners, in a file with 30 bytes left: refused
  // before anything is sized from it.
  std::string long_list = good;
  long_list[body + 4 * 25] = static_cast<char>(255);
  refused("long_list.ply", long_list, "face 0 (property vertex_indices): a list of 255 items, more than the file holds");
  // A uint length of about four billion (what fuzz_mesh sent CGAL's reader).
  std::string ascii = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
                      "property float z\nelement face 1\nproperty list uint int vertex_indices\nend_header\n"
                      "0 0 0\n1 0 0\n0 1 0\n";
  refused("four_billion.ply", ascii + "4294967062 0 1 2\n",
          "face 0 (property vertex_indices): a list of 4294967062 items, more than the file holds");
  refused("cut.ply", good.substr(0, good.size() - 11), "ends or has a non-number inside face 1 (property flag)");
  refused("few_bytes.ply", good.substr(0, body + 99), "element vertex claims 4 items, more than the file's remaining 99");
  refused("trailing.ply", good + "xyz", "3 bytes follow the last element");
  refused("word.ply", ascii + "3 0 one 2\n", "ends or has a non-number inside face 0 (property vertex_indices)");
  refused("negative.ply", ascii + "3 0 -1 2\n",
          "face 0 (property vertex_indices): vertex index -1 is not a whole number from 0 to 4294967295");
  refused("no_z.ply", "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nend_header\n1 2\n",
          "header line 3: the vertex element has no property z");
  refused("float_index.ply",
          "ply\nformat ascii 1.0\nelement vertex 0\nproperty float x\nproperty float y\nproperty float z\n"
          "element face 0\nproperty list uchar float vertex_indices\nend_header\n",
          "header line 7: face vertex indices must be an integer type");
  refused("version.ply", "ply\nformat ascii 2.0\nend_header\n", "header line 2: expected 'format");
  refused("keyword.ply", "ply\nformat ascii 1.0\nelemental vertex 1\nend_header\n",
          "header line 3: unknown keyword 'elemental'");
  refused("type.ply", "ply\nformat ascii 1.0\nelement vertex 1\nproperty quad x\nend_header\n",
          "header line 4: unknown property type 'quad'");
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
  EXPECT_NE(empty.error().message.find("empty.obj: not a readable OBJ mesh"),
            std::string::npos)
      << empty.error().message;

  auto garbage = read_tin(write(dir, "garbage.ply", "this is not a ply file\n"));
  ASSERT_FALSE(garbage.ok());
  EXPECT_EQ(garbage.error().code, ErrorCode::kDataError);

  // PLY headers a trusting reader would follow: a property before any
  // element, a count no file of this size can hold.
  auto orphan = read_tin(write(dir, "orphan.ply", "ply\nformat ascii 1.0\nproperty double x\nend_header\n"));
  ASSERT_FALSE(orphan.ok());
  EXPECT_NE(orphan.error().message.find("orphan.ply: PLY header line 3: a property before any element"),
            std::string::npos)
      << orphan.error().message;
  auto huge = read_tin(write(dir, "huge.ply",
                             "ply\nformat binary_little_endian 1.0\nelement vertex 4000000000\nproperty float x\n"
                             "property float y\nproperty float z\n"
                             "end_header\n"));
  ASSERT_FALSE(huge.ok());
  EXPECT_NE(huge.error().message.find("element vertex claims 4000000000 items, more than the file's remaining 0"),
            std::string::npos)
      << huge.error().message;

  auto no_faces = read_tin(write(dir, "no_faces.ply",
                                 "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\n"
                                 "property float z\nend_header\n1 2 3\n"));
  ASSERT_FALSE(no_faces.ok());
  EXPECT_NE(no_faces.error().message.find("no_faces.ply: the file has 1 vertices and 0 faces; a TIN needs both"),
            std::string::npos)
      << no_faces.error().message;

  auto fold = read_tin(write(dir, "fold.obj", "v 0 0 0\nv 2 0 0\nv 1 2 0\nv 1 1 5\nf 1 2 3\nf 1 2 4\n"));
  ASSERT_FALSE(fold.ok());
  EXPECT_EQ(fold.error().code, ErrorCode::kInvalidArgument);
  EXPECT_NE(fold.error().message.find("fold.obj: triangle 0 (vertices 0, 1, 2) and triangle 1"), std::string::npos)
      << fold.error().message;
}

}  // namespace
}  // namespace horizon::mesh
