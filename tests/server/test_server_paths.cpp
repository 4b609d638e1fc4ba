// What a client sees of the server's file system in an error: paths inside
// data_root relative to it, the scratch directory hidden, no path as a field.
#include <gtest/gtest.h>

#include "call_scope.hpp"

namespace horizon::server {
namespace {

TEST(ServerPaths, ErrorsNameFilesRelativeToTheDataRoot) {
  const Error e = without_server_paths(
      make_error(ErrorCode::kDataError,
                 "dem '/srv/dem/alps/tile_1_1.tif': bad block (block 7: cols 0..9, rows 0..9 of '/srv/dem/alps')",
                 "/srv/dem/alps"),
      "/srv/dem", "/tmp/horizond-abc123");
  EXPECT_EQ(e.message, "dem 'alps/tile_1_1.tif': bad block (block 7: cols 0..9, rows 0..9 of 'alps')");
  EXPECT_EQ(e.field, "dataset");
  EXPECT_EQ(e.code, ErrorCode::kDataError);
}

TEST(ServerPaths, TheRootItselfAndTheScratchDirectoryAreNotShown) {
  const Error root = without_server_paths(make_error(ErrorCode::kIoError, "cannot read '/srv/dem'"), "/srv/dem/", "");
  EXPECT_EQ(root.message, "cannot read '.'");
  const Error scratch = without_server_paths(
      make_error(ErrorCode::kIoError, "geotiff '/tmp/horizond-abc123/horizond-1-0.tif': disk full"), "/srv/dem",
      "/tmp/horizond-abc123");
  EXPECT_EQ(scratch.message, "geotiff '<scratch>/horizond-1-0.tif': disk full");
}

TEST(ServerPaths, MessagesWithoutPathsAndRequestFieldsAreKept) {
  const Error e = without_server_paths(
      make_error(ErrorCode::kInvalidArgument, "options.max_distance: must be > 0", "options.max_distance"), "/srv/dem",
      "/tmp/x");
  EXPECT_EQ(e.message, "options.max_distance: must be > 0");
  EXPECT_EQ(e.field, "options.max_distance");
  // A data root of "/" would strip every leading slash: it is left alone.
  EXPECT_EQ(without_server_paths(make_error(ErrorCode::kIoError, "'/a/b'"), "/", "").message, "'/a/b'");
}

}  // namespace
}  // namespace horizon::server
