// Tests for mesh/tin.cpp (check_height_field): hand-built meshes, each
// fault refused with the element named, and the exact boundary cases that
// must pass (triangles touching at a corner or along part of an edge).
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "horizon/mesh/tin.hpp"

namespace horizon::mesh {
namespace {

// The unit square as two counter-clockwise triangles.
Tin square() {
  Tin t;
  t.vertices = {{0, 0, 1}, {1, 0, 2}, {1, 1, 3}, {0, 1, 4}};
  t.triangles = {{0, 1, 2}, {0, 2, 3}};
  return t;
}

std::string refusal(Tin tin) {
  const Status s = check_height_field(tin, "test.obj");
  EXPECT_FALSE(s.ok());
  return s.ok() ? "" : s.error().message;
}

TEST(CheckHeightField, AcceptsASquareAndTurnsClockwiseTrianglesCounterClockwise) {
  Tin t = square();
  t.triangles[1] = {0, 3, 2};  // clockwise seen from above
  ASSERT_TRUE(check_height_field(t, "test.obj").ok());
  EXPECT_EQ(t.triangles[1], (TinTriangle{0, 2, 3}));
  for (const TinTriangle& tri : t.triangles) EXPECT_DOUBLE_EQ(signed_area(t, tri), 0.5);
}

TEST(CheckHeightField, NamesANonFiniteVertex) {
  Tin t = square();
  t.vertices[2].z = std::numeric_limits<double>::quiet_NaN();
  const std::string m = refusal(t);
  EXPECT_NE(m.find("test.obj: vertex 2 has a coordinate that is not a finite number"), std::string::npos) << m;
}

TEST(CheckHeightField, NamesATriangleWithAMissingOrRepeatedVertex) {
  Tin t = square();
  t.triangles[1] = {0, 2, 7};
  EXPECT_NE(refusal(t).find("triangle 1 names vertex 7, but there are 4 vertices"), std::string::npos);
  t.triangles[1] = {0, 2, 2};
  EXPECT_NE(refusal(t).find("triangle 1 (vertices 0, 2, 2) names one vertex twice"), std::string::npos);
}

TEST(CheckHeightField, NamesAnUnusedVertexAndTwoVerticesAtOnePlace) {
  Tin t = square();
  t.vertices.push_back({5, 5, 0});
  EXPECT_NE(refusal(t).find("vertex 4 belongs to no triangle"), std::string::npos);
  t = square();
  t.vertices.push_back({1, 1, 9});  // under vertex 2, another height
  t.vertices.push_back({2, 1, 0});
  t.triangles.push_back({1, 5, 4});
  EXPECT_NE(refusal(t).find("vertices 2 and 4 are both at (x, y) = (1, 1)"), std::string::npos) << refusal(t);
}

TEST(CheckHeightField, NamesATriangleWithNoArea) {
  Tin t;
  t.vertices = {{0, 0, 0}, {1, 1, 0}, {3, 3, 5}};
  t.triangles = {{0, 1, 2}};
  EXPECT_NE(refusal(t).find("triangle 0 (vertices 0, 1, 2) has no area seen from above"), std::string::npos);
  // Off the line by one part in 10^16 of its length: a real (tiny) area,
  // which an exact predicate sees and a rounded one need not.
  t.vertices[2] = {3, std::nextafter(3.0, 4.0), 5};
  EXPECT_TRUE(check_height_field(t, "test.obj").ok());
}

TEST(CheckHeightField, NamesAnEdgeOfThreeTriangles) {
  Tin t;
  t.vertices = {{0, 0, 0}, {2, 0, 0}, {1, 1, 0}, {1, -1, 0}, {1, 3, 0}};
  t.triangles = {{0, 1, 2}, {1, 0, 3}, {0, 1, 4}};
  EXPECT_NE(refusal(t).find("the edge between vertices 0 and 1 belongs to 3 triangles (0, 1, 2)"), std::string::npos);
}

TEST(CheckHeightField, NamesAFoldAcrossASharedEdge) {
  Tin t;
  t.vertices = {{0, 0, 0}, {2, 0, 0}, {1, 2, 0}, {1, 1, 0}};
  t.triangles = {{0, 1, 2}, {0, 1, 3}};  // both above the edge 0-1
  EXPECT_NE(refusal(t).find("lie on the same side of the edge between vertices 0 and 1"), std::string::npos);
}

TEST(CheckHeightField, NamesTrianglesThatOverlapWithoutSharingAnEdge) {
  Tin t;
  t.vertices = {{0, 0, 0}, {2, 0, 0}, {0, 2, 0}, {0.5, 0.5, 1}, {3, 0.5, 1}, {0.5, 3, 1}};
  t.triangles = {{0, 1, 2}, {3, 4, 5}};
  EXPECT_NE(refusal(t).find("triangle 0 (vertices 0, 1, 2) and triangle 1 (vertices 3, 4, 5) overlap"),
            std::string::npos);
  // Sharing a corner, and overlapping beyond it.
  t.vertices = {{0, 0, 0}, {2, 0, 0}, {0, 2, 0}, {2, 2, 0}, {0.5, 0.2, 0}};
  t.triangles = {{0, 1, 2}, {0, 3, 4}};
  EXPECT_NE(refusal(t).find("overlap seen from above"), std::string::npos);
}

TEST(CheckHeightField, AcceptsTrianglesThatOnlyTouch) {
  Tin t;  // a shared corner
  t.vertices = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {2, 0, 0}, {1, 1, 0}};
  t.triangles = {{0, 1, 2}, {1, 3, 4}};
  EXPECT_TRUE(check_height_field(t, "test.obj").ok());
  // A T-junction: the second triangle's top edge lies along part of the first's base.
  t.vertices = {{0, 0, 0}, {2, 0, 0}, {1, 2, 0}, {0.5, 0, 0}, {1.5, 0, 0}, {1, -1, 0}};
  t.triangles = {{0, 1, 2}, {3, 5, 4}};
  EXPECT_TRUE(check_height_field(t, "test.obj").ok());
}

// A 40 x 30 lattice cut into 2 x 39 x 29 triangles, diagonals alternating.
Tin lattice() {
  Tin t;
  const int w = 40, h = 30;
  for (int r = 0; r < h; ++r)
    for (int c = 0; c < w; ++c) t.vertices.push_back({c * 10.0, r * 10.0, std::sin(c * 0.3) * 50 + r});
  auto at = [&](int c, int r) { return static_cast<std::uint32_t>(r * w + c); };
  for (int r = 0; r + 1 < h; ++r)
    for (int c = 0; c + 1 < w; ++c) {
      if ((r + c) % 2) {
        t.triangles.push_back({at(c, r), at(c + 1, r), at(c + 1, r + 1)});
        t.triangles.push_back({at(c, r), at(c + 1, r + 1), at(c, r + 1)});
      } else {
        t.triangles.push_back({at(c, r), at(c + 1, r), at(c, r + 1)});
        t.triangles.push_back({at(c + 1, r), at(c + 1, r + 1), at(c, r + 1)});
      }
    }
  return t;
}

TEST(CheckHeightField, AcceptsALatticeAndRefusesItWithAnyInnerVertexPushedAcrossItsNeighbours) {
  Tin t = lattice();
  ASSERT_TRUE(check_height_field(t, "lattice").ok());
  for (int c : {1, 7, 20, 38})
    for (int r : {1, 13, 28}) {
      Tin moved = lattice();
      moved.vertices[static_cast<std::size_t>(r * 40 + c)].x += 25.0;  // past its right neighbour (10 m on)
      const Status s = check_height_field(moved, "lattice");
      ASSERT_FALSE(s.ok()) << c << ", " << r;
      EXPECT_TRUE(s.error().message.find("overlap") != std::string::npos ||
                  s.error().message.find("no area") != std::string::npos)
          << s.error().message;
    }
}

TEST(CheckHeightField, RefusesAMeshWithNoTriangle) {
  Tin t;
  t.vertices = {{0, 0, 0}};
  EXPECT_NE(refusal(t).find("test.obj: the mesh has no triangle"), std::string::npos);
}

}  // namespace
}  // namespace horizon::mesh
