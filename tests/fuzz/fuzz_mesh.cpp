// libFuzzer target: mesh files (OBJ, PLY text or binary) on arbitrary
// bytes. The first byte picks the extension (read_tin dispatches on it); the
// rest is the file. read_tin must answer an Error or a TIN that passed
// check_height_field, never crash, hang or read out of bounds; a TIN it
// accepts has every triangle counter-clockwise, and its horizons (8
// sectors) are computed when it is small.
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <string>

#include "horizon/mesh/horizons.hpp"
#include "horizon/mesh/tin_io.hpp"
#include "scratch_file.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace horizon::mesh;
  if (size < 1) return 0;
  static const char* const kNames[] = {"mesh.obj", "mesh.ply"};
  const auto written = horizon::fuzz::write_scratch("mesh", kNames[data[0] % 2], data + 1, size - 1);
  if (!written) return 0;
  const std::filesystem::path& path = *written;
  auto tin = read_tin(path.string());
  if (!tin.ok()) return 0;
  for (const TinTriangle& t : tin->triangles)
    if (signed_area(*tin, t) < 0.0) std::abort();  // checked, so never clockwise
  if (tin->vertices.size() <= 2000) (void)compute_horizons(tin->vertices, {8, 1, 1});
  return 0;
}
