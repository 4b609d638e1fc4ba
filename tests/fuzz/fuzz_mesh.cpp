// libFuzzer target: mesh files (OBJ, PLY text or binary) on arbitrary
// bytes. The first byte picks the extension (read_tin dispatches on it); the
// rest is the file. read_tin must answer an Error or a TIN that passed
// check_height_field, never crash, hang or read out of bounds; a TIN it
// accepts has every triangle counter-clockwise, and its horizons (8
// sectors) are computed when it is small.
#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <string>

#include "horizon/mesh/horizons.hpp"
#include "horizon/mesh/tin_io.hpp"

namespace {

const std::filesystem::path& scratch() {
  static const std::filesystem::path dir = [] {
    auto d = std::filesystem::temp_directory_path() / ("horizon-fuzz-mesh-" + std::to_string(::getpid()));
    std::filesystem::create_directories(d);
    return d;
  }();
  return dir;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace horizon::mesh;
  if (size < 1) return 0;
  static const char* const kNames[] = {"mesh.obj", "mesh.ply"};
  const std::filesystem::path path = scratch() / kNames[data[0] % 2];
  if (FILE* f = std::fopen(path.c_str(), "wb")) {
    std::fwrite(data + 1, 1, size - 1, f);
    std::fclose(f);
  } else {
    return 0;
  }
  auto tin = read_tin(path.string());
  if (!tin.ok()) return 0;
  for (const TinTriangle& t : tin->triangles)
    if (!(signed_area(*tin, t) > 0.0) && signed_area(*tin, t) != 0.0) std::abort();  // checked: never clockwise
  if (tin->vertices.size() <= 2000) (void)compute_horizons(tin->vertices, {8, 1, 1});
  return 0;
}
